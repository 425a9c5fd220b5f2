//! Small dense linear algebra the solver needs: 3×3 SVD and polar decomposition.

pub mod newton_polar;
pub mod svd;

pub use newton_polar::polar_rotation;
pub use svd::{Polar, Svd3, polar, svd3};
