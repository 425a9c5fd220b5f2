//! Contact between objects, the captured background and grid colliders.
//!
//! Which mechanism handles which pair, so that nothing is pushed twice (docs/design/com-layer.md):
//!
//! | pair | mechanism |
//! |---|---|
//! | deformable – static, rigid, background, collider | boundary nodes on the deformable's grid ([`boundary`]; colliders in the grid update); a rigid object gets the reaction; with `surface_contact = "barrier"`, "separate" colliders, static and kinematic objects (procedural or captured) and the background first push the touching particles ([`barrier`]) |
//! | rigid – rigid, static, background, collider | the contact solver ([`solver`]) on manifolds ([`manifold`]) |
//! | deformable – deformable | one COM-level impulse per pair and substep with the restitution law (the paper's stage 2; `world::deformable_pair`) |
//!
//! Surfaces are [`geometry::Geometry`]: an analytic signed distance for procedural shapes, a
//! [`level_set::LevelSet`] built from particles or opaque Gaussians otherwise.
//!
//! Pair coefficients (one rule everywhere): friction μ = √(μ_A μ_B), restitution
//! e = max(e_A, e_B) (Box2D's mixing rules), rolling resistance b = max(b_A, b_B). Grid
//! colliders and the captured background have a friction coefficient and no restitution or
//! rolling resistance of their own (the object's applies); a sticky collider acts on a rigid
//! object as friction [`STICKY_FRICTION`] (as on deformable material, `collider::surface`), and
//! so does a clamp (the rigid solver has no glue).

pub mod barrier;
pub mod block;
pub mod boundary;
pub mod coupling;
pub mod crossing;
pub mod energy;
pub mod exact;
pub mod geometry;
pub mod grid_coupling;
pub mod level_set;
pub mod manifold;
mod obstacle_gaps;
pub mod patch;
pub mod rows;
pub mod settings;
pub mod soft_step;
pub mod solver;

pub use geometry::{Collision, Geometry, Pose};
pub use level_set::LevelSet;
pub use rows::{ContactPoint, SolverBody};
pub use settings::{ContactSolver, SolverSettings, SurfaceContact};

/// The friction μ a sticky collider has against a solid: large, far above any real pair, but
/// finite, so its grip is bounded by μ times the normal impulse like any friction: nothing
/// grips without a normal impulse, and a kinematic body pushing a box that a sticky surface
/// holds has a solution (the box slides) instead of a contradiction between two infinite
/// masses.
pub const STICKY_FRICTION: f64 = 10.0;

/// Pair friction μ = √(μ_A μ_B).
pub fn mix_friction(a: f32, b: f32) -> f32 {
    (a.max(0.0) * b.max(0.0)).sqrt()
}

/// Pair restitution e = max(e_A, e_B).
pub fn mix_restitution(a: f32, b: f32) -> f32 {
    a.max(b).clamp(0.0, 1.0)
}
