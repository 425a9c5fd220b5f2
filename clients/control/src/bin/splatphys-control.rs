//! `splatphys-control`: send commands to a running splatphys server from the shell.
//!
//! Exit status: 0 when every command was accepted, 1 when one was rejected or the input is
//! invalid, 2 when the server is not found, gone, or does not reply.

use std::time::Duration;

use anyhow::Result;
use clap::Parser;
use splatphys_control::action::{Action, parse_kind, parse_model};
use splatphys_control::cli::{Cli, Cmd, PREFIX_ENV};
use splatphys_control::follow::{FollowConfig, FollowStop, follow};
use splatphys_control::session::{describe_reply, reply_json};
use splatphys_control::timeline::{load_timeline, run_timeline};
use splatphys_control::{ControlError, Session, SessionOptions};
use splatphys_ipc::IpcError;
use splatphys_ipc::command::{MaterialEdit, Reply};

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
