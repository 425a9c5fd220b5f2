//! MLS-MPM on the GPU: splatphys-core's P2G, grid update and G2P as WGSL compute shaders run
//! through wgpu (Vulkan, Metal or DirectX 12), for a self-contained particle system
//! ([`splatphys_core::mpm::MpmSystem`]: particles, materials, grid colliders, gravity).
//!
//! - [`context`]: finding an adapter and opening a device ([`GpuContext`]); no adapter is an
//!   error the caller reports ([`GpuError::NoAdapter`]), never a panic;
//! - [`backend`]: [`GpuBackend`], the GPU as the device a `World` runs deformable objects' MPM
//!   on (`splatphys_core::world::device`: an object steps there while only grid colliders can
//!   reach it);
//! - [`mpm`]: [`GpuMpm`], the particles kept on the GPU between substeps, read back when asked;
//!   what the COM layer needs of them (mass, COM, momentum, angular momentum, inertia, bounds,
//!   largest speed: [`GpuMpm::moments`]; each collider's normal and friction impulse:
//!   [`GpuMpm::collider_contacts`]) summed on the GPU, and the rigid velocity field its laws
//!   add ([`GpuMpm::rigid_field`]) applied there.
//!
//! What runs on the GPU: every material model of splatphys-core with its Kelvin–Voigt damping
//! (fixed-corotated "jelly", neo-Hookean, and the plastic models with their return mappings and
//! the plastic deformation F_p their Gaussians follow: snow, sand, metal, plasticine, foam; the
//! SVD they need is the CPU's one-sided Jacobi, `plastic.wgsl`); plane, box and domain-bound
//! colliders, static or moving within an active window, with the sticky, slip and separate rules
//! and Coulomb friction, with the CPU's gap check (a plane or box that lets material leave takes
//! its rule only at nodes where material reaches it, `splatphys_core::mpm::reach`, and the
//! nodes behind a box thinner than three cells hold the material on its near side, for every
//! rule), on a dense grid over the domain bound. What does not (and is refused with [`GpuError::Unsupported`],
//! naming it, so the caller can stay on the CPU): a system without a domain bound.
//!
//! P2G adds into fixed-point sums of two 32-bit words that need no carry (each term's part
//! below 2^16, rounded up or down by a dither hashed from the particle, the node and the
//! substep, and the rest), so no atomic waits for its old value and a node's sum does not depend
//! on the order particles arrive in: a run gives the same bits on the same device every time.
//! [`GpuMpm::profile`] times each kernel.

pub mod backend;
pub mod context;
pub mod mpm;

pub use backend::GpuBackend;
pub use context::GpuContext;
pub use mpm::{ColliderSums, GpuMpm, Profile, RoundTrip};

/// What can go wrong on the GPU path.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No GPU (or software Vulkan) adapter was found.
    #[error(
        "no GPU adapter found (wgpu looked for Vulkan, Metal or DirectX 12; on Linux without a GPU, install Mesa's lavapipe: apt install mesa-vulkan-drivers)"
    )]
    NoAdapter,
    /// The adapter refused the device.
    #[error("opening the GPU device on {adapter}: {message}")]
    Device {
        /// The adapter's name.
        adapter: String,
        /// wgpu's message.
        message: String,
    },
    /// The system uses something the GPU path does not run.
    #[error("not on the GPU yet: {what}")]
    Unsupported {
        /// What, in words.
        what: String,
    },
    /// A substep failed on the GPU: a particle left the grid or a value was not finite.
    #[error(
        "GPU substep {substep}: {count} particle or node updates failed (left the grid or not finite; first particle {first:?})"
    )]
    Failed {
        /// Substep index.
        substep: u64,
        /// Failed updates.
        count: u32,
        /// The highest-numbered failed particle, if a particle failed.
        first: Option<u32>,
    },
    /// Reading results back failed.
    #[error("reading back from the GPU: {0}")]
    Readback(String),
}
