//! `splatphys bench realtime`: how fast a captured scene can run, and what accuracy that costs
//! (goal: 30 simulated frames per wall second on 2 cores).
//!
//! Thinning the particles at a fixed grid (`bench subsets`) leaves too few particles per cell for
//! MLS-MPM, so here the grid is coarsened together with the particles. Per scene:
//! - the **reference** is the scene as written (every Gaussian a particle, its own `grid_dx_m`,
//!   called dx_ref);
//! - one **rigid** candidate (unless `--no-rigid`, and only where the scene has deformable
//!   objects) makes every deformable object rigid: the COM layer alone, no MPM, the coarsest
//!   model of all (the "model no more than a scene needs"); it shows what the scene's
//!   deformation is worth in position error;
//! - each **grid** candidate sets `grid_dx_m = dx` (`--dx-factor` × dx_ref, or `--dx-m`) and the
//!   physics-particle spacing of every moving object to `--spacing-per-dx` × dx (default 1/2:
//!   about 2 particles per cell per axis, MPM's usual 8 per cell);
//! - every run simulates the same time (the scene's duration, or `--duration-s`) on `--threads`
//!   threads in this process (no renderer or recorder), through the same code as `bench subsets`.
//!
//! Measured per run: wall time of the frame loop (the world build is `build_s`), simulated frames
//! per wall second (frames / wall_s) and the real-time factor (simulated s / wall s), speed-up
//! against the reference, substeps and the CFL limit at the end with the material that sets it
//! (as `splatphys run --explain`); errors against the reference, all in **cells of the reference
//! grid** (dx_ref): the COM trajectory (largest |COM − COM_ref| over frames and moving objects;
//! also its part present before the first step, from particle volumes that depend on dx, and the
//! error of the displacement COM(t) − COM(0)), and every moving Gaussian's position at the end
//! (mean, 95th percentile, max).
//!
//! A setting passes when its COM error and its Gaussian p95 error are both under one reference
//! cell; the summary line per scene names the fastest passing setting and whether it reaches
//! `--target-fps`. JSON lines on stdout; `realtime.csv`, `.svg`, `.png` in `--out-dir`.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::{Value, json};

use splatphys_core::scene::{Device, ObjectKind, Scene, SceneObject};

use crate::chart::{self, Series};
use splatphys::trace::{Trace, gaussian_errors_cells, max_distance, moving, run_scene};

/// Arguments of `bench realtime`.
#[derive(Args, Debug)]
pub struct RealtimeBenchArgs {
    /// Scenes, each swept separately against its own reference run.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "scenes/donut_snow_push.toml,scenes/guitar_topple.toml"
    )]
    pub scenes: Vec<PathBuf>,
    /// Simulated time per run (s): one value for every scene or one per scene; default: each
    /// scene's duration. The reference and the candidates of a scene run the same time.
    #[arg(long, value_delimiter = ',')]
    pub duration_s: Vec<f64>,
    /// Candidate grid cell sizes as multiples of each scene's own grid_dx_m.
    #[arg(long, value_delimiter = ',', default_value = "1,1.5,2,3,4")]
    pub dx_factor: Vec<f64>,
    /// Candidate grid cell sizes in metres for every scene (replaces --dx-factor).
    #[arg(long, value_delimiter = ',')]
    pub dx_m: Vec<f64>,
    /// Physics-particle spacing of the candidates as a fraction of their dx (0.5: about 8
    /// particles per cell).
    #[arg(long, default_value_t = 0.5)]
    pub spacing_per_dx: f64,
    /// Leave out the candidate that makes every deformable object rigid.
    #[arg(long)]
    pub no_rigid: bool,
    /// Where the grid candidates' MPM runs: `cpu`, `gpu`, or both (`cpu,gpu`: each candidate
    /// twice, side by side; the reference always on the CPU). A GPU run's deformable objects step
    /// there while only grid colliders reach them (`[simulation] device`).
    #[arg(long, value_delimiter = ',', default_value = "cpu", value_parser = parse_device)]
    pub device: Vec<Device>,
    /// Simulated frames per wall second to reach.
    #[arg(long, default_value_t = 30.0)]
    pub target_fps: f64,
    /// Worker threads.
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Where `realtime.csv`, `.svg` and `.png` go.
    #[arg(long, default_value = "docs/results/bench")]
    pub out_dir: PathBuf,
}

fn parse_device(s: &str) -> Result<Device, String> {
    s.parse::<Device>().map_err(|e| e.to_string())
}

/// CSV columns, in order.
const COLUMNS: [&str; 33] = [
    "scene",
    "setting",
    "dx_m",
    "dx_ref_m",
    "spacing_m",
    "duration_s",
    "frames",
    "threads",
    "gaussians",
    "particles",
    "grid_blocks",
    "substeps",
    "substeps_per_sim_s",
    "dt_min_s",
    "dt_max_s",
    "dt_limit_s",
    "wave_speed_m_s",
    "limited_by",
    "build_s",
    "wall_s",
    "cpu_s",
    "us_per_substep",
    "frames_per_wall_s",
    "realtime_factor",
    "speedup",
    "com_error_m",
    "com_error_cells",
    "com_initial_offset_cells",
    "com_displacement_error_cells",
    "gaussian_error_mean_cells",
    "gaussian_error_p95_cells",
    "gaussian_error_max_cells",
    "passes",
];

/// Errors below this (in reference cells) are drawn at it on the log axis.
const CHART_FLOOR_CELLS: f64 = 1e-4;

/// The comparison of `t` against `reference` as a JSON row (`setting`, `dx`, `spacing` named by
/// the caller). Errors in cells of `dx_ref`.
fn row(
    scene: &str,
    setting: &str,
    (dx, dx_ref, spacing): (f64, f64, Option<f64>),
    (duration_s, frames, threads): (f64, usize, usize),
    t: &Trace,
    reference: &Trace,
) -> Result<Value> {
    if t.gaussians.len() != reference.gaussians.len() || t.com.len() != reference.com.len() {
        bail!(
            "{scene} {setting}: {} Gaussians over {} frames, the reference {} over {}: not \
             comparable",
            t.gaussians.len(),
            t.com.len(),
            reference.gaussians.len(),
            reference.com.len()
        );
    }
    let com_error_m = max_distance(&t.com, &reference.com);
    let offset0 = t
        .com0
        .iter()
        .zip(&reference.com0)
        .map(|(a, b)| (*a - *b).length())
        .fold(0.0, f64::max);
    let displacement = |tr: &Trace| -> Vec<Vec<glam::DVec3>> {
        tr.com
            .iter()
            .map(|f| f.iter().zip(&tr.com0).map(|(c, c0)| *c - *c0).collect())
            .collect()
    };
    let displacement_m = max_distance(&displacement(t), &displacement(reference));
    let (mean, p95, max) = gaussian_errors_cells(t, reference, dx_ref);
    let e = &t.explain;
    let limit = e
        .objects
        .iter()
        .filter_map(|o| o.dt_limit_s.map(|dt| (dt, o)))
        .min_by(|a, b| a.0.total_cmp(&b.0));
    let fps = frames as f64 / t.wall_s;
    Ok(json!({
        "bench": "realtime",
        "scene": scene,
        "setting": setting,
        "dx_m": dx,
        "dx_ref_m": dx_ref,
        "spacing_m": spacing,
        "duration_s": duration_s,
        "frames": frames,
        "threads": threads,
        "gaussians": t.gaussians.len(),
        "particles": t.particles,
        "grid_blocks": e.objects.iter().map(|o| o.grid_blocks).sum::<usize>(),
        "substeps": t.substeps,
        "substeps_per_sim_s": t.substeps as f64 / duration_s,
        "dt_min_s": e.dt_range_s[0],
        "dt_max_s": e.dt_range_s[1],
        "dt_limit_s": limit.map(|l| l.0),
        "wave_speed_m_s": limit.and_then(|l| l.1.wave_speed_m_s),
        "limited_by": e.limited_by.clone().unwrap_or_else(|| "none (no MPM)".into()),
        "build_s": t.build_s,
        "wall_s": t.wall_s,
        "cpu_s": t.cpu_s,
        "us_per_substep": 1e6 * t.wall_s / t.substeps.max(1) as f64,
        "frames_per_wall_s": fps,
        "realtime_factor": duration_s / t.wall_s,
        "speedup": reference.wall_s / t.wall_s,
        "com_error_m": com_error_m,
        "com_error_cells": com_error_m / dx_ref,
        "com_initial_offset_cells": offset0 / dx_ref,
        "com_displacement_error_cells": displacement_m / dx_ref,
        "gaussian_error_mean_cells": mean,
        "gaussian_error_p95_cells": p95,
        "gaussian_error_max_cells": max,
        "passes": com_error_m / dx_ref < 1.0 && p95 < 1.0,
    }))
}

/// The per-scene summary: the fastest passing setting, or which criterion failed first.
fn summary(scene: &str, rows: &[Value], target_fps: f64) -> Value {
    let f = |r: &Value, k: &str| r[k].as_f64().unwrap_or(f64::NAN);
    let fastest = rows
        .iter()
        .filter(|r| r["passes"].as_bool() == Some(true))
        .max_by(|a, b| f(a, "frames_per_wall_s").total_cmp(&f(b, "frames_per_wall_s")));
    // The first candidate (in sweep order, finest first) that fails, and why.
    let first_failure = rows.iter().find(|r| r["passes"].as_bool() == Some(false));
    let why = first_failure.map(|r| {
        let com = f(r, "com_error_cells") >= 1.0;
        let p95 = f(r, "gaussian_error_p95_cells") >= 1.0;
        let what = match (com, p95) {
            (true, true) => "COM and Gaussian p95",
            (true, false) => "COM",
            _ => "Gaussian p95",
        };
        format!("{} fails on {what}", r["setting"].as_str().unwrap_or(""))
    });
    json!({
        "bench": "realtime-summary",
        "scene": scene,
        "error_unit": format!("cells of the reference grid, dx_ref = {} mm",
            f(&rows[0], "dx_ref_m") * 1e3),
        "fastest_under_one_cell": fastest.map(|r| r["setting"].clone()),
        "its_frames_per_wall_s": fastest.map(|r| f(r, "frames_per_wall_s")),
        "target_frames_per_wall_s": target_fps,
        "target_met": fastest.is_some_and(|r| f(r, "frames_per_wall_s") >= target_fps),
        "first_failure": why,
        "fastest_overall_frames_per_wall_s": rows.iter().map(|r| f(r, "frames_per_wall_s"))
            .fold(0.0, f64::max),
    })
}

/// Runs the benchmark.
pub fn run(a: &RealtimeBenchArgs) -> Result<()> {
    if a.scenes.is_empty() {
        bail!("--scenes: name at least one scene");
    }
    if !(a.duration_s.len() <= 1 || a.duration_s.len() == a.scenes.len()) {
        bail!(
            "--duration-s: give one value or one per scene ({} scenes, {} values)",
            a.scenes.len(),
            a.duration_s.len()
        );
    }
    let bad = |v: &f64| !(v.is_finite() && *v > 0.0);
    if a.dx_factor.iter().any(bad) || a.dx_m.iter().any(bad) || bad(&a.spacing_per_dx) {
        bail!("--dx-factor, --dx-m and --spacing-per-dx must be positive numbers");
    }
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("creating {}", a.out_dir.display()))?;
    let pool = crate::thread_pool(a.threads)?;
    let mut scenes = Vec::new();
    for (i, path) in a.scenes.iter().enumerate() {
        let duration = a.duration_s.get(i).or(a.duration_s.first()).copied();
        let (name, scene) = splatphys_core::scene::load_named(Some(path), duration)?;
        if moving(&scene).is_empty() {
            bail!("{}: no deformable or rigid object", path.display());
        }
        scenes.push((name, scene));
    }
    let grids = if a.dx_m.is_empty() {
        a.dx_factor.len()
    } else {
        a.dx_m.len()
    } as u64
        * a.device.len() as u64;
    let total_frames: u64 = scenes
        .iter()
        .map(|(_, s)| {
            let runs = 1 + grids + u64::from(rigid_variant(s, a).is_some());
            runs * (s.simulation.duration_s * s.simulation.frame_rate_hz).round() as u64
        })
        .sum();
    let pb = ProgressBar::new(total_frames);
    pb.set_style(
        ProgressStyle::with_template("realtime {msg} [{bar:30}] {pos}/{len} frames {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut rows = Vec::new();
    let mut summaries = Vec::new();
    for (name, scene) in &scenes {
        let dx_ref = scene.simulation.grid_dx_m;
        let dxs: Vec<f64> = if a.dx_m.is_empty() {
            a.dx_factor.iter().map(|f| f * dx_ref).collect()
        } else {
            a.dx_m.clone()
        };
        let sim = &scene.simulation;
        // Runs `s` and prints and returns its row against `reference` (itself when `None`).
        let run = |s: &Scene,
                   setting: &str,
                   dxs: (f64, Option<f64>),
                   reference: Option<&Trace>|
         -> Result<(Trace, Value)> {
            pb.set_message(format!("{name} {setting}"));
            let t = pool.install(|| run_scene(s, &pb))?;
            let reference = reference.unwrap_or(&t);
            let info = (sim.duration_s, reference.com.len(), a.threads);
            let r = row(name, setting, (dxs.0, dx_ref, dxs.1), info, &t, reference)?;
            pb.suspend(|| println!("{r}"));
            Ok((t, r))
        };
        let (reference, r) = run(scene, "reference", (dx_ref, None), None)?;
        let mut scene_rows = vec![r];
        for &dx in &dxs {
            for &device in &a.device {
                let mut s = scene.clone();
                let h = dx * a.spacing_per_dx;
                s.simulation.grid_dx_m = dx;
                s.simulation.device = device;
                for k in moving(&s) {
                    s.objects[k].physics_spacing_m = Some(h as f32);
                    s.objects[k].grid_dx_m = Some(dx);
                }
                let on = match device {
                    Device::Cpu => "",
                    Device::Gpu => " on gpu",
                };
                let setting = format!("dx {:.1} mm / h {:.2} mm{on}", dx * 1e3, h * 1e3);
                scene_rows.push(run(&s, &setting, (dx, Some(h)), Some(&reference))?.1);
            }
        }
        if let Some(s) = rigid_variant(scene, a) {
            let setting = "rigid (COM layer only)";
            scene_rows.push(run(&s, setting, (dx_ref, None), Some(&reference))?.1);
        }
        let s = summary(name, &scene_rows, a.target_fps);
        pb.suspend(|| println!("{s}"));
        summaries.push(s);
        rows.extend(scene_rows);
    }
    pb.finish_and_clear();
    let stem = a.out_dir.join("realtime");
    chart::write_columns_csv(&stem.with_extension("csv"), &COLUMNS, &rows)?;
    draw(&stem, &scenes, &rows, a)?;
    Ok(())
}

/// `scene` with every deformable object made rigid, or `None` when it has none (or
/// `--no-rigid`).
fn rigid_variant(scene: &Scene, a: &RealtimeBenchArgs) -> Option<Scene> {
    let deformable = |o: &SceneObject| o.kind == ObjectKind::Deformable;
    if a.no_rigid || !scene.objects.iter().any(deformable) {
        return None;
    }
    let mut s = scene.clone();
    for o in s.objects.iter_mut().filter(|o| deformable(o)) {
        o.kind = ObjectKind::Rigid;
    }
    Some(s)
}

/// Error (reference cells) against simulated frames per wall second, COM and Gaussian p95 per
/// scene, with the 1-cell and target-fps lines drawn as two-point series (line_chart has no
/// reference lines of its own).
fn draw(
    stem: &std::path::Path,
    scenes: &[(String, Scene)],
    rows: &[Value],
    a: &RealtimeBenchArgs,
) -> Result<()> {
    let f = |r: &Value, k: &str| r[k].as_f64().unwrap_or(f64::NAN);
    let mut series = Vec::new();
    for (name, scene) in scenes {
        let mut candidates: Vec<&Value> = rows
            .iter()
            .filter(|r| r["scene"] == name.as_str() && r["setting"] != "reference")
            .collect();
        candidates.sort_by(|a, b| f(a, "frames_per_wall_s").total_cmp(&f(b, "frames_per_wall_s")));
        for (label, key) in [
            ("COM, max over frames", "com_error_cells"),
            ("Gaussians at the end, p95", "gaussian_error_p95_cells"),
        ] {
            series.push(Series {
                name: format!(
                    "{name} (dx_ref {} mm): {label}",
                    scene.simulation.grid_dx_m * 1e3
                ),
                points: candidates
                    .iter()
                    .map(|r| (f(r, "frames_per_wall_s"), f(r, key).max(CHART_FLOOR_CELLS)))
                    .collect(),
            });
        }
    }
    let xs = || series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
    let ys = || series.iter().flat_map(|s| s.points.iter().map(|p| p.1));
    let x_lo = xs().fold(a.target_fps, f64::min) / 1.5;
    let x_hi = xs().fold(a.target_fps, f64::max) * 1.5;
    let y_lo = ys().fold(1.0, f64::min) / 1.5;
    let y_hi = ys().fold(1.0, f64::max) * 1.5;
    series.push(Series {
        name: "1 reference cell (pass below)".into(),
        points: vec![(x_lo, 1.0), (x_hi, 1.0)],
    });
    series.push(Series {
        name: format!("{} simulated frames per wall s (pass right)", a.target_fps),
        points: vec![(a.target_fps, y_lo), (a.target_fps, y_hi)],
    });
    let durations: Vec<String> = scenes
        .iter()
        .map(|(n, s)| format!("{n} {} s", s.simulation.duration_s))
        .collect();
    chart::line_chart(
        stem,
        &format!(
            "Real time, {} threads: error vs speed, dx swept with h = {} dx{}",
            a.threads,
            a.spacing_per_dx,
            if a.no_rigid { "" } else { ", plus rigid" }
        ),
        &format!(
            "simulated frames per wall second (runs of {})",
            durations.join(", ")
        ),
        &format!("error, cells of the reference grid (< {CHART_FLOOR_CELLS} drawn at it)"),
        &series,
        true,
        true,
    )?;
    Ok(())
}
