//! `splatphys serve`: the co-simulation server alone; clients attach and detach freely.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use clap::Args;
use splatphys_ipc::fake::FreeFall;
use splatphys_ipc::server::{ServerConfig, serve};
use splatphys_ipc::validate::Limits;

/// Arguments of `splatphys serve`.
#[derive(Args, Debug)]
pub struct ServeArgs {
    /// Scene file (TOML).
    pub scene: Option<PathBuf>,
    /// Service prefix (default `splatphys/<scene name>`).
    #[arg(long)]
    pub prefix: Option<String>,
    /// Pace frames to simulated time instead of running as fast as possible.
    #[arg(long)]
    pub realtime: bool,
    /// Stop after this many frames (after the initial one).
    #[arg(long)]
    pub frames: Option<u64>,
    /// Longest wait on a lagging lossless subscriber (recorder), milliseconds.
    #[arg(long, default_value_t = 100)]
    pub lossless_limit_ms: u64,
    /// Largest accepted impulse magnitude, N·s.
    #[arg(long, default_value_t = 1e3)]
    pub max_impulse: f64,
    /// Start paused (send `resume` or `step N`).
    #[arg(long)]
    pub paused: bool,
    /// Serve the built-in free-fall stand-in instead of the scene (testing the IPC layer).
    #[arg(long, hide = true)]
    pub fake: bool,
    /// Objects of the free-fall stand-in.
    #[arg(long, hide = true, default_value_t = 2)]
    pub fake_objects: usize,
    /// Gaussians per object of the free-fall stand-in.
    #[arg(long, hide = true, default_value_t = 1000)]
    pub fake_gaussians: usize,
    /// Simulated time per frame of the free-fall stand-in, seconds.
    #[arg(long, hide = true, default_value_t = 1.0 / 60.0)]
    pub fake_dt: f64,
}

/// Runs the server until a signal, a shutdown command or the end of the run.
pub fn run(args: &ServeArgs) -> Result<()> {
    let cfg = ServerConfig {
        prefix: args.prefix.clone(),
        realtime: args.realtime,
        lossless_limit: Duration::from_millis(args.lossless_limit_ms),
        limits: Limits {
            max_impulse_n_s: args.max_impulse,
            ..Limits::default()
        },
        max_frames: args.frames,
        start_paused: args.paused,
        ..ServerConfig::default()
    };
    if !args.fake {
        bail!(
            "serving a scene file needs the sim-core world, which is not wired in yet; use --fake to serve the free-fall stand-in"
        );
    }
    let name = args
        .scene
        .as_ref()
        .and_then(|p| p.file_stem())
        .map_or_else(|| "fake".to_owned(), |s| s.to_string_lossy().into_owned());
    let mut sim = FreeFall::new(
        &name,
        args.fake_objects,
        args.fake_gaussians,
        args.fake_dt,
        None,
    );
    let report = serve(&mut sim, &cfg).context("server failed")?;
    eprintln!(
        "splatphys serve: stopped ({:?}) at step {}, {} frames published, {} commands ({} rejected), {} frames skipped by best-effort clients, {} lost by recorders",
        report.reason,
        report.step,
        report.frames_published,
        report.commands_received,
        report.commands_rejected,
        report.frames_dropped,
        report.recorder_frames_lost
    );
    Ok(())
}
