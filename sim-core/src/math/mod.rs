//! Small dense linear algebra the solver needs: 3×3 SVD and polar decomposition.

pub mod svd;

pub use svd::{Polar, Svd3, polar, svd3};
