//! The reports a run leaves behind, as types shared by every writer: `server.json`
//! ([`ServerJson`], written by `splatphys serve --report`) and `summary.json` ([`RunSummary`],
//! written by both modes of `splatphys run` with the same keys).

use std::path::Path;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use splatphys_core::mpm::Diagnostics;
use splatphys_core::world::explain::Explanation;
use splatphys_core::world::{World, WorldStats};

/// `server.json`: what the server did, written when it stops.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ServerJson {
    /// Scene name.
    pub scene: String,
    /// Simulation method (`com`, `mpm`, `multi-field`).
    pub method: String,
    /// Why the server stopped (`Finished`, `Signal`, ...).
    pub stopped: String,
    /// Simulated particles.
    pub particles: usize,
    /// Published Gaussians.
    pub gaussians: usize,
    /// Objects.
    pub objects: usize,
    /// Frames published.
    pub frames_published: u64,
    /// Last step index.
    pub last_step: u64,
    /// Simulated seconds.
    pub simulated_s: f64,
    /// Substeps.
    pub substeps: u64,
    /// Wall seconds of the whole server run.
    pub wall_s: f64,
    /// Wall seconds spent stepping.
    pub step_wall_s: f64,
    /// Wall seconds spent publishing.
    pub publish_wall_s: f64,
    /// MPM particle-substeps computed.
    pub mpm_particle_substeps: u64,
    /// MPM particle-substeps per stepping wall second.
    pub particle_substeps_per_s: f64,
    /// Frames best-effort clients skipped.
    pub frames_dropped_by_clients: u64,
    /// Frames lossless clients (recorders) lost past the backpressure limit.
    pub frames_lost_by_recorder: u64,
    /// Commands received.
    pub commands_received: u64,
    /// Commands rejected.
    pub commands_rejected: u64,
    /// The world's counters.
    pub stats: WorldStats,
    /// Momentum and energy totals at the end.
    pub diagnostics: Diagnostics,
    /// What each object needed (`--explain`).
    pub explain: Explanation,
}

/// `summary.json`: one run of `splatphys run`, the same keys in both modes (`mode` tells which;
/// counts that a mode does not have are 0 or `false` there).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunSummary {
    /// `multi-process` or `in-process`.
    pub mode: String,
    /// Scene name.
    pub scene: String,
    /// Service prefix (`None` in process).
    pub prefix: Option<String>,
    /// Simulation method.
    pub method: String,
    /// Simulated particles.
    pub particles: usize,
    /// Published Gaussians.
    pub gaussians: usize,
    /// Objects.
    pub objects: usize,
    /// Substeps.
    pub substeps: u64,
    /// Frames simulated after the initial one.
    pub frames: u64,
    /// Simulated seconds.
    pub simulated_s: f64,
    /// Frames rendered to PNG.
    pub frames_rendered: u64,
    /// PNG files in `frames/`.
    pub frame_pngs: usize,
    /// Wall seconds of the whole run.
    pub wall_s: f64,
    /// Wall seconds spent stepping.
    pub simulation_wall_s: f64,
    /// MPM particle-substeps per stepping wall second.
    pub particle_substeps_per_s: f64,
    /// Share of the step's wall time in the COM layer.
    pub com_layer_fraction: f64,
    /// Frames the live renderer skipped.
    pub frames_dropped_by_renderer: u64,
    /// Whether skipped frames were re-rendered from the recording.
    pub frames_rerendered_from_recording: bool,
    /// Steps missing from the recording (0 ..= the last step, counted from the MCAP file; the
    /// run exits non-zero when any is missing).
    pub frames_lost_by_recorder: u64,
    /// Distinct steps the recording holds.
    pub frames_recorded: u64,
    /// Whether the recorder exited cleanly.
    pub recorder_ok: bool,
    /// Whether the renderer exited cleanly.
    pub renderer_ok: bool,
    /// Rows written to `objects.csv` (header excluded).
    pub objects_csv_rows: u64,
    /// The world's counters.
    pub stats: WorldStats,
    /// Momentum and energy totals at the end.
    pub diagnostics_end: Diagnostics,
    /// What each object needed.
    pub explain: Explanation,
    /// Why the simulation stopped early, if it did.
    pub error: Option<String>,
    /// The level of detail the run used, when `--budget-fps`, `[simulation] budget_fps` or
    /// `--spacing-from` asked for one (`--spacing-from` reads it back).
    pub level_of_detail: Option<crate::level_of_detail::LodRecord>,
}

impl RunSummary {
    /// The fields every mode takes from the world at the end of a run.
    pub fn from_world(mode: &str, scene: &str, world: &World, wall_s: f64) -> Self {
        let stats = *world.stats();
        Self {
            mode: mode.into(),
            scene: scene.into(),
            prefix: None,
            method: method_name(world),
            particles: world.particle_count(),
            gaussians: world.published_count(),
            objects: world.bodies().len(),
            substeps: stats.substeps,
            frames: world.frame(),
            simulated_s: world.time_s(),
            frames_rendered: 0,
            frame_pngs: 0,
            wall_s,
            simulation_wall_s: wall_s,
            particle_substeps_per_s: stats.mpm_particle_substeps as f64 / wall_s.max(1e-9),
            com_layer_fraction: com_layer_fraction(&stats),
            frames_dropped_by_renderer: 0,
            frames_rerendered_from_recording: false,
            frames_lost_by_recorder: 0,
            frames_recorded: 0,
            recorder_ok: false,
            renderer_ok: false,
            objects_csv_rows: 0,
            stats,
            diagnostics_end: world.diagnostics(),
            explain: world.explain(),
            error: None,
            level_of_detail: None,
        }
    }

    /// The fields a multi-process run takes from the server's report.
    pub fn from_server(scene: &str, prefix: &str, s: ServerJson, wall_s: f64) -> Self {
        Self {
            mode: "multi-process".into(),
            scene: scene.into(),
            prefix: Some(prefix.into()),
            method: s.method,
            particles: s.particles,
            gaussians: s.gaussians,
            objects: s.objects,
            substeps: s.substeps,
            frames: s.frames_published,
            simulated_s: s.simulated_s,
            frames_rendered: 0,
            frame_pngs: 0,
            wall_s,
            simulation_wall_s: s.step_wall_s,
            particle_substeps_per_s: s.particle_substeps_per_s,
            com_layer_fraction: com_layer_fraction(&s.stats),
            frames_dropped_by_renderer: 0,
            frames_rerendered_from_recording: false,
            frames_lost_by_recorder: s.frames_lost_by_recorder,
            frames_recorded: 0,
            recorder_ok: false,
            renderer_ok: false,
            objects_csv_rows: 0,
            stats: s.stats,
            diagnostics_end: s.diagnostics,
            explain: s.explain,
            error: None,
            level_of_detail: None,
        }
    }
}

/// The method's scene-file name.
pub fn method_name(world: &World) -> String {
    world.settings().method.name().to_string()
}

fn com_layer_fraction(s: &WorldStats) -> f64 {
    s.com_layer_wall_s / (s.com_layer_wall_s + s.mpm_wall_s).max(1e-12)
}

/// Writes `value` as pretty JSON to `path`.
///
/// # Errors
/// Serialisation or I/O errors, naming the file.
pub fn write_json(path: &Path, value: &impl Serialize) -> Result<()> {
    std::fs::write(path, serde_json::to_string_pretty(value)?)
        .with_context(|| format!("writing {}", path.display()))
}

/// Reads a JSON report written by [`write_json`].
///
/// # Errors
/// I/O or parse errors, naming the file.
pub fn read_json<T: for<'de> Deserialize<'de>>(path: &Path) -> Result<T> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))
}
