//! The calibration behind `splatphys run --budget-fps`: short timed runs of a scene at each level
//! of detail ([`splatphys_core::scene::level_of_detail`]), measured against the scene as written.
//!
//! Each run simulates the first `window_s` seconds of the scene on the run's thread count, through
//! the same code as `bench realtime` (no renderer or recorder). Its cost is the wall time of the
//! frame loop per frame (the world build is not counted); its error is the largest COM distance
//! over the window and the 95th percentile Gaussian distance at its end, against the scene as
//! written over the same window. Both describe the window only: a scene whose hard part (an
//! impact, a push) comes later costs more there than the calibration saw.

use anyhow::{Context, Result};
use indicatif::ProgressBar;
use splatphys_core::scene::level_of_detail::{Choice, CostModel, Measurement, choose};
use splatphys_core::scene::{LevelOfDetail, Scene};

use crate::subsets::{Trace, gaussian_errors_cells, max_distance, run_scene};

/// Timed calibration runs of one scene: a [`CostModel`].
pub struct Calibration<'a> {
    /// The scene, cut to the calibration window.
    window: Scene,
    pool: rayon::ThreadPool,
    reference: Option<Trace>,
    pb: &'a ProgressBar,
}

impl<'a> Calibration<'a> {
    /// Calibration of `scene` over its first `window_s` simulated seconds on `threads` threads;
    /// `pb` counts simulated frames.
    ///
    /// # Errors
    /// `window_s` not positive, or shorter than one frame; a thread pool that cannot start.
    pub fn new(scene: &Scene, window_s: f64, threads: usize, pb: &'a ProgressBar) -> Result<Self> {
        let frame_s = 1.0 / scene.simulation.frame_rate_hz;
        if !(window_s.is_finite() && window_s >= frame_s) {
            anyhow::bail!(
                "calibration window {window_s} s: give at least one frame ({frame_s:.4} s)"
            );
        }
        let mut window = scene.clone();
        window.simulation.duration_s = window_s.min(scene.simulation.duration_s);
        Ok(Self {
            window,
            pool: crate::thread_pool(threads)?,
            reference: None,
            pb,
        })
    }

    /// Frames each calibration run simulates.
    pub fn frames(&self) -> u64 {
        let s = &self.window.simulation;
        (s.duration_s * s.frame_rate_hz).round() as u64
    }

    fn run(&self, level: &LevelOfDetail) -> Result<Trace> {
        let mut s = self.window.clone();
        level.apply(&mut s)?;
        self.pb
            .set_message(format!("dx {:.1} mm", level.grid_dx_m * 1e3));
        self.pool
            .install(|| run_scene(&s, self.pb))
            .with_context(|| format!("calibration run at dx {} m", level.grid_dx_m))
    }
}

impl CostModel for Calibration<'_> {
    type Error = anyhow::Error;

    fn measure(&mut self, level: &LevelOfDetail) -> Result<Measurement> {
        let t = self.run(level)?;
        let frames = t.com.len().max(1) as f64;
        let wall_s_per_frame = t.wall_s / frames;
        if level.is_as_written(&self.window) {
            self.reference = Some(t);
            return Ok(Measurement {
                wall_s_per_frame,
                com_error_m: 0.0,
                p95_error_m: 0.0,
            });
        }
        if self.reference.is_none() {
            let as_written = LevelOfDetail::as_written(&self.window);
            self.reference = Some(self.run(&as_written)?);
        }
        let reference = self.reference.as_ref().context("no reference run")?;
        Ok(Measurement {
            wall_s_per_frame,
            com_error_m: max_distance(&t.com, &reference.com),
            p95_error_m: gaussian_errors_cells(&t, reference, 1.0).1,
        })
    }
}

/// Chooses the level of detail of `scene` for `budget_fps` by calibration runs of `window_s`
/// simulated seconds on `threads` threads.
///
/// # Errors
/// A bad window, a world that cannot be built or a failing calibration step.
pub fn calibrate(
    scene: &Scene,
    budget_fps: f64,
    window_s: f64,
    threads: usize,
    pb: &ProgressBar,
) -> Result<Choice> {
    let mut model = Calibration::new(scene, window_s, threads, pb)?;
    choose(scene, budget_fps, &mut model)
}
