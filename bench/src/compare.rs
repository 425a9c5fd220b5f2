//! `splatphys bench compare`: the COM method against the two baselines (`mpm`, one shared grid;
//! `multi-field`, Bardenhagen et al. 2000), speed against accuracy.
//!
//! 1. Accuracy: two equal elastic spheres (radius 4 cm, E = 2e5 Pa, nu = 0.3, 1000 kg/m³) meet
//!    head-on at ±1 m/s with no gravity, restitution e (default 0.5), at several grid cell sizes
//!    (particle spacing dx / 2). Error = the larger of the two spheres' |v' - v_law| over the
//!    approach speed (2 m/s), v_law from the 1D restitution law with the measured masses; the
//!    baselines have no e of their own, so their error is what their contact physics gives.
//! 2. Scaling: 2 and 8 separated spheres (particle spacing dx / 2, dx = 1 cm) moving together at
//!    0.5 m/s, wall time per substep from 10k to 1M particles in all.
//!
//! Writes JSON lines to stdout and `compare_accuracy.{csv,svg,png}` and
//! `compare_scaling.{csv,svg,png}` into `--out-dir`.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;
use splatphys_core::material::MaterialSpec;
use splatphys_core::scene::{Method, Scene, SceneBuilder, SceneObject};
use splatphys_core::world::World;

use crate::chart::{self, Series};

/// Methods compared, in chart order.
const METHODS: [Method; 3] = Method::ALL;

/// Arguments of `bench compare`.
#[derive(Args, Debug)]
pub struct CompareBenchArgs {
    /// Grid cell sizes (m) for the accuracy runs.
    #[arg(long, value_delimiter = ',', default_value = "0.02,0.01,0.0067,0.005")]
    pub dx_m: Vec<f64>,
    /// Restitution coefficient e of the accuracy runs.
    #[arg(long, default_value_t = 0.5)]
    pub restitution: f64,
    /// Total particle counts for the scaling runs.
    #[arg(long, value_delimiter = ',', default_value = "10000,100000,1000000")]
    pub particles: Vec<usize>,
    /// Object counts for the scaling runs.
    #[arg(long, value_delimiter = ',', default_value = "2,8")]
    pub objects: Vec<usize>,
    /// Timed substeps per scaling run (after 2 warm-up substeps).
    #[arg(long, default_value_t = 5)]
    pub substeps: u32,
    /// Worker threads.
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Where the CSV files and charts go.
    #[arg(long, default_value = "docs/results/bench")]
    pub out_dir: PathBuf,
}

/// Runs the comparison.
pub fn run(a: &CompareBenchArgs) -> Result<()> {
    if a.dx_m
        .iter()
        .any(|d| !(d.is_finite() && *d >= 0.002 && *d <= 0.05))
    {
        bail!(
            "--dx-m: every cell size must be in [0.002, 0.05] m, got {:?}",
            a.dx_m
        );
    }
    if a.objects.iter().any(|&k| k == 0 || k > 64) {
        bail!("--objects: counts must be in 1..=64, got {:?}", a.objects);
    }
    if a.particles.iter().any(|n| !(100..=20_000_000).contains(n)) {
        bail!(
            "--particles: counts must be in 100..=20000000, got {:?}",
            a.particles
        );
    }
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("creating {}", a.out_dir.display()))?;
    let pool = crate::thread_pool(a.threads)?;
    pool.install(|| {
        accuracy(a)?;
        scaling(a)
    })
}

fn bar(len: usize, what: &str) -> ProgressBar {
    let pb = ProgressBar::new(len as u64);
    pb.set_style(
        ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    pb.set_message(what.to_string());
    pb
}

/// The head-on sphere pair of the accuracy runs (also `bench spheres`).
pub(crate) fn sphere_pair(method: Method, dx_m: f64, e: f64) -> SceneBuilder {
    let sphere = |name: &str, x_m: f32, vx_m_s: f32| {
        SceneObject::sphere(name, [x_m, 0.0, 0.0], 0.04)
            .spacing_m((dx_m / 2.0) as f32)
            .material(MaterialSpec::jelly(2e5, 0.3, 1000.0))
            .restitution(e as f32)
            .friction(0.0)
            .velocity([vx_m_s, 0.0, 0.0])
    };
    Scene::builder()
        .method(method)
        .duration_s(0.3)
        .frame_rate_hz(100.0)
        .grid_dx_m(dx_m)
        .gravity_m_s2([0.0, 0.0, 0.0])
        .object(sphere("left", -0.08, 1.0))
        .object(sphere("right", 0.08, -1.0))
}

pub(crate) fn world(scene: &SceneBuilder) -> Result<World> {
    let scene = scene.build().context("generated scene")?;
    Ok(World::from_scene(&scene)?)
}

fn accuracy(a: &CompareBenchArgs) -> Result<()> {
    let pb = bar(METHODS.len() * a.dx_m.len(), "accuracy");
    let mut rows = Vec::new();
    for method in METHODS {
        for &dx in &a.dx_m {
            let mut w = world(&sphere_pair(method, dx, a.restitution))?;
            let particles = w.particle_count();
            let t = Instant::now();
            while !w.is_finished() {
                w.advance_frame()?;
            }
            let seconds = t.elapsed().as_secs_f64();
            let o = w.objects();
            let (m1, m2) = (o[0].mass_kg, o[1].mass_kg);
            let (v1, v2, e) = (1.0, -1.0, a.restitution);
            let p = m1 * v1 + m2 * v2;
            let law1 = (p - m2 * e * (v1 - v2)) / (m1 + m2);
            let law2 = (p + m1 * e * (v1 - v2)) / (m1 + m2);
            let (u1, u2) = (o[0].velocity_m_s[0], o[1].velocity_m_s[0]);
            let error = (u1 - law1).abs().max((u2 - law2).abs()) / (v1 - v2);
            let s = w.stats();
            let com_fraction = s.com_layer_wall_s / (s.mpm_wall_s + s.com_layer_wall_s);
            let row = json!({
                "bench": "compare_accuracy",
                "method": method.name(),
                "dx_m": dx,
                "particles": particles,
                "restitution": e,
                "v1_m_s": u1, "v2_m_s": u2, "v1_law_m_s": law1, "v2_law_m_s": law2,
                "relative_error": error,
                "wall_s": seconds,
                "substeps": s.substeps,
                "com_layer_fraction": com_fraction,
            });
            pb.suspend(|| println!("{row}"));
            rows.push(row);
            pb.inc(1);
        }
    }
    pb.finish_and_clear();
    let stem = a.out_dir.join("compare_accuracy");
    chart::write_rows_csv(&stem.with_extension("csv"), &rows)?;
    let series: Vec<Series> = METHODS
        .iter()
        .map(|m| Series {
            name: m.to_string(),
            points: rows
                .iter()
                .filter(|r| r["method"] == m.name())
                .map(|r| {
                    (
                        r["wall_s"].as_f64().unwrap_or(0.0),
                        r["relative_error"].as_f64().unwrap_or(0.0).max(1e-5),
                    )
                })
                .collect(),
        })
        .collect();
    chart::line_chart(
        &stem,
        &format!("Head-on spheres, e = {}: error vs wall time", a.restitution),
        &format!(
            "wall time for 0.3 s simulated (s); points: dx = {:?} m",
            a.dx_m
        ),
        "post-impact velocity error / approach speed",
        &series,
        true,
        true,
    )?;
    Ok(())
}

/// `k` spheres of `n` particles each in a row along x, two cells apart, all at 0.5 m/s along y.
fn sphere_row(method: Method, k: usize, n_total: usize, dx_m: f64) -> SceneBuilder {
    let spacing = dx_m / 2.0;
    let per = (n_total / k).max(1) as f64;
    let r = spacing * (3.0 * per / (4.0 * std::f64::consts::PI)).cbrt();
    let mut scene = Scene::builder()
        .method(method)
        .duration_s(10.0)
        .frame_rate_hz(30.0)
        .grid_dx_m(dx_m)
        .gravity_m_s2([0.0, 0.0, 0.0]);
    for i in 0..k {
        let x = i as f64 * (2.0 * r + 2.0 * dx_m);
        scene = scene.object(
            SceneObject::sphere(format!("s{i}"), [x as f32, 0.0, 0.0], r as f32)
                .spacing_m(spacing as f32)
                .material(MaterialSpec::jelly(2e5, 0.3, 1000.0))
                .velocity([0.0, 0.5, 0.0]),
        );
    }
    scene
}

fn scaling(a: &CompareBenchArgs) -> Result<()> {
    let dx = 0.01;
    let pb = bar(
        METHODS.len() * a.objects.len() * a.particles.len(),
        "scaling",
    );
    let mut rows = Vec::new();
    for &k in &a.objects {
        for method in METHODS {
            for &n in &a.particles {
                let mut w = world(&sphere_row(method, k, n, dx))?;
                let particles = w.particle_count();
                for _ in 0..2 {
                    w.substep(f64::INFINITY)?;
                }
                let before = *w.stats();
                let t = Instant::now();
                for _ in 0..a.substeps {
                    w.substep(f64::INFINITY)?;
                }
                let per_substep = t.elapsed().as_secs_f64() / a.substeps.max(1) as f64;
                let s = w.stats();
                let mpm = s.mpm_wall_s - before.mpm_wall_s;
                let com = s.com_layer_wall_s - before.com_layer_wall_s;
                let row = json!({
                    "bench": "compare_scaling",
                    "method": method.name(),
                    "objects": k,
                    "particles": particles,
                    "seconds_per_substep": per_substep,
                    "particle_substeps_per_s": particles as f64 / per_substep,
                    "com_layer_fraction": com / (mpm + com),
                    "threads": a.threads,
                });
                pb.suspend(|| println!("{row}"));
                rows.push(row);
                pb.inc(1);
            }
        }
    }
    pb.finish_and_clear();
    let stem = a.out_dir.join("compare_scaling");
    chart::write_rows_csv(&stem.with_extension("csv"), &rows)?;
    let mut series = Vec::new();
    for &k in &a.objects {
        for m in METHODS {
            series.push(Series {
                name: format!("{m}, {k} objects"),
                points: rows
                    .iter()
                    .filter(|r| r["method"] == m.name() && r["objects"] == k)
                    .map(|r| {
                        (
                            r["particles"].as_f64().unwrap_or(0.0),
                            1e3 * r["seconds_per_substep"].as_f64().unwrap_or(0.0),
                        )
                    })
                    .collect(),
            });
        }
    }
    chart::line_chart(
        &stem,
        &format!("Time per substep vs particles ({} threads)", a.threads),
        "particles",
        "wall time per substep (ms)",
        &series,
        true,
        true,
    )?;
    Ok(())
}
