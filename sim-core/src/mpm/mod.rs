//! MLS-MPM (Hu et al. 2018, "A moving least squares material point method with displacement
//! discontinuity and two-way rigid body coupling") in 3D with quadratic B-splines and APIC
//! transfers (Jiang et al. 2015), on a sparse block grid, explicit in time.
//!
//! One substep: [`binning`] sorts particles into 4³-node blocks; [`p2g`] scatters mass, APIC
//! momentum and stress into per-block scratch; [`grid_update`] sums the scratch in a fixed order,
//! divides by mass, adds gravity and applies colliders; [`g2p`] gathers velocity and its gradient C,
//! updates F = (I + dt C) F, runs the material's return mapping (carrying the plastic part to
//! F_p, [`plastic_flow`]) and advects. Every reduction has a
//! fixed order, so the result is bit-identical for any thread count.

pub mod binning;
pub mod bspline;
pub mod deep_nodes;
pub mod diagnostics;
pub mod g2p;
pub mod grid;
pub mod grid_update;
pub mod multi_field;
pub mod p2g;
pub mod particles;
pub mod plastic_flow;
mod prefetch;
pub mod reach;
pub mod solver;
pub mod system;
pub mod timestep;

pub use diagnostics::Diagnostics;
pub use particles::Particles;
pub use solver::{MpmError, MpmSolver, SubstepInput, SubstepReport};
pub use system::{MpmSystem, SimError};
pub use timestep::{TimeStepError, TimeStepPolicy, cfl_dt_s};
