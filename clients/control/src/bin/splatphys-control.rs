//! `splatphys-control`: send commands to a running splatphys server from the shell.
//!
//! Exit status: 0 when every command was accepted, 1 when one was rejected or the input is
//! invalid, 2 when the server is not found, gone, or does not reply.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::Result;
use clap::{Args, Parser, Subcommand};
use splatphys_control::action::{
    Action, ObjectRef, parse_floats, parse_kind, parse_model, parse_vec3,
};
use splatphys_control::follow::{FollowConfig, FollowStop, follow};
use splatphys_control::session::{describe_reply, reply_json};
use splatphys_control::timeline::{load_timeline, run_timeline};
use splatphys_control::{ControlError, Session, SessionOptions};
use splatphys_ipc::IpcError;
use splatphys_ipc::command::{MaterialEdit, Reply};

/// Environment variable giving the default service prefix.
const PREFIX_ENV: &str = "SPLATPHYS_PREFIX";

const EXAMPLES: &str = "\
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
struct Cli {
    /// Service prefix of the server (default: $SPLATPHYS_PREFIX).
    #[arg(long, global = true)]
    prefix: Option<String>,
    /// How long to wait for the server to appear, milliseconds.
    #[arg(long, global = true, default_value_t = 5000)]
    connect_timeout_ms: u64,
    /// How long to wait for a reply, milliseconds.
    #[arg(long, global = true, default_value_t = 2000)]
    reply_timeout_ms: u64,
    /// Print JSON lines instead of text.
    #[arg(long, global = true)]
    json: bool,
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Args, Debug)]
struct ObjectArg {
    /// Object name (from the scene) or id (3 or #3).
    #[arg(long)]
    object: ObjectRef,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// Apply an impulse (N·s, world frame) to an object, at its COM or at a point.
    Impulse {
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

fn vec3(s: &str) -> Result<[f64; 3], String> {
    parse_vec3(s).map_err(|e| e.to_string())
}

fn quat(s: &str) -> Result<[f64; 4], String> {
    parse_floats(s).map_err(|e| e.to_string())
}

/// Exit status for an error: 2 for connection trouble, 1 otherwise.
fn exit_code(e: &ControlError) -> i32 {
    if e.is_connection() { 2 } else { 1 }
}

fn one_shot_action(cmd: &Cmd) -> Result<Option<Action>, ControlError> {
    Ok(Some(match cmd {
        Cmd::Impulse {
            object,
            vector,
            point,
        } => Action::Impulse {
            object: object.object.clone(),
            impulse_n_s: *vector,
            point_m: *point,
        },
        Cmd::SetVelocity {
            object,
            vector,
            angular,
        } => Action::SetVelocity {
            object: object.object.clone(),
            velocity_m_s: *vector,
            angular_velocity_rad_s: *angular,
        },
        Cmd::SetPose {
            object,
            position,
            orientation,
            at_step,
        } => Action::SetPose {
            object: object.object.clone(),
            position_m: *position,
            orientation_wxyz: *orientation,
            at_step: *at_step,
        },
        Cmd::EditMaterial {
            object,
            model,
            youngs_modulus_pa,
            poisson_ratio,
            density_kg_m3,
            restitution,
            friction,
        } => Action::EditMaterial {
            object: object.object.clone(),
            edit: MaterialEdit {
                model: model.as_deref().map(parse_model).transpose()?,
                youngs_modulus_pa: *youngs_modulus_pa,
                poisson_ratio: *poisson_ratio,
                density_kg_m3: *density_kg_m3,
                restitution: *restitution,
                friction: *friction,
            },
        },
        Cmd::SetKind { object, kind } => Action::SetKind {
            object: object.object.clone(),
            kind: parse_kind(kind)?,
        },
        Cmd::Pause => Action::Pause,
        Cmd::Resume => Action::Resume,
        Cmd::Step { count } => Action::Step { count: *count },
        Cmd::Reset => Action::Reset,
        Cmd::Shutdown => Action::Shutdown,
        Cmd::Timeline { .. } | Cmd::Follow { .. } => return Ok(None),
    }))
}

fn run(cli: &Cli) -> Result<i32, ControlError> {
    let prefix = cli
        .prefix
        .clone()
        .or_else(|| std::env::var(PREFIX_ENV).ok())
        .ok_or_else(|| ControlError::UnknownName {
            what: "service prefix",
            input: String::new(),
            expected: "pass --prefix P or set SPLATPHYS_PREFIX".into(),
        })?;
    let mut opts = SessionOptions::new(&prefix);
    opts.connect_timeout = Duration::from_millis(cli.connect_timeout_ms);
    opts.reply_timeout = Duration::from_millis(cli.reply_timeout_ms);
    // Validate the input before connecting.
    let action = one_shot_action(&cli.command)?;
    let timeline = match &cli.command {
        Cmd::Timeline { file, .. } => Some(load_timeline(file)?),
        _ => None,
    };
    opts.objects = matches!(cli.command, Cmd::Timeline { .. } | Cmd::Follow { .. });
    let mut session = Session::connect(&opts)?;

    if let Some(action) = action {
        let cmd = session.command_for(&action)?;
        let reply = session.connection().command(&cmd, opts.reply_timeout)?;
        print_reply(cli.json, action.name(), cmd.object().copied(), &reply);
        return Ok(if matches!(reply, Reply::Accepted { .. }) {
            0
        } else {
            1
        });
    }
    if let Some(events) = timeline {
        let json = cli.json;
        let relative = matches!(cli.command, Cmd::Timeline { relative: true, .. });
        let report = run_timeline(&mut session, &events, relative, |o| {
            let object = o.object.map_or(String::new(), |id| format!(" #{id}"));
            match (&o.reply, json) {
                (Ok(r), true) => {
                    let mut v = reply_json(r);
                    v["event"] = o.index.into();
                    v["at_s"] = o.at_s.into();
                    v["sent_at_s"] = o.sent_at_s.into();
                    v["command"] = o.command.into();
                    v["object"] = o.object.into();
                    println!("{v}");
                }
                (Ok(r), false) => println!(
                    "t = {:.3} s (server {:.3} s): {}{object}: {}",
                    o.at_s,
                    o.sent_at_s,
                    o.command,
                    describe_reply(r)
                ),
                (Err(e), true) => println!(
                    "{}",
                    serde_json::json!({"event": o.index, "at_s": o.at_s, "command": o.command, "accepted": false, "error": e})
                ),
                (Err(e), false) => println!("t = {:.3} s: {}: not sent: {e}", o.at_s, o.command),
            }
        })?;
        if !cli.json {
            println!(
                "timeline: {} events sent, {} accepted, {} rejected or not sent",
                report.sent, report.accepted, report.rejected
            );
        }
        return Ok(if report.rejected == 0 { 0 } else { 1 });
    }
    let Cmd::Follow {
        object,
        target,
        kp,
        kd,
        gravity,
        max_impulse,
        max_speed,
        duration_s,
        tolerance_m,
        verbose,
    } = &cli.command
    else {
        return Ok(0);
    };
    let id = session.resolve(&object.object)?;
    let label = session
        .scene_now()
        .map_or_else(|| format!("#{id}"), |s| s.label(id));
    let cfg = FollowConfig {
        kp_per_s2: *kp,
        kd_per_s: *kd,
        gravity_m_s2: *gravity,
        max_impulse_n_s: *max_impulse,
        max_speed_m_s: *max_speed,
        duration: Duration::from_secs_f64(duration_s.clamp(0.0, 1e6)),
        tolerance_m: *tolerance_m,
        ..FollowConfig::new(id, *target)
    };
    let json = cli.json;
    let report = follow(&mut session, &cfg, |t| {
        if *verbose {
            if json {
                println!("{}", serde_json::json!({"tick": t}));
            } else {
                println!(
                    "step {} t = {:.3} s  x = ({:.3}, {:.3}, {:.3}) m  error {:.4} m",
                    t.step, t.time_s, t.position_m[0], t.position_m[1], t.position_m[2], t.error_m
                );
            }
        }
    })?;
    if json {
        let mut v = serde_json::to_value(&report).unwrap_or_default();
        v["object"] = label.clone().into();
        v["target_m"] = serde_json::json!(target);
        println!("{v}");
    } else {
        let l = &report.latency;
        let p = report.final_position_m;
        println!(
            "follow {label}: stopped ({:?}) after {} updates, {} impulses ({} accepted, {} rejected)",
            report.stop, report.updates, report.commands_sent, report.accepted, report.rejected
        );
        println!(
            "final COM ({:.4}, {:.4}, {:.4}) m, {:.4} m from the target",
            p[0], p[1], p[2], report.final_error_m
        );
        println!(
            "loop latency (command sent -> first frame showing it), {} samples: p50 {:.0} us, p90 {:.0} us, p99 {:.0} us, max {:.0} us",
            l.count, l.p50_us, l.p90_us, l.p99_us, l.max_us
        );
        if let Some(r) = &report.last_rejection {
            println!("last rejection: {r}");
        }
    }
    if report.stop == FollowStop::ServerShutDown {
        eprintln!("splatphys-control: the server shut down");
    }
    Ok(if report.rejected == 0 { 0 } else { 1 })
}

fn print_reply(json: bool, name: &str, object: Option<u32>, reply: &Reply) {
    if json {
        let mut v = reply_json(reply);
        v["command"] = name.into();
        v["object"] = object.into();
        println!("{v}");
    } else {
        let object = object.map_or(String::new(), |id| format!(" #{id}"));
        println!("{name}{object}: {}", describe_reply(reply));
    }
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    let code = match run(&cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("splatphys-control: {e}");
            if matches!(e, ControlError::Ipc(IpcError::ServerGone { .. })) {
                // The dead server's shared memory can go once nobody holds its services
                // (the session is dropped by now).
                let _ = splatphys_ipc::services::cleanup_dead_nodes();
            }
            exit_code(&e)
        }
    };
    std::process::exit(code);
}
