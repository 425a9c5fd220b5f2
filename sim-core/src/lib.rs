//! splatphys-core: captured 3D Gaussian Splatting scenes made physical.
//!
//! The pipeline reads as the module tree: [`formats`] (3DGS files) -> [`scene`] (the scene file,
//! sources, objects) -> [`selection`] (stage 1: which Gaussians form which object) -> [`mpm`]
//! (MLS-MPM, per object or shared) with [`material`] and [`collider`] -> [`world`] (the COM object
//! layer, stage 2) -> [`kinematics`] (particle state back to Gaussians).

mod clone_reusing;
pub mod collider;
pub mod contact;
pub mod fill;
pub mod kinematics;
pub mod material;
pub mod math;
pub mod mpm;
pub mod procedural;
pub mod scene;
pub mod selection;
pub mod world;

pub use splatphys_formats as formats;
pub use splatphys_formats::gaussians;

/// What a program that builds and steps a scene in-process uses, in one import:
/// `use splatphys_core::prelude::*;` (the runnable example is `cargo run --release -p
/// splatphys-core --example step_scene`).
pub mod prelude {
    pub use crate::contact::{ContactSolver, SurfaceContact};
    pub use crate::formats::read_gaussians;
    pub use crate::gaussians::GaussianCloud;
    pub use crate::kinematics::GaussianState;
    pub use crate::scene::{
        ColliderSpec, Command, EventSpec, MaterialSpec, Method, ObjectBuilder, ObjectKind, Scene,
        SceneBuilder, SceneError, SceneObject, Surface, load_scene,
    };
    pub use crate::world::{ObjectSummary, World, WorldError};
}
