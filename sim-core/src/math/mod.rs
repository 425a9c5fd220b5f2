//! Small dense linear algebra the solver needs: 3×3 SVD and polar decomposition.
