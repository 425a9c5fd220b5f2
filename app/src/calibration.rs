//! The calibration behind `splatphys run --budget-fps`: short timed runs of a scene at each level
//! of detail ([`splatphys_core::scene::level_of_detail`]).
//!
//! Each run simulates the first `window_s` seconds of the scene on the run's thread count, through
//! the same code as `bench realtime` (no renderer or recorder). Its cost is the wall time of the
//! frame loop per simulated frame (the world build is not counted). A run that cannot meet the
//! budget any more (its frame loop has taken the window's frames divided by the budget) is
//! stopped there, so a fine candidate costs at most that much wall time: the cost is then a lower
//! bound, enough to reject it.
//!
//! With errors asked for, every run goes to the window's end and is compared with the scene as
//! written over the same window (largest COM distance; 95th percentile Gaussian distance at the
//! end), which costs a run of the scene as written. Otherwise [`expected_error`] compares the
//! chosen level alone over a shorter window. Both measures describe their window only.

use anyhow::{Context, Result};
use indicatif::ProgressBar;
use splatphys_core::scene::level_of_detail::{Choice, CostModel, Measurement, choose};
use splatphys_core::scene::{LevelOfDetail, Scene};

use crate::trace::{Trace, gaussian_errors_cells, max_distance, run_scene_within};

/// How a scene is calibrated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrationSettings {
    /// Simulated frames per wall second asked for.
    pub budget_fps: f64,
    /// Simulated seconds each run covers, from the scene's start (clamped to its duration).
    pub window_s: f64,
    /// Worker threads.
    pub threads: usize,
    /// Measure each candidate's error against the scene as written (runs it to the window's end).
    pub errors: bool,
}

/// Timed calibration runs of one scene: a [`CostModel`].
pub struct Calibration<'a> {
    settings: CalibrationSettings,
    /// The scene, cut to the calibration window.
    window: Scene,
    pool: rayon::ThreadPool,
    reference: Option<Trace>,
    pb: &'a ProgressBar,
}

impl<'a> Calibration<'a> {
    /// Calibration of `scene`; `pb` counts simulated frames.
    ///
    /// # Errors
    /// A window shorter than one frame, a budget that is not a positive number, a thread pool
    /// that cannot start.
    pub fn new(scene: &Scene, settings: CalibrationSettings, pb: &'a ProgressBar) -> Result<Self> {
        let frame_s = 1.0 / scene.simulation.frame_rate_hz;
        let window_s = settings.window_s;
        if !(window_s.is_finite() && window_s >= frame_s) {
            anyhow::bail!(
                "calibration window {window_s} s: give at least one frame ({frame_s:.4} s)"
            );
        }
        if !(settings.budget_fps.is_finite() && settings.budget_fps > 0.0) {
            anyhow::bail!(
                "budget {} frames per wall second: give a positive number",
                settings.budget_fps
            );
        }
        let mut window = scene.clone();
        window.simulation.duration_s = window_s.min(scene.simulation.duration_s);
        Ok(Self {
            settings,
            window,
            pool: rayon::ThreadPoolBuilder::new()
                .num_threads(settings.threads)
                .build()
                .context("thread pool")?,
            reference: None,
            pb,
        })
    }

    /// Frames each calibration run simulates (when not stopped).
    pub fn frames(&self) -> u64 {
        let s = &self.window.simulation;
        (s.duration_s * s.frame_rate_hz).round() as u64
    }

    /// Runs `level` over the window; stopped once it cannot meet the budget unless `to_end`.
    fn run(&self, level: &LevelOfDetail, to_end: bool) -> Result<Trace> {
        let mut s = self.window.clone();
        level.apply(&mut s)?;
        self.pb
            .set_message(format!("dx {:.1} mm", level.coarsest_cell_m() * 1e3));
        let max_wall_s = if to_end {
            f64::INFINITY
        } else {
            self.frames() as f64 / self.settings.budget_fps
        };
        let position = self.pb.position();
        let trace = self
            .pool
            .install(|| run_scene_within(&s, self.pb, max_wall_s))
            .with_context(|| {
                format!(
                    "calibration run at dx {} m (the coarsest object's cell)",
                    level.coarsest_cell_m()
                )
            })?;
        self.pb.set_position(position + self.frames());
        Ok(trace)
    }
}

impl CostModel for Calibration<'_> {
    type Error = anyhow::Error;

    fn measure(&mut self, level: &LevelOfDetail) -> Result<Measurement> {
        let errors = self.settings.errors;
        let t = self.run(level, errors)?;
        let frames = t.frames_run.max(1e-9);
        let wall_s_per_frame = t.wall_s / frames;
        // Each deformable object's own MPM time per whole frame, matched by name (the level
        // lists them); unknown (empty) when the run stopped within its first frame or an
        // object has no time.
        let whole_frames = t.com.len();
        let object_wall_s_per_frame = if whole_frames == 0 {
            Vec::new()
        } else {
            level
                .objects
                .iter()
                .map(|o| {
                    t.explain
                        .objects
                        .iter()
                        .position(|e| e.name == o.name)
                        .and_then(|k| t.object_mpm_s_whole_frames.get(k))
                        .map(|s| s / whole_frames as f64)
                })
                .collect::<Option<Vec<f64>>>()
                .unwrap_or_default()
        };
        if !errors {
            return Ok(Measurement {
                wall_s_per_frame,
                com_error_m: None,
                p95_error_m: None,
                object_wall_s_per_frame,
            });
        }
        if level.is_as_written(&self.window) {
            self.reference = Some(t);
            return Ok(Measurement {
                wall_s_per_frame,
                com_error_m: Some(0.0),
                p95_error_m: Some(0.0),
                object_wall_s_per_frame,
            });
        }
        if self.reference.is_none() {
            let as_written = LevelOfDetail::as_written(&self.window);
            self.reference = Some(self.run(&as_written, true)?);
        }
        let reference = self.reference.as_ref().context("no reference run")?;
        Ok(Measurement {
            wall_s_per_frame,
            com_error_m: Some(max_distance(&t.com, &reference.com)),
            p95_error_m: Some(gaussian_errors_cells(&t, reference, 1.0).1),
            object_wall_s_per_frame,
        })
    }
}

/// Chooses the level of detail of `scene` by calibration runs.
///
/// # Errors
/// Bad settings, a world that cannot be built or a failing calibration step.
pub fn calibrate(scene: &Scene, settings: CalibrationSettings, pb: &ProgressBar) -> Result<Choice> {
    let mut model = Calibration::new(scene, settings, pb)?;
    choose(scene, settings.budget_fps, &mut model)
}

/// The error of `level` against `scene` as written over the first `window_s` simulated seconds
/// (clamped to the scene): largest COM distance over the window and 95th percentile Gaussian
/// distance at its end, m. Zero without running when `level` is the scene as written. Runs the
/// scene as written and `level` on `threads` threads; `pb` counts their frames.
///
/// # Errors
/// A window shorter than one frame, a world that cannot be built, a failing step.
pub fn expected_error(
    scene: &Scene,
    level: &LevelOfDetail,
    window_s: f64,
    threads: usize,
    pb: &ProgressBar,
) -> Result<(f64, f64)> {
    if level.is_as_written(scene) {
        return Ok((0.0, 0.0));
    }
    // Runs that measure errors go to the window's end: the budget stops none of them.
    let settings = CalibrationSettings {
        budget_fps: 1.0,
        window_s,
        threads,
        errors: true,
    };
    let mut model = Calibration::new(scene, settings, pb)?;
    let as_written = LevelOfDetail::as_written(scene);
    model.measure(&as_written)?;
    let m = model.measure(level)?;
    Ok((
        m.com_error_m.context("no COM error")?,
        m.p95_error_m.context("no Gaussian error")?,
    ))
}
