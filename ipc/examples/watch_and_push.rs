//! A Rust client of a running server: subscribes to `frame` and `objects`, prints one object's
//! centre of mass and speed, and pushes it with an impulse half-way through.
//!
//! ```text
//! target/release/splatphys serve --prefix splatphys/default --realtime &
//! cargo run --release -p splatphys-ipc --example watch_and_push -- --prefix splatphys/default --object jelly
//! ```
//!
//! Arguments: `--prefix P` (the server's service prefix, `splatphys serve --prefix`), `--object
//! NAME` (an object of the scene; default: the first), `--frames N` (stop after N frames; default
//! 60), `--impulse-n-s X,Y,Z` (default `0,0,0.05`). The same calls from Python:
//! `clients/python`; the bytes: `docs/reference/protocol.md`.

use std::time::Duration;

use splatphys_ipc::client::{ClientOptions, Connection};
use splatphys_ipc::command::{Command, Reply};

/// What the command line asked for.
struct Args {
    prefix: String,
    object: Option<String>,
    frames: u64,
    impulse_n_s: [f64; 3],
}

fn parse_args() -> Result<Args, String> {
    let mut args = Args {
        prefix: "splatphys/default".into(),
        object: None,
        frames: 60,
        impulse_n_s: [0.0, 0.0, 0.05],
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let value = it.next().ok_or_else(|| format!("{flag} needs a value"))?;
        match flag.as_str() {
            "--prefix" => args.prefix = value,
            "--object" => args.object = Some(value),
            "--frames" => {
                args.frames = value
                    .parse()
                    .map_err(|e| format!("--frames {value}: {e}"))?;
            }
            "--impulse-n-s" => {
                let v: Vec<f64> = value
                    .split(',')
                    .map(|c| c.trim().parse::<f64>())
                    .collect::<Result<_, _>>()
                    .map_err(|e| format!("--impulse-n-s {value}: {e}"))?;
                args.impulse_n_s = match v[..] {
                    [x, y, z] if v.iter().all(|c| c.is_finite()) => [x, y, z],
                    _ => return Err(format!("--impulse-n-s {value}: expected x,y,z")),
                };
            }
            other => return Err(format!("unknown argument {other}")),
        }
    }
    Ok(args)
}

fn main() {
    if let Err(e) = run() {
        eprintln!("watch_and_push: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args = parse_args()?;
    let mut opts = ClientOptions::new(&args.prefix);
    opts.node_name = "watch-and-push".into();
    opts.commands = true;
    let mut conn = Connection::connect(&opts)?;

    // Object names arrive once per scene generation; ids index the `objects` payload.
    let mut object_id = None;
    let mut seen = 0u64;
    let mut pushed = false;
    while seen < args.frames {
        if let Some(names) = conn.recv_object_names()? {
            let names: Vec<String> = names.payload().iter().map(|n| n.text()).collect();
            object_id = match &args.object {
                Some(want) => Some(
                    names
                        .iter()
                        .position(|n| n == want)
                        .ok_or_else(|| format!("no object {want:?}; the scene has {names:?}"))?,
                ),
                None => Some(0),
            };
        }
        // The newest frame: a zero-copy view of every visible Gaussian (52 B each).
        let Some(frame) = conn.wait_frame(Duration::from_millis(100))? else {
            continue;
        };
        let gaussians = frame.payload().len();
        drop(frame);
        seen += 1;
        // Objects go out right after their frame.
        while let Some(objects) = conn.recv_objects()? {
            let Some(o) = object_id.and_then(|i| objects.payload().get(i).copied()) else {
                continue;
            };
            let header = *objects.user_header();
            let speed = o.velocity_m_s.iter().map(|v| v * v).sum::<f32>().sqrt();
            println!(
                "step {:>5}  t {:.3} s  {gaussians} Gaussians  object {} at ({:.3}, {:.3}, {:.3}) m, {speed:.3} m/s",
                header.step, header.time_s, o.id, o.position_m[0], o.position_m[1], o.position_m[2],
            );
        }
        if !pushed && seen >= args.frames / 2 {
            if let Some(id) = object_id {
                let cmd = Command::Impulse {
                    object: id as u32,
                    impulse_n_s: args.impulse_n_s,
                    point_m: None,
                };
                match conn.command(&cmd, Duration::from_secs(2))? {
                    Reply::Accepted { effective_step, .. } => {
                        println!("impulse accepted, effective at step {effective_step}");
                    }
                    Reply::Rejected { reason, .. } => println!("impulse rejected: {reason}"),
                }
            }
            pushed = true;
        }
    }
    Ok(())
}
