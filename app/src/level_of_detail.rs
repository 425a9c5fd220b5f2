//! `--budget-fps` and `--spacing-from` of `splatphys run` and `serve`: how coarsely the scene's
//! deformable objects are simulated, chosen by a calibration on this machine or read back from an
//! earlier run's `summary.json` so that the run is reproduced exactly elsewhere.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde::{Deserialize, Serialize};
use splatphys_core::scene::level_of_detail::{Choice, ObjectSpacing, candidates};
use splatphys_core::scene::{LevelOfDetail, Scene};

use crate::calibration::CalibrationSettings;

/// Level-of-detail flags.
#[derive(Args, Debug, Clone)]
pub struct LodArgs {
    /// Coarsen deformable objects (each one's grid cell and physics-particle spacing) to run at
    /// this many simulated frames per wall second on this machine, chosen by short calibration
    /// runs first; overrides `[simulation] budget_fps`. Rigid, static and kinematic objects are
    /// never changed.
    #[arg(long)]
    pub budget_fps: Option<f64>,
    /// Simulated seconds each calibration run covers, from the scene's start; default: the whole
    /// scene. A run that cannot meet the budget is stopped once it has taken the window's frames
    /// divided by the budget, so a calibration costs a few such spans of wall time.
    #[arg(long)]
    pub calibrate_s: Option<f64>,
    /// After choosing, measure the chosen level's error against the scene as written over this
    /// many simulated seconds from the start (runs the scene as written that long); 0 skips it.
    #[arg(long, default_value_t = 0.2)]
    pub error_window_s: f64,
    /// Measure every candidate's error against the scene as written over the whole calibration
    /// window instead (runs the scene as written and every candidate to the window's end: slow).
    #[arg(long)]
    pub calibrate_errors: bool,
    /// Use the level of detail recorded in an earlier run's summary.json (or a
    /// level_of_detail.json) instead of calibrating: the same grid and spacings on any machine.
    #[arg(long, conflicts_with = "budget_fps")]
    pub spacing_from: Option<PathBuf>,
}

/// What a run used, as recorded in `summary.json` under `level_of_detail`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LodRecord {
    /// `calibrated` (on this machine) or `from <file>`.
    pub source: String,
    /// The level of detail the run used.
    pub chosen: LevelOfDetail,
    /// The calibration behind it (absent when read from a file).
    pub calibration: Option<CalibrationRecord>,
}

/// A calibration, as recorded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationRecord {
    /// Simulated frames per wall second asked for.
    pub budget_fps: f64,
    /// Whether the chosen level met it.
    pub budget_met: bool,
    /// Simulated seconds of each calibration run.
    pub window_s: f64,
    /// Whether errors against the scene as written were measured.
    pub errors: bool,
    /// Worker threads of the calibration runs.
    pub threads: usize,
    /// Every candidate measured: the uniform steps finest first, then the per-object choice when
    /// one was tried; the errors are against the scene as written over the window.
    pub candidates: Vec<CandidateRecord>,
    /// The chosen level's error against the scene as written (absent when not measured).
    pub expected_error: Option<ExpectedError>,
}

/// The error a level of detail costs against the scene as written, over a window from the start.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ExpectedError {
    /// Simulated seconds compared.
    pub window_s: f64,
    /// Largest COM distance over the window, m.
    pub com_error_m: f64,
    /// 95th percentile Gaussian distance at the window's end, m.
    pub p95_error_m: f64,
}

/// One measured candidate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CandidateRecord {
    /// The coarsest deformable object's grid cell, m.
    pub grid_dx_m: f64,
    /// Each deformable object's spacing and grid cell as the level gives them.
    pub objects: Vec<ObjectSpacing>,
    /// The grid cell each of them is simulated on, m, in the same order.
    pub cells_m: Vec<f64>,
    /// Wall seconds per simulated frame each of them spent in its own MPM substeps, in the same
    /// order (what the per-object choice predicts from).
    pub object_wall_s_per_frame: Vec<f64>,
    /// Simulated frames per wall second (until it was stopped, for a run stopped as over budget).
    pub frames_per_wall_s: f64,
    /// Largest COM error over the window, m (when errors were measured).
    pub com_error_m: Option<f64>,
    /// 95th percentile Gaussian error at the window's end, m (when errors were measured).
    pub p95_error_m: Option<f64>,
    /// Whether this is the one chosen.
    pub chosen: bool,
}

impl LodArgs {
    /// The budget asked for: the flag, else the scene's `budget_fps`.
    fn budget(&self, scene: &Scene) -> Option<f64> {
        self.budget_fps.or(scene.simulation.budget_fps)
    }
}

/// Applies the level of detail `args` and `scene` ask for to `scene`, printing what was chosen
/// (`who` prefixes the lines), and returns its record; `None` when neither asks for one.
///
/// # Errors
/// An unreadable `--spacing-from` file or one without a level of detail, one that does not fit
/// the scene, a budget that is not a positive number, a failing calibration run.
pub fn resolve(
    scene: &mut Scene,
    args: &LodArgs,
    threads: usize,
    who: &str,
) -> Result<Option<LodRecord>> {
    if let Some(path) = &args.spacing_from {
        let chosen = read(path)?;
        chosen
            .apply(scene)
            .with_context(|| format!("--spacing-from {}", path.display()))?;
        eprintln!(
            "{who}: level of detail from {}: {}",
            path.display(),
            describe(&chosen)
        );
        return Ok(Some(LodRecord {
            source: format!("from {}", path.display()),
            chosen,
            calibration: None,
        }));
    }
    let Some(budget_fps) = args.budget(scene) else {
        return Ok(None);
    };
    if !(budget_fps.is_finite() && budget_fps > 0.0) {
        bail!("--budget-fps {budget_fps}: give a positive number of frames per wall second");
    }
    if !(args.error_window_s.is_finite() && args.error_window_s >= 0.0) {
        bail!(
            "--error-window-s {}: give simulated seconds, 0 or more",
            args.error_window_s
        );
    }
    let duration_s = scene.simulation.duration_s;
    let settings = CalibrationSettings {
        budget_fps,
        window_s: args.calibrate_s.map_or(duration_s, |w| w.min(duration_s)),
        threads,
        errors: args.calibrate_errors,
    };
    let frames = (settings.window_s * scene.simulation.frame_rate_hz).round() as u64;
    let pb = ProgressBar::new(frames * candidates(scene).len() as u64);
    pb.set_style(
        ProgressStyle::with_template("calibrating {msg} [{bar:30}] {pos}/{len} frames {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let choice = crate::calibration::calibrate(scene, settings, &pb)?;
    let mut record = record(&choice, &settings);
    if let Some(c) = &mut record.calibration {
        c.expected_error = expected_error(scene, &choice, &settings, args.error_window_s, &pb)?;
    }
    pb.finish_and_clear();
    choice.chosen.apply(scene)?;
    eprint!("{}", table(&record, who));
    Ok(Some(record))
}

/// The chosen level's expected error: from the calibration when it measured errors, else by
/// [`crate::calibration::expected_error`] over `window_s` (none when 0).
fn expected_error(
    scene: &Scene,
    choice: &Choice,
    settings: &CalibrationSettings,
    window_s: f64,
    pb: &ProgressBar,
) -> Result<Option<ExpectedError>> {
    if settings.errors {
        let m = &choice.expected;
        return Ok(m
            .com_error_m
            .zip(m.p95_error_m)
            .map(|(com_error_m, p95_error_m)| ExpectedError {
                window_s: settings.window_s,
                com_error_m,
                p95_error_m,
            }));
    }
    if window_s == 0.0 {
        return Ok(None);
    }
    let window_s = window_s.min(scene.simulation.duration_s);
    let frames = (window_s * scene.simulation.frame_rate_hz).round() as u64;
    pb.set_length(pb.length().unwrap_or(0) + 2 * frames);
    let (com_error_m, p95_error_m) =
        crate::calibration::expected_error(scene, &choice.chosen, window_s, settings.threads, pb)
            .context("--error-window-s")?;
    Ok(Some(ExpectedError {
        window_s,
        com_error_m,
        p95_error_m,
    }))
}

/// Warns when a calibrated run of `duration_s` simulated `frames` in `wall_s`, slower than its
/// budget.
pub fn check_pace(
    record: Option<&LodRecord>,
    frames: u64,
    wall_s: f64,
    duration_s: f64,
    who: &str,
) {
    let Some(c) = record.and_then(|r| r.calibration.as_ref()) else {
        return;
    };
    let fps = frames as f64 / wall_s.max(1e-9);
    if !c.budget_met || fps >= c.budget_fps {
        return;
    }
    let hint = if c.window_s < duration_s {
        format!(
            ": the calibration timed the first {} s only; without --calibrate-s it times the \
             whole scene",
            c.window_s
        )
    } else {
        " (a busy machine, or a chosen level at the edge of the budget)".to_owned()
    };
    eprintln!(
        "{who}: warning: the run simulated {fps:.1} frames per wall second, below the {} asked \
         for{hint}",
        c.budget_fps
    );
}

/// The level of detail in `path`: a `summary.json` (its `level_of_detail.chosen`), a record, or a
/// level of detail itself.
fn read(path: &Path) -> Result<LevelOfDetail> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("--spacing-from: reading {}", path.display()))?;
    let v: serde_json::Value = serde_json::from_str(&text)
        .with_context(|| format!("--spacing-from: {} is not JSON", path.display()))?;
    let v = v.get("level_of_detail").unwrap_or(&v);
    if v.is_null() {
        bail!(
            "--spacing-from: {} records no level of detail (that run had no --budget-fps)",
            path.display()
        );
    }
    let v = v.get("chosen").unwrap_or(v);
    serde_json::from_value(v.clone()).with_context(|| {
        format!(
            "--spacing-from: {} holds no level of detail (grid_dx_m, collision_dx_m, objects)",
            path.display()
        )
    })
}

/// Writes `level` as `path` (the form `--spacing-from` reads).
///
/// # Errors
/// An unwritable path.
pub fn write(path: &Path, level: &LevelOfDetail) -> Result<()> {
    let text = serde_json::to_string_pretty(level)?;
    std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))
}

fn record(c: &Choice, settings: &CalibrationSettings) -> LodRecord {
    LodRecord {
        source: "calibrated".into(),
        chosen: c.chosen.clone(),
        calibration: Some(CalibrationRecord {
            budget_fps: c.budget_fps,
            budget_met: c.budget_met,
            window_s: settings.window_s,
            errors: settings.errors,
            threads: settings.threads,
            expected_error: None,
            candidates: c
                .calibration
                .iter()
                .map(|(level, m)| CandidateRecord {
                    grid_dx_m: level.coarsest_cell_m(),
                    objects: level.objects.clone(),
                    cells_m: level
                        .objects
                        .iter()
                        .map(|o| o.cell_m(level.grid_dx_m))
                        .collect(),
                    object_wall_s_per_frame: m.object_wall_s_per_frame.clone(),
                    frames_per_wall_s: m.frames_per_wall_s(),
                    com_error_m: m.com_error_m,
                    p95_error_m: m.p95_error_m,
                    chosen: *level == c.chosen,
                })
                .collect(),
        }),
    }
}

fn describe(level: &LevelOfDetail) -> String {
    let objects: Vec<String> = level
        .objects
        .iter()
        .map(|o| {
            let cell = o.cell_m(level.grid_dx_m) * 1e3;
            match o.physics_spacing_m {
                Some(h) => format!(
                    "{} on a {cell:.2} mm grid at {:.2} mm spacing",
                    o.name,
                    h * 1e3
                ),
                None => format!("{} as written ({cell:.2} mm grid)", o.name),
            }
        })
        .collect();
    format!(
        "{}; collision surfaces {:.2} mm",
        if objects.is_empty() {
            "no deformable object".to_owned()
        } else {
            objects.join(", ")
        },
        level.collision_dx_m * 1e3,
    )
}

/// The calibration as a table for the terminal.
fn table(r: &LodRecord, who: &str) -> String {
    let Some(c) = &r.calibration else {
        return format!("{who}: level of detail: {}\n", describe(&r.chosen));
    };
    let errors = if c.errors {
        "errors against the scene as written over that window"
    } else {
        "--calibrate-errors measures errors"
    };
    let names: Vec<&str> = r.chosen.objects.iter().map(|o| o.name.as_str()).collect();
    let mut out = format!(
        "{who}: level of detail for {} frames per wall second ({} s calibration runs, {} threads; \
         {errors}):\n    {:<24} frames/s  COM error  p95 error\n",
        c.budget_fps,
        c.window_s,
        c.threads,
        format!("grid cell, mm ({})", names.join(" / ")),
    );
    let mm = |e: Option<f64>| e.map_or_else(|| "-".to_owned(), |e| format!("{:.2} mm", e * 1e3));
    for k in &c.candidates {
        let cells: Vec<String> = k
            .objects
            .iter()
            .zip(&k.cells_m)
            .map(|(o, cell)| {
                let cell = format!("{:.1}", cell * 1e3);
                if o.physics_spacing_m.is_none() {
                    cell + "*"
                } else {
                    cell
                }
            })
            .collect();
        out += &format!(
            "  {} {:<24} {:>8.2} {:>10} {:>10}\n",
            if k.chosen { '>' } else { ' ' },
            cells.join(" / "),
            k.frames_per_wall_s,
            mm(k.com_error_m),
            mm(k.p95_error_m),
        );
    }
    out += "    (* every Gaussian a particle)\n";
    out += &format!("{who}: chose {}", describe(&r.chosen));
    if let Some(e) = c.expected_error {
        out += &format!(
            "; error against the scene as written over the first {} s: COM {:.2} mm, p95 \
             Gaussian {:.2} mm",
            e.window_s,
            e.com_error_m * 1e3,
            e.p95_error_m * 1e3
        );
    }
    if !c.budget_met {
        out += &format!(
            "; the budget is not met: this is the fastest candidate (the coarsest keeps {} cells \
             across the thinnest deformable object)",
            splatphys_core::scene::level_of_detail::MIN_CELLS_ACROSS
        );
    }
    out.push('\n');
    out
}
