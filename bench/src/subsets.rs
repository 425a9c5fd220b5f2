//! `splatphys bench subsets`: physics-particle subsets (`physics_spacing_m`,
//! `splatphys_core::world::carry`) on a real captured scene, error against speed-up.
//!
//! The scene runs once with every Gaussian a particle (ratio 1, the reference) and once per
//! subset ratio 1/r: the spacing h that gives about (Gaussians of the moving objects) / r
//! particles is found by bisection on log h over the voxel count (the count is not strictly
//! monotone in h, so the closest count seen is kept and the achieved ratio printed). Every run
//! simulates the scene's duration (or `--duration-s`). Per run:
//! - wall time of the frame loop (building the world, carry included, is `build_s`), and the
//!   speed-up against ratio 1 in the same process; on Linux also the process CPU time of the
//!   loop (`cpu_s`, all threads, from /proc/self/stat, COM measurement included) and its
//!   speed-up, which another job on the machine disturbs far less than the wall time;
//! - COM error: the largest |COM − COM_full| over frames and moving objects, in m and in grid
//!   cells (dx);
//! - Gaussian error at the end: |x_g − x_g,full| over every published Gaussian of the moving
//!   objects, mean and 95th percentile, in grid cells.
//!
//! JSON lines on stdout; `subsets.csv`, `subsets.svg` and `subsets.png` in `--out-dir`.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use glam::Vec3A;
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;
use splatphys::trace::{Trace, gaussian_errors_cells, max_distance, moving, run_scene};
use splatphys_core::scene::Scene;
use splatphys_core::world::carry::subset_count;

use crate::chart::{self, Series};

/// Arguments of `bench subsets`.
#[derive(Args, Debug)]
pub struct SubsetsBenchArgs {
    /// The scene (a captured one; static objects keep every Gaussian).
    #[arg(long, default_value = "scenes/donut_drop.toml")]
    pub scene: PathBuf,
    /// Simulated time per run (s); default: the scene's duration.
    #[arg(long)]
    pub duration_s: Option<f64>,
    /// Subset ratios as denominators r (1/r of the Gaussians simulated); 1 is always run first,
    /// as the reference.
    #[arg(long, value_delimiter = ',', default_value = "1,2,4,8,16,32,64")]
    pub ratios: Vec<u32>,
    /// Worker threads.
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Where `subsets.csv`, `.svg` and `.png` go.
    #[arg(long, default_value = "docs/results/bench")]
    pub out_dir: PathBuf,
}

/// Gaussian centres of the moving objects, one list per object.
fn centres(scene: &Scene) -> Vec<Vec<Vec3A>> {
    moving(scene)
        .into_iter()
        .map(|k| {
            let g = &scene.objects[k].gaussians;
            g.positions.iter().map(|p| Vec3A::from(*p)).collect()
        })
        .collect()
}

/// The spacing (m) whose voxel count over `objects` is closest to `target`, and that count.
fn spacing_for(objects: &[Vec<Vec3A>], target: f64) -> (f32, usize) {
    let count = |h: f32| objects.iter().map(|x| subset_count(x, h)).sum::<usize>();
    let extent = objects
        .iter()
        .flatten()
        .fold((Vec3A::INFINITY, Vec3A::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    let (mut lo, mut hi) = (
        1e-6f64.ln(),
        ((extent.1 - extent.0).length().max(1e-3) as f64).ln(),
    );
    let mut best = (hi.exp() as f32, count(hi.exp() as f32));
    for _ in 0..48 {
        let mid = 0.5 * (lo + hi);
        let h = mid.exp() as f32;
        let n = count(h);
        if (n as f64 - target).abs() < (best.1 as f64 - target).abs() {
            best = (h, n);
        }
        if n as f64 > target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    best
}

/// Runs the benchmark.
pub fn run(a: &SubsetsBenchArgs) -> Result<()> {
    if a.ratios.iter().any(|&r| r == 0 || r > 4096) {
        bail!(
            "--ratios: denominators must be in 1..=4096, got {:?}",
            a.ratios
        );
    }
    let (name, scene) = splatphys_core::scene::load_named(Some(&a.scene), a.duration_s)?;
    let ids = moving(&scene);
    if ids.is_empty() {
        bail!(
            "{}: no deformable or rigid object to subsample",
            a.scene.display()
        );
    }
    let objects = centres(&scene);
    let total: usize = objects.iter().map(Vec::len).sum();
    let dx = scene.simulation.grid_dx_m;
    let mut ratios = vec![1u32];
    ratios.extend(a.ratios.iter().copied().filter(|&r| r != 1));
    ratios.dedup();
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("creating {}", a.out_dir.display()))?;
    let pool = crate::thread_pool(a.threads)?;
    let frames = (scene.simulation.duration_s * scene.simulation.frame_rate_hz).round() as u64;
    let pb = ProgressBar::new(frames * ratios.len() as u64);
    pb.set_style(
        ProgressStyle::with_template("subsets {msg} [{bar:30}] {pos}/{len} frames {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut reference: Option<Trace> = None;
    let mut rows = Vec::new();
    for &r in &ratios {
        let mut s = scene.clone();
        let spacing = if r == 1 {
            None
        } else {
            let (h, _) = spacing_for(&objects, total as f64 / r as f64);
            for &k in &ids {
                // The subset on the scene's grid: what thinning alone costs.
                s.objects[k].physics_spacing_m = Some(h);
                s.objects[k].grid_dx_m = Some(s.simulation.grid_dx_m);
            }
            Some(h)
        };
        pb.set_message(format!("1/{r}"));
        let trace = pool.install(|| run_scene(&s, &pb))?;
        let full = reference.as_ref().unwrap_or(&trace);
        let com_error_m = max_distance(&trace.com, &full.com);
        let (mean, p95, max) = gaussian_errors_cells(&trace, full, dx);
        let row = json!({
            "bench": "subsets",
            "scene": name,
            "ratio": format!("1/{r}"),
            "target_ratio": 1.0 / r as f64,
            "spacing_m": spacing,
            "gaussians": total,
            "particles": trace.particles,
            "achieved_ratio": trace.particles as f64 / total as f64,
            "dx_m": dx,
            "duration_s": scene.simulation.duration_s,
            "threads": a.threads,
            "substeps": trace.substeps,
            "build_s": trace.build_s,
            "wall_s": trace.wall_s,
            "speedup": full.wall_s / trace.wall_s,
            "cpu_s": trace.cpu_s,
            "cpu_speedup": full.cpu_s.zip(trace.cpu_s).map(|(a, b)| a / b),
            "com_error_m": com_error_m,
            "com_error_cells": com_error_m / dx,
            "gaussian_error_mean_cells": mean,
            "gaussian_error_p95_cells": p95,
            "gaussian_error_max_cells": max,
        });
        pb.suspend(|| println!("{row}"));
        rows.push(row);
        if reference.is_none() {
            reference = Some(trace);
        }
    }
    pb.finish_and_clear();
    let stem = a.out_dir.join("subsets");
    let columns = [
        "scene",
        "ratio",
        "target_ratio",
        "spacing_m",
        "gaussians",
        "particles",
        "achieved_ratio",
        "dx_m",
        "duration_s",
        "threads",
        "substeps",
        "build_s",
        "wall_s",
        "speedup",
        "cpu_s",
        "cpu_speedup",
        "com_error_m",
        "com_error_cells",
        "gaussian_error_mean_cells",
        "gaussian_error_p95_cells",
        "gaussian_error_max_cells",
    ];
    chart::write_columns_csv(&stem.with_extension("csv"), &columns, &rows)?;
    let series = |label: &str, key: &str| Series {
        name: label.to_string(),
        // Ratio 1 is the reference (zero error by definition), left off the chart.
        points: rows
            .iter()
            .skip(1)
            .map(|r| {
                (
                    r["speedup"].as_f64().unwrap_or(f64::NAN),
                    r[key].as_f64().unwrap_or(f64::NAN),
                )
            })
            .collect(),
    };
    let labels: Vec<String> = rows
        .iter()
        .skip(1)
        .map(|r| r["ratio"].as_str().unwrap_or("").to_string())
        .collect();
    chart::line_chart(
        &stem,
        &format!("Physics-particle subsets, {name}: error vs speed-up"),
        &format!(
            "speed-up over every Gaussian a particle (points: ratios {})",
            labels.join(", ")
        ),
        "error (grid cells)",
        &[
            series("COM, max over frames", "com_error_cells"),
            series("Gaussians at the end, mean", "gaussian_error_mean_cells"),
            series("Gaussians at the end, p95", "gaussian_error_p95_cells"),
        ],
        false,
        false,
    )?;
    Ok(())
}
