//! The command-flood part of `splatphys bench ipc`: does a controller sending thousands of
//! commands per second slow the server's stepping?
//!
//! Each run serves a simulation ([`FloodSim`]: the built-in default scene on the real `World`,
//! or the free-fall stand-in) in a thread of this process, paused; a flood run first starts a
//! controller process (`bench ipc-peer --role flood`) that sends impulse commands of 1e-9 N·s
//! to the first movable object at the requested rate. The run then resumes the server and
//! counts its steps for `seconds`, from the accepted `resume` to the server's return. Quiet and
//! flood runs alternate, each from the same initial state; the medians of their step rates are
//! compared. The server drains every pending command once per loop iteration (one step), and
//! one client may have at most the command service's 64 requests in flight: a server that steps
//! fewer than rate / 64 times per second cannot take the whole flood, so the achieved rate is
//! reported next to the requested one.

use std::io::Read;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow, ensure};
use serde_json::{Value, json};
use splatphys_core::scene::ObjectKind;
use splatphys_ipc::client::{ClientOptions, Connection};
use splatphys_ipc::command::{Command, Reply};
use splatphys_ipc::fake::FreeFall;
use splatphys_ipc::server::{ServerConfig, ServerReport, serve};
use splatphys_ipc::{IpcError, Simulation};

use crate::WorldSimFactory;
use crate::peer::Peer;

/// What the server steps during a flood run.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum FloodSim {
    /// The built-in default scene on the real `World` (MPM; a few steps per second).
    Default,
    /// The free-fall stand-in of `serve --fake` with 100,000 Gaussians (cheap steps, so the
    /// server loop, and with it the command handling, runs thousands of times per second).
    Fake,
}

/// Gaussians of the [`FloodSim::Fake`] server.
const FAKE_GAUSSIANS: usize = 100_000;

/// The server thread: its report and when `serve` returned.
type ServerThread = JoinHandle<(Result<ServerReport, IpcError>, Instant)>;

/// One timed run.
struct RunResult {
    steps_per_s: f64,
    flood: Option<Value>,
}

/// A fresh simulation of `kind` and the object the flood pushes (the first one that is not
/// static).
fn start_server(
    kind: FloodSim,
    cfg: ServerConfig,
    world: WorldSimFactory,
) -> Result<(u32, ServerThread)> {
    fn spawn<S: Simulation + Send + 'static>(mut sim: S, cfg: ServerConfig) -> ServerThread {
        std::thread::spawn(move || {
            let report = serve(&mut sim, &cfg);
            (report, Instant::now())
        })
    }
    Ok(match kind {
        FloodSim::Default => {
            let (name, scene) = splatphys_core::scene::load_named(None, Some(1e6))?;
            let object = scene
                .objects
                .iter()
                .position(|o| o.kind != ObjectKind::Static)
                .context("the default scene has no movable object")?;
            let sim = world(&name, &scene).context("building the default scene")?;
            (object as u32, spawn(sim, cfg))
        }
        FloodSim::Fake => {
            let sim = FreeFall::new("fake", 2, FAKE_GAUSSIANS / 2, 1.0 / 60.0, None);
            (0, spawn(sim, cfg))
        }
    })
}

fn one_run(
    kind: FloodSim,
    world: WorldSimFactory,
    prefix: &str,
    hz: f64,
    seconds: f64,
) -> Result<RunResult> {
    let stop = Arc::new(AtomicBool::new(false));
    let cfg = ServerConfig {
        prefix: Some(prefix.to_owned()),
        start_paused: true,
        stop: stop.clone(),
        ..ServerConfig::default()
    };
    let (object, server) = start_server(kind, cfg, world)?;
    let mut opts = ClientOptions::new(prefix);
    opts.node_name = "splatphys-bench".into();
    opts.frames = false;
    opts.objects = false;
    opts.connect_timeout = Duration::from_secs(30);
    let mut conn = Connection::connect(&opts)?;
    let peer = if hz > 0.0 {
        let mut p = Peer::spawn(&[
            "--role".into(),
            "flood".into(),
            "--prefix".into(),
            prefix.into(),
            "--hz".into(),
            hz.to_string(),
            "--object".into(),
            object.to_string(),
        ])?;
        // The peer prints "ready" once connected; its last line (the counts) is read at exit,
        // so read byte by byte here and leave the rest in the pipe.
        let out = p.0.stdout.as_mut().context("peer stdout")?;
        let mut line = Vec::new();
        let mut byte = [0u8; 1];
        while out.read(&mut byte)? == 1 && byte[0] != b'\n' {
            line.push(byte[0]);
        }
        ensure!(
            line == b"ready",
            "flood peer said {:?}",
            String::from_utf8_lossy(&line)
        );
        Some(p)
    } else {
        None
    };
    let reply = conn.command(&Command::Resume, Duration::from_secs(30))?;
    let t0 = Instant::now();
    ensure!(
        matches!(reply, Reply::Accepted { .. }),
        "resume refused: {reply:?}"
    );
    drop(conn);
    std::thread::sleep(Duration::from_secs_f64(seconds));
    stop.store(true, Ordering::Release);
    let (report, ended) = server
        .join()
        .map_err(|_| anyhow!("server thread panicked"))?;
    let report = report.context("server failed")?;
    let steps_per_s = report.step as f64 / (ended - t0).as_secs_f64();
    let flood = peer
        .map(|p| p.finish(Duration::from_secs(30)))
        .transpose()?;
    Ok(RunResult { steps_per_s, flood })
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// Runs `repeats` quiet and flood runs of `seconds` each on `kind`; returns the JSON line.
pub fn run(
    kind: FloodSim,
    world: WorldSimFactory,
    hz: f64,
    seconds: f64,
    repeats: u32,
) -> Result<Value> {
    ensure!(
        seconds > 0.0 && repeats > 0,
        "--flood-seconds and --flood-repeats must be positive"
    );
    let (mut quiet, mut flooded) = (Vec::new(), Vec::new());
    let mut counts = [0u64; 4]; // sent, accepted, rejected, send errors
    let mut peer_s = 0.0f64;
    for r in 0..repeats {
        let prefix = |what: &str| {
            format!(
                "splatphys-bench/flood-{}-{kind:?}-{what}{r}",
                std::process::id()
            )
        };
        quiet.push(one_run(kind, world, &prefix("quiet"), 0.0, seconds)?.steps_per_s);
        let f = one_run(kind, world, &prefix("flood"), hz, seconds)?;
        flooded.push(f.steps_per_s);
        let c = f.flood.unwrap_or_default();
        for (total, key) in counts
            .iter_mut()
            .zip(["sent", "accepted", "rejected", "send_errors"])
        {
            *total += c[key].as_u64().unwrap_or(0);
        }
        peer_s += c["seconds"].as_f64().unwrap_or(0.0);
    }
    let (q, f) = (median(quiet.clone()), median(flooded.clone()));
    Ok(json!({
        "bench": "ipc_command_flood",
        "sim": format!("{kind:?}").to_lowercase(),
        "seconds_per_run": seconds,
        "runs_each": repeats,
        "command_hz_requested": hz,
        "commands_sent": counts[0],
        "commands_accepted": counts[1],
        "commands_rejected": counts[2],
        "commands_refused_in_flight_limit": counts[3],
        "commands_accepted_per_s": counts[1] as f64 / peer_s.max(1e-9),
        "steps_per_s_quiet": q,
        "steps_per_s_flood": f,
        "steps_per_s_quiet_runs": quiet,
        "steps_per_s_flood_runs": flooded,
        "flood_step_rate_ratio": f / q,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_even_and_odd_counts() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 2.0, 3.0]), 2.5);
    }
}
