//! Small dense linear algebra the solver needs: 3×3 SVD and polar decomposition, and four 3×3
//! matrices per SIMD lane for the four-lane stress.

pub mod mat3x4;
pub mod newton_polar;
pub mod svd;

pub use mat3x4::Mat3x4;
pub use newton_polar::{polar_rotation, polar_rotation_x4};
pub use svd::{Polar, Svd3, polar, svd3};
