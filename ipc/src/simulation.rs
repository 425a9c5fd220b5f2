//! The interface between the server and whatever it simulates.
//!
//! The server ([`crate::server`]) is generic over [`Simulation`]; sim-core's `World` implements
//! it, and [`crate::fake::FreeFall`] is a small stand-in for tests. The server loans shared
//! memory and the simulation writes its output straight into it: no intermediate buffers.
//!
//! A failing step never ends the server: it restores the checkpoint the simulation keeps of the
//! last published frame, pauses, and reports the failure ([`crate::wire::STATUS_FAILED`]).

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

/// Why [`Simulation::advance`] did not complete a frame.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimulationError {
    /// The state became invalid (non-finite, unstable). The server restores the last
    /// checkpoint ([`Simulation::restore_checkpoint`]), pauses and reports it.
    #[error("simulation failed at step {step}: {reason}")]
    Failed {
        /// Step being computed.
        step: u64,
        /// What happened.
        reason: String,
    },
    /// The progress callback asked to stop mid-frame (a signal or a stop flag).
    #[error("step {step} interrupted")]
    Interrupted {
        /// Step being computed.
        step: u64,
    },
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
    /// Advances by one published frame, calling `keep_going` after every substep (the server
    /// counts progress there and looks for a stop); when it returns `false`, return
    /// [`SimulationError::Interrupted`] at once.
    ///
    /// # Errors
    /// [`SimulationError::Failed`] when the state became invalid (the state may then be
    /// anything; the server restores the checkpoint); [`SimulationError::Interrupted`].
    fn advance(&mut self, keep_going: &mut dyn FnMut() -> bool)
    -> Result<Advance, SimulationError>;
    /// Saves the current state as the last good one. The server calls it after every published
    /// frame and after every new scene generation.
    fn checkpoint(&mut self) {}
    /// Goes back to the last [`Simulation::checkpoint`]; `false` when there is none (the server
    /// then stops with the failure).
    fn restore_checkpoint(&mut self) -> bool {
        false
    }
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
    fn advance(
        &mut self,
        keep_going: &mut dyn FnMut() -> bool,
    ) -> Result<Advance, SimulationError> {
        (**self).advance(keep_going)
    }
    fn checkpoint(&mut self) {
        (**self).checkpoint();
    }
    fn restore_checkpoint(&mut self) -> bool {
        (**self).restore_checkpoint()
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
