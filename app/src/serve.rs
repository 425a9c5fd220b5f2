//! `splatphys serve`: the co-simulation server alone; clients attach and detach freely.

use std::path::PathBuf;
use std::time::Duration;

use crate::device::{self, DeviceArgs};
use crate::level_of_detail::{self, LodArgs};
use crate::plan::camera_args;
use crate::report::{ServerJson, method_name, write_json};
use crate::view::{ViewArgs, Viewer};
use crate::world_sim::WorldSim;
use anyhow::{Context, Result};
use clap::Args;
use splatphys_core::scene::CameraSpec;
use splatphys_ipc::fake::FreeFall;
use splatphys_ipc::server::{ServerConfig, serve};
use splatphys_ipc::services::ServiceNames;
use splatphys_ipc::validate::Limits;

/// Arguments of `splatphys serve`.
#[derive(Args, Debug)]
#[command(after_help = "Examples:
  splatphys serve scenes/donut_drop.toml --view         # watch it in the browser; holds the last frame at the end
  splatphys serve scenes/donut_push_finger.toml --realtime --prefix splatphys/finger
  splatphys serve scenes/guitar_topple.toml --exit-at-end --wait-for-recorders=1 &
  splatphys-record record --prefix splatphys/guitar_topple --out run.mcap   # every step, none twice")]
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
    #[arg(long, default_value_t = 2000)]
    pub lossless_limit_ms: u64,
    /// Largest accepted impulse magnitude, N·s.
    #[arg(long, default_value_t = splatphys_types::limits::DEFAULT_MAX_IMPULSE_N_S)]
    pub max_impulse: f64,
    /// Start paused (send `resume` or `step N`).
    #[arg(long)]
    pub paused: bool,
    /// Override the scene's duration, seconds.
    #[arg(long)]
    pub duration_s: Option<f64>,
    /// Exit when the scene's duration has been simulated. Without it the server holds the last
    /// frame, paused (status flag "finished"), and keeps answering: `step N`, `resume` (one
    /// more duration), `reset`, until Ctrl-C or `shutdown`.
    #[arg(long)]
    pub exit_at_end: bool,
    /// Publish no frame until this many lossless subscribers (recorders) are ready: every port
    /// connected and the scene taken. The recording then holds every step, the first once; the
    /// server fails if they are not ready within --wait-timeout-s. At the end it waits for them
    /// to take the last frame.
    #[arg(long, default_value_t = 0)]
    pub wait_for_recorders: usize,
    /// Publish no frame until this many frame subscribers of any kind (renderers, viewers) are
    /// connected; past --wait-timeout-s the server starts anyway.
    #[arg(long, default_value_t = 0)]
    pub wait_for_subscribers: usize,
    /// Longest wait for --wait-for-recorders and --wait-for-subscribers, seconds.
    #[arg(long, default_value_t = 10.0)]
    pub wait_timeout_s: f64,
    /// Write a JSON report (counts, wall time, diagnostics) here when the server stops.
    #[arg(long)]
    pub report: Option<PathBuf>,
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
    /// The browser viewer.
    #[command(flatten)]
    pub view: ViewArgs,
    /// Level of detail by budget.
    #[command(flatten)]
    pub lod: LodArgs,
    /// Where deformable objects' MPM runs.
    #[command(flatten)]
    pub device: DeviceArgs,
}

/// Starts the viewer when `--view` asks for it, printing its URL.
fn viewer(
    args: &ServeArgs,
    cfg: &ServerConfig,
    name: &str,
    camera: Option<&CameraSpec>,
) -> Result<Option<Viewer>> {
    if !args.view.view {
        return Ok(None);
    }
    let prefix = cfg
        .prefix
        .clone()
        .unwrap_or_else(|| ServiceNames::default_prefix(name));
    let v = Viewer::start(&args.view, &prefix, &camera_args(camera))?;
    v.announce("splatphys serve");
    Ok(Some(v))
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
        exit_when_finished: args.exit_at_end,
        start_paused: args.paused,
        wait_for_lossless: args.wait_for_recorders,
        wait_for_subscribers: args.wait_for_subscribers,
        wait_timeout: Duration::try_from_secs_f64(args.wait_timeout_s)
            .with_context(|| format!("--wait-timeout-s {}", args.wait_timeout_s))?,
        ..ServerConfig::default()
    };
    if !args.fake {
        return serve_scene(args, &cfg);
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
    let _viewer = viewer(args, &cfg, &name, None)?;
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

/// Serves the scene file (or the built-in default scene) with the real simulation.
fn serve_scene(args: &ServeArgs, cfg: &ServerConfig) -> Result<()> {
    let (name, mut scene) =
        splatphys_core::scene::load_named(args.scene.as_deref(), args.duration_s)?;
    for w in &scene.warnings {
        eprintln!("splatphys serve: warning: {w}");
    }
    level_of_detail::resolve(
        &mut scene,
        &args.lod,
        rayon::current_num_threads(),
        "splatphys serve",
    )?;
    args.device.apply(&mut scene);
    let mut sim =
        WorldSim::new(&name, &scene).with_context(|| format!("building scene {name:?}"))?;
    device::attach(&mut sim.world, "splatphys serve");
    eprintln!(
        "splatphys serve: scene {name:?}: {} objects, {} particles, {} Gaussians published, {} frames",
        sim.world.bodies().len(),
        sim.world.particle_count(),
        sim.world.published_count(),
        sim.world.total_frames()
    );
    let _viewer = viewer(args, cfg, &name, scene.cameras.first())?;
    let started = std::time::Instant::now();
    let result = serve(&mut sim, cfg);
    let wall_s = started.elapsed().as_secs_f64();
    let report = result.context("server failed")?;
    let w = &sim.world;
    let json = ServerJson {
        scene: name,
        method: method_name(w),
        stopped: format!("{:?}", report.reason),
        particles: w.particle_count(),
        gaussians: w.published_count(),
        objects: w.bodies().len(),
        frames_published: report.frames_published,
        last_step: report.step,
        simulated_s: w.time_s(),
        substeps: w.stats().substeps,
        wall_s,
        step_wall_s: report.step_wall_s,
        publish_wall_s: report.publish_wall_s,
        mpm_particle_substeps: w.stats().mpm_particle_substeps,
        particle_substeps_per_s: w.stats().mpm_particle_substeps as f64
            / report.step_wall_s.max(1e-9),
        frames_dropped_by_clients: report.frames_dropped,
        frames_lost_by_recorder: report.recorder_frames_lost,
        commands_received: report.commands_received,
        commands_rejected: report.commands_rejected,
        stats: *w.stats(),
        diagnostics: w.diagnostics(),
        explain: w.explain(),
    };
    if let Some(path) = &args.report {
        write_json(path, &json)?;
    }
    eprintln!(
        "splatphys serve: wall time: {:.2} s stepping, {:.2} s publishing, {:.2} s saving checkpoints; {} failed steps restored",
        report.step_wall_s, report.publish_wall_s, report.checkpoint_wall_s, report.step_failures
    );
    eprintln!(
        "splatphys serve: stopped ({:?}) at step {}, {} frames published, {} lost by recorders",
        report.reason, report.step, report.frames_published, report.recorder_frames_lost
    );
    Ok(())
}
