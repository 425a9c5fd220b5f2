//! The command vocabulary: what a scene `[[event]]`, a control timeline entry and a wire command
//! all are once parsed.

use crate::{MaterialEdit, ObjectKind};

/// A command to a running simulation.
///
/// `O` names the target object: `u32` ids on the wire and inside the simulation, names (or
/// name-or-id references) in scene files and timelines ([`Command::map_object`] resolves one
/// into the other). Scene files and timelines write commands the same way, as
/// [`CommandToml`](crate::CommandToml) tables.
#[derive(Debug, Clone, PartialEq)]
pub enum Command<O = u32> {
    /// Apply an impulse (N·s, world frame) to an object, at a point (m, world) or at its COM.
    Impulse {
        /// Target object.
        object: O,
        /// Impulse, N·s.
        impulse_n_s: [f64; 3],
        /// Point of application, metres; `None` = centre of mass.
        point_m: Option<[f64; 3]>,
    },
    /// Set an object's COM velocity, m/s, and optionally its angular velocity, rad/s (unchanged
    /// when `None`). A kinematic object keeps moving at these velocities until the next command.
    SetVelocity {
        /// Target object.
        object: O,
        /// Velocity, m/s.
        velocity_m_s: [f64; 3],
        /// Angular velocity about the COM, rad/s, world frame.
        angular_velocity_rad_s: Option<[f64; 3]>,
    },
    /// Drive a kinematic object to a pose: its COM reaches `position_m` and its orientation
    /// (relative to its rest pose, as `objects` publishes it) reaches `orientation_wxyz` at the
    /// end of step `at_step`, moving at constant linear and angular velocity from where it is
    /// (interpolated over the substeps); it then holds still. `None`, or a step already begun:
    /// the end of the current step.
    SetPose {
        /// Target object (kinematic).
        object: O,
        /// COM position, m, world frame.
        position_m: [f64; 3],
        /// Orientation (w, x, y, z) relative to the rest pose; normalised on arrival.
        orientation_wxyz: [f64; 4],
        /// The step at whose end the pose is reached.
        at_step: Option<u64>,
    },
    /// Edit an object's material; only the fields named change.
    EditMaterial {
        /// Target object.
        object: O,
        /// The fields to change.
        edit: MaterialEdit,
    },
    /// Change how an object moves.
    SetKind {
        /// Target object.
        object: O,
        /// New kind.
        kind: ObjectKind,
    },
    /// Stop stepping (frames and status keep flowing).
    Pause,
    /// Resume stepping.
    Resume,
    /// While paused, advance this many published frames (>= 1).
    Step {
        /// Frames to advance.
        count: u64,
    },
    /// Reset the scene to its initial state (bumps the scene generation).
    Reset,
    /// Ask the server to shut down cleanly.
    Shutdown,
}

impl<O> Command<O> {
    /// The object this command targets, if any.
    pub fn object(&self) -> Option<&O> {
        match self {
            Self::Impulse { object, .. }
            | Self::SetVelocity { object, .. }
            | Self::SetPose { object, .. }
            | Self::EditMaterial { object, .. }
            | Self::SetKind { object, .. } => Some(object),
            _ => None,
        }
    }

    /// The command's name as written in TOML and on the command line (`impulse`,
    /// `set-velocity`, `set-pose`, `edit-material`, `set-kind`, `pause`, `resume`, `step`, `reset`,
    /// `shutdown`).
    pub fn name(&self) -> &'static str {
        match self {
            Self::Impulse { .. } => "impulse",
            Self::SetVelocity { .. } => "set-velocity",
            Self::SetPose { .. } => "set-pose",
            Self::EditMaterial { .. } => "edit-material",
            Self::SetKind { .. } => "set-kind",
            Self::Pause => "pause",
            Self::Resume => "resume",
            Self::Step { .. } => "step",
            Self::Reset => "reset",
            Self::Shutdown => "shutdown",
        }
    }

    /// The same command with its target mapped by `f` (e.g. a name resolved to an id).
    ///
    /// # Errors
    /// Whatever `f` returns for the target.
    pub fn map_object<P, E>(self, f: impl FnOnce(O) -> Result<P, E>) -> Result<Command<P>, E> {
        Ok(match self {
            Self::Impulse {
                object,
                impulse_n_s,
                point_m,
            } => Command::Impulse {
                object: f(object)?,
                impulse_n_s,
                point_m,
            },
            Self::SetVelocity {
                object,
                velocity_m_s,
                angular_velocity_rad_s,
            } => Command::SetVelocity {
                object: f(object)?,
                velocity_m_s,
                angular_velocity_rad_s,
            },
            Self::SetPose {
                object,
                position_m,
                orientation_wxyz,
                at_step,
            } => Command::SetPose {
                object: f(object)?,
                position_m,
                orientation_wxyz,
                at_step,
            },
            Self::EditMaterial { object, edit } => Command::EditMaterial {
                object: f(object)?,
                edit,
            },
            Self::SetKind { object, kind } => Command::SetKind {
                object: f(object)?,
                kind,
            },
            Self::Pause => Command::Pause,
            Self::Resume => Command::Resume,
            Self::Step { count } => Command::Step { count },
            Self::Reset => Command::Reset,
            Self::Shutdown => Command::Shutdown,
        })
    }
}
