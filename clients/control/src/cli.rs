//! The `splatphys-control` command line (clap), in the library so tests parse the commands the
//! docs show and `docs/reference/cli/` is generated from it.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

use crate::action::{ObjectRef, parse_floats, parse_vec3};

/// Environment variable giving the default service prefix.
pub const PREFIX_ENV: &str = "SPLATPHYS_PREFIX";

/// The examples after `--help`.
pub const EXAMPLES: &str = "\
Examples:
  splatphys-control --prefix splatphys/vase impulse --object donut --vector 0,0,2
  splatphys-control --prefix splatphys/vase impulse --object 1 --vector=-1,0,0 --point 0.1,0,0.5
  splatphys-control --prefix splatphys/vase set-velocity --object donut --vector 0,0,0
  splatphys-control --prefix splatphys/vase set-velocity --object finger --vector 0.1,0,0 --angular 0,0,1
  splatphys-control --prefix splatphys/vase set-pose --object finger --position 0.2,0,0.05 --orientation 1,0,0,0 --at-step 30
  splatphys-control --prefix splatphys/vase edit-material --object donut --model snow --youngs-modulus-pa 1.4e5 --poisson-ratio 0.2
  splatphys-control --prefix splatphys/vase set-kind --object donut --kind rigid
  splatphys-control --prefix splatphys/vase pause
  splatphys-control --prefix splatphys/vase step 10
  splatphys-control --prefix splatphys/vase timeline push.toml
  splatphys-control --prefix splatphys/vase follow --object donut --target 0,0,0.5 --duration-s 5

Objects are named (as in the scene) or numbered (3 or #3). The prefix can also come from
SPLATPHYS_PREFIX. Exit status: 0 accepted, 1 rejected or bad input, 2 server not found,
gone or silent.";

/// Send commands to a running splatphys server: one-shot, from a timeline, or closed-loop.
#[derive(Parser, Debug)]
#[command(version, about, after_help = EXAMPLES)]
pub struct Cli {
    /// Service prefix of the server (default: $SPLATPHYS_PREFIX).
    #[arg(long, global = true)]
    pub prefix: Option<String>,
    /// How long to wait for the server to appear, milliseconds.
    #[arg(long, global = true, default_value_t = 5000)]
    pub connect_timeout_ms: u64,
    /// How long to wait for a reply, milliseconds.
    #[arg(long, global = true, default_value_t = 2000)]
    pub reply_timeout_ms: u64,
    /// Print JSON lines instead of text.
    #[arg(long, global = true)]
    pub json: bool,
    /// The subcommand.
    #[command(subcommand)]
    pub command: Cmd,
}

/// The object a command acts on.
#[derive(Args, Debug)]
pub struct ObjectArg {
    /// Object name (from the scene) or id (3 or #3).
    #[arg(long)]
    pub object: ObjectRef,
}

/// The subcommands.
#[derive(Subcommand, Debug)]
pub enum Cmd {
    /// Apply an impulse (N·s, world frame) to an object, at its COM or at a point.
    Impulse {
        /// The object it acts on.
        #[command(flatten)]
        object: ObjectArg,
        /// Impulse x,y,z in N·s (e.g. 0,0,2; write --vector=-1,0,0 for a leading minus).
        #[arg(long, value_parser = vec3, allow_hyphen_values = true)]
        vector: [f64; 3],
        /// Point of application x,y,z in world metres (default: centre of mass).
        #[arg(long, value_parser = vec3, allow_hyphen_values = true)]
        point: Option<[f64; 3]>,
    },
    /// Set an object's COM velocity (m/s, world frame) and optionally its angular velocity; a
    /// kinematic object keeps them until its next command.
    SetVelocity {
        /// The object it acts on.
        #[command(flatten)]
        object: ObjectArg,
        /// Velocity x,y,z in m/s.
        #[arg(long, alias = "velocity", value_parser = vec3, allow_hyphen_values = true)]
        vector: [f64; 3],
        /// Angular velocity x,y,z in rad/s about the COM (default: unchanged).
        #[arg(long, value_parser = vec3, allow_hyphen_values = true)]
        angular: Option<[f64; 3]>,
    },
    /// Drive a kinematic object to a pose (COM position, orientation relative to its rest
    /// pose), reached at the end of a step.
    SetPose {
        /// The object it acts on.
        #[command(flatten)]
        object: ObjectArg,
        /// COM position x,y,z in world metres.
        #[arg(long, value_parser = vec3, allow_hyphen_values = true)]
        position: [f64; 3],
        /// Orientation w,x,y,z relative to the rest pose.
        #[arg(long, value_parser = quat, allow_hyphen_values = true, default_value = "1,0,0,0")]
        orientation: [f64; 4],
        /// The step at whose end the pose is reached (default: the end of the current step).
        #[arg(long)]
        at_step: Option<u64>,
    },
    /// Edit an object's material; unspecified fields keep their value.
    EditMaterial {
        /// The object it acts on.
        #[command(flatten)]
        object: ObjectArg,
        /// Model: jelly, fixed-corotated, neo-hookean, snow, sand, metal, plasticine, foam.
        #[arg(long)]
        model: Option<String>,
        /// Young's modulus E, pascals (> 0).
        #[arg(long, alias = "e")]
        youngs_modulus_pa: Option<f64>,
        /// Poisson ratio nu, in (-1, 0.5).
        #[arg(long, alias = "nu", allow_hyphen_values = true)]
        poisson_ratio: Option<f64>,
        /// Density, kg/m³ (> 0).
        #[arg(long, alias = "density")]
        density_kg_m3: Option<f64>,
        /// Coefficient of restitution e, in [0, 1].
        #[arg(long)]
        restitution: Option<f64>,
        /// Coulomb friction coefficient (>= 0).
        #[arg(long)]
        friction: Option<f64>,
    },
    /// Change how an object moves: deformable, rigid, static or kinematic.
    SetKind {
        /// The object it acts on.
        #[command(flatten)]
        object: ObjectArg,
        /// deformable, rigid, static or kinematic.
        #[arg(long)]
        kind: String,
    },
    /// Pause stepping (frames and status keep flowing).
    Pause,
    /// Resume stepping.
    Resume,
    /// While paused, advance N frames.
    Step {
        /// Frames to advance (>= 1).
        count: u64,
    },
    /// Reset the scene to its initial state.
    Reset,
    /// Ask the server to shut down cleanly.
    Shutdown,
    /// Send the commands of a TOML timeline at their simulated times.
    Timeline {
        /// Timeline file (see `splatphys_control::timeline` or docs/reference/protocol.md).
        file: PathBuf,
        /// Event times count from the server's simulated time when the timeline starts
        /// (default: absolute simulated time).
        #[arg(long)]
        relative: bool,
    },
    /// Push an object's COM to a target with a PD controller; prints loop latency at the end.
    Follow {
        /// The object it acts on.
        #[command(flatten)]
        object: ObjectArg,
        /// Target COM x,y,z in world metres.
        #[arg(long, value_parser = vec3, allow_hyphen_values = true)]
        target: [f64; 3],
        /// Proportional gain, 1/s².
        #[arg(long, default_value_t = 20.0)]
        kp: f64,
        /// Derivative gain, 1/s.
        #[arg(long, default_value_t = 9.0)]
        kd: f64,
        /// Gravity to compensate x,y,z in m/s² (0,0,0 disables compensation).
        #[arg(long, value_parser = vec3, allow_hyphen_values = true, default_value = "0,0,-9.81")]
        gravity: [f64; 3],
        /// Largest impulse per command, N·s.
        #[arg(long, default_value_t = 5.0)]
        max_impulse: f64,
        /// Largest approach speed asked for, m/s.
        #[arg(long, default_value_t = 2.0)]
        max_speed: f64,
        /// Run for this long (wall clock), seconds.
        #[arg(long, default_value_t = 10.0)]
        duration_s: f64,
        /// Stop early once within this distance of the target for 0.5 s of simulated time, m.
        #[arg(long)]
        tolerance_m: Option<f64>,
        /// Print every control update.
        #[arg(long)]
        verbose: bool,
    },
}
/// Parses `x,y,z` (clap value parser).
pub fn vec3(s: &str) -> Result<[f64; 3], String> {
    parse_vec3(s).map_err(|e| e.to_string())
}

/// Parses `w,x,y,z` (clap value parser).
pub fn quat(s: &str) -> Result<[f64; 4], String> {
    parse_floats(s).map_err(|e| e.to_string())
}
