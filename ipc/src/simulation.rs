//! The interface between the server and whatever it simulates.
//!
//! The server ([`crate::server`]) is generic over [`Simulation`]; sim-core's `World` implements
//! it, and [`crate::fake::FreeFall`] is a small stand-in for tests. The server loans shared
//! memory and the simulation writes its output straight into it: no intermediate buffers.

use crate::command::Command;
use crate::wire::{FrameGaussian, ObjectState, SceneGaussian};

/// What one call of [`Simulation::advance`] did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Advance {
    /// Simulation steps done (usually 1 per published frame).
    pub steps: u64,
    /// MPM substeps done.
    pub substeps: u64,
    /// Simulated time after the advance, seconds.
    pub time_s: f64,
}

/// A simulation failure (e.g. a NaN blow-up); the server reports it and stops.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("simulation failed at step {step}: {reason}")]
pub struct SimulationError {
    /// Step at which it failed.
    pub step: u64,
    /// What happened.
    pub reason: String,
}

/// A world the server can publish.
///
/// Counts are fixed between [`Simulation::scene_generation`] changes; the server re-reads them
/// (and republishes the scene) whenever the generation changes.
pub trait Simulation {
    /// Scene name (used in the default service prefix `splatphys/<name>`).
    fn scene_name(&self) -> &str;
    /// Current scene generation; bump it on reset or on any change of the published counts.
    fn scene_generation(&self) -> u32;
    /// Published (visible) Gaussians; fill particles are not counted.
    fn gaussian_count(&self) -> usize;
    /// Objects in the scene; object ids are `0..object_count`.
    fn object_count(&self) -> usize;
    /// Name of object `id` (`None` if out of range).
    fn object_name(&self, id: u32) -> Option<&str>;
    /// SH degree of the scene (0..=3).
    fn sh_degree(&self) -> u32;
    /// Simulated time between two published frames, seconds.
    fn frame_dt_s(&self) -> f64;
    /// Current step index.
    fn step(&self) -> u64;
    /// Current simulated time, seconds.
    fn time_s(&self) -> f64;
    /// Substeps done since the start or the last reset.
    fn substeps(&self) -> u64;
    /// Writes the static data of every published Gaussian; `out.len() == gaussian_count()`.
    fn write_scene(&self, out: &mut [SceneGaussian]);
    /// Advances by one published frame.
    ///
    /// # Errors
    /// [`SimulationError`] when the state became invalid; the server stops publishing.
    fn advance(&mut self) -> Result<Advance, SimulationError>;
    /// Writes the dynamic state of every published Gaussian straight into the loaned
    /// shared-memory slice; `out.len() == gaussian_count()`. The slice holds stale data on entry
    /// (an older frame or zeros): every element must be overwritten.
    fn write_frame(&self, out: &mut [FrameGaussian]);
    /// Writes every object's state; `out.len() == object_count()`.
    fn write_objects(&self, out: &mut [ObjectState]);
    /// Applies an already validated command (not `Pause`/`Resume`/`Step`/`Shutdown`, which the
    /// server handles) and returns the step at which it takes effect.
    ///
    /// # Errors
    /// A reason when the simulation refuses it (e.g. a static object cannot be pushed).
    fn apply(&mut self, command: &Command) -> Result<u64, String>;
    /// Whether the simulation reached its configured end.
    fn is_finished(&self) -> bool;
}

/// A boxed simulation is a simulation (what lets an application hand the server a
/// `Box<dyn Simulation + Send>` it chose at run time).
impl<S: Simulation + ?Sized> Simulation for Box<S> {
    fn scene_name(&self) -> &str {
        (**self).scene_name()
    }
    fn scene_generation(&self) -> u32 {
        (**self).scene_generation()
    }
    fn gaussian_count(&self) -> usize {
        (**self).gaussian_count()
    }
    fn object_count(&self) -> usize {
        (**self).object_count()
    }
    fn object_name(&self, id: u32) -> Option<&str> {
        (**self).object_name(id)
    }
    fn sh_degree(&self) -> u32 {
        (**self).sh_degree()
    }
    fn frame_dt_s(&self) -> f64 {
        (**self).frame_dt_s()
    }
    fn step(&self) -> u64 {
        (**self).step()
    }
    fn time_s(&self) -> f64 {
        (**self).time_s()
    }
    fn substeps(&self) -> u64 {
        (**self).substeps()
    }
    fn write_scene(&self, out: &mut [SceneGaussian]) {
        (**self).write_scene(out);
    }
    fn advance(&mut self) -> Result<Advance, SimulationError> {
        (**self).advance()
    }
    fn write_frame(&self, out: &mut [FrameGaussian]) {
        (**self).write_frame(out);
    }
    fn write_objects(&self, out: &mut [ObjectState]) {
        (**self).write_objects(out);
    }
    fn apply(&mut self, command: &Command) -> Result<u64, String> {
        (**self).apply(command)
    }
    fn is_finished(&self) -> bool {
        (**self).is_finished()
    }
}
