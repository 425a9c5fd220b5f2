//! splatphys-core: captured 3D Gaussian Splatting scenes made physical.
//!
//! The pipeline reads as the module tree: [`formats`] (3DGS files) -> [`scene`] (the scene file,
//! sources, objects) -> [`selection`] (stage 1: which Gaussians form which object) -> [`mpm`]
//! (MLS-MPM, per object or shared) with [`material`] and [`collider`] -> [`world`] (the COM object
//! layer, stage 2) -> [`kinematics`] (particle state back to Gaussians).

pub mod gaussians;
pub mod math;
pub mod formats;
pub mod procedural;
pub mod selection;
pub mod scene;
pub mod fill;
pub mod collider;
pub mod material;
pub mod mpm;
