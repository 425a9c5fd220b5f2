//! `splatphys bench stability`: the stability map. Which Young's modulus, Poisson's
//! ratio, impact speed and time step each method (`com`, `mpm`, `multi-field`) survives, for
//! every material model.
//!
//! The impact scene: two equal spheres of one material (radius 3 cm, particle spacing 5 mm,
//! about 900 particles each, density 1000 kg/m³, the scene defaults for everything else:
//! restitution 0.5, friction 0.3) on a grid of dx = 1 cm, no gravity and no colliders. The
//! striker moves at the impact speed v along +x into the target at rest; they start touching
//! (their nearest particles share a grid cell), so the impact begins at t = 0. A run lasts 1.5
//! Hertz contact times of the pair, t_H = 2.87 (m*² / (R* E*² v))^(1/5) with m* = m/2, R* = R/2,
//! E* = E / (2 (1 - nu²)), and is sampled at 40 frames.
//!
//! With no external force, total momentum and energy (kinetic + elastic; there is no potential)
//! must not grow. Recorded per run: finished or not (and the substep and kind of failure: NaN in
//! the grid or a particle, a particle leaving the grid, or energy above 100× its start), the
//! largest energy growth max_t E(t)/E(0) − 1, the deepest interpenetration in cells
//! ([`splatphys_core::world::overlap`]), the largest momentum drift |P(t) − P(0)| / |P(0)|. A run
//! is stable when it finished with energy growth <= 1 %. Elastic energy is the model's own
//! ψ(Fe): for the plastic models (snow, sand, metal, plasticine, foam) it is the elastic part only
//! (plastic work is dissipated), for snow with the hardened moduli of each particle.
//!
//! Planes, each for every method × material (`--quick`: only their corners):
//! - `auto_speed`: E (1e3 to 1e9 Pa) × v (0.1 to 20 m/s), nu = 0.3, automatic dt (C = 0.5, the
//!   scene default; `--auto-cfl` changes it);
//! - `auto_poisson`: E × nu (0 to 0.49), v = 2 m/s, automatic dt;
//! - `forced_cfl`: CFL number C (0.1 to 2) × E, nu = 0.3, v = 2 m/s, a fixed forced
//!   dt = C dx / (c_p + v) with c_p the model's largest dilational wave speed (the bound the
//!   automatic policy uses; for snow that includes its largest hardening, √5 c_p). C* (the
//!   smallest C at which a run is not stable) is reported per method × material and per E, and
//!   the heat map marks the theory's C = 1.
//!
//! CSV columns (one row per run): the parameters (`youngs_modulus_pa`, `poisson_ratio`,
//! `impact_speed_m_s`, `cfl`, `forced_dt_s`), `wave_speed_m_s` (the c_p the bound uses),
//! `finished`, `failure` (`nan`, `left_grid`, `energy_blowup`; empty when finished),
//! `failure_substep` (substeps completed when it was detected), `energy_growth`,
//! `energy_final_ratio`, `penetration_cells`, `momentum_drift`, `stable`, `substeps`, `dt_min_s`,
//! `dt_max_s`, `wall_s`. A value that is not finite (an energy at blow-up) is left empty.
//!
//! Runs go in parallel, one per thread (a run's result does not depend on the thread count).
//! Writes a JSON line per run and a summary per plane to stdout, and `stability_PLANE.{csv,svg,
//! png}` plus `stability_cstar.csv` into `--out-dir`.

mod cstar;
use cstar::{critical_cfl, cstar_key};

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use plotters::style::RGBColor;
use serde_json::{Value, json};
use splatphys_core::material::{self, ConstitutiveModel, Material};
use splatphys_core::mpm::MpmError;
use splatphys_core::scene::{Method, Scene, SceneBuilder, SceneObject};
use splatphys_core::world::{World, WorldError, overlap};

use crate::chart::{self, HeatMap, HeatPanel};

/// Grid cell size (m).
const DX_M: f64 = 0.01;
/// Particle spacing (m).
const SPACING_M: f64 = 0.005;
/// Sphere radius (m).
const RADIUS_M: f64 = 0.03;
/// Density (kg/m³).
const DENSITY_KG_M3: f64 = 1000.0;
/// Run length in Hertz contact times: the whole impact and half as long again after it.
const DURATION_CONTACT_TIMES: f64 = 1.5;
/// Frames (energy, momentum and overlap samples) per run.
const FRAMES: u32 = 40;
/// A run is stable when its energy never grows by more than this fraction.
const ENERGY_TOLERANCE: f64 = 0.01;
/// A run whose energy exceeds this multiple of its start has blown up and is stopped.
const BLOWUP: f64 = 100.0;
/// Poisson's ratio where the plane does not sweep it.
const NU: f64 = 0.3;
/// Impact speed (m/s) where the plane does not sweep it.
const SPEED_M_S: f64 = 2.0;

/// Arguments of `bench stability`.
#[derive(Args, Debug)]
pub struct StabilityBenchArgs {
    /// Only the corners of each plane (2 values per axis, about a minute on 2 cores).
    #[arg(long)]
    pub quick: bool,
    /// Methods to sweep.
    #[arg(long, value_delimiter = ',', default_value = "com,mpm,multi-field")]
    pub methods: Vec<String>,
    /// Material models to sweep.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "jelly,neo-hookean,snow,sand,metal,plasticine,foam"
    )]
    pub materials: Vec<String>,
    /// Planes to sweep (`auto_speed`, `auto_poisson`, `forced_cfl`).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "auto_speed,auto_poisson,forced_cfl"
    )]
    pub planes: Vec<String>,
    /// CFL number of the automatic planes (the scene default, 0.5; at most 1).
    #[arg(long, default_value_t = 0.5)]
    pub auto_cfl: f64,
    /// Worker threads (runs go in parallel).
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Where the CSV files and heat maps go.
    #[arg(long, default_value = "docs/results/bench")]
    pub out_dir: PathBuf,
}

/// A swept parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Param {
    YoungsModulus,
    Speed,
    Poisson,
    Cfl,
}

impl Param {
    fn label(self) -> &'static str {
        match self {
            Param::YoungsModulus => "Young's modulus E (Pa)",
            Param::Speed => "impact speed v (m/s)",
            Param::Poisson => "Poisson's ratio nu",
            Param::Cfl => "CFL number C (forced dt = C dx / (c_p + v))",
        }
    }

    fn tick(self, v: f64) -> String {
        match self {
            Param::YoungsModulus => format!("1e{}", v.log10().round()),
            _ => format!("{v}"),
        }
    }
}

/// One 2-D slice of the sweep.
#[derive(Debug, Clone)]
struct Plane {
    name: &'static str,
    title: String,
    x: (Param, Vec<f64>),
    y: (Param, Vec<f64>),
    forced: bool,
}

/// The parameters of one run.
#[derive(Debug, Clone, Copy)]
struct RunSpec {
    method: &'static str,
    material: &'static str,
    youngs_modulus_pa: f64,
    poisson_ratio: f64,
    speed_m_s: f64,
    cfl: f64,
    forced: bool,
    ix: usize,
    iy: usize,
}

/// What one run measured.
#[derive(Debug, Clone, Default)]
struct Outcome {
    particles: usize,
    wave_speed_m_s: f64,
    duration_s: f64,
    forced_dt_s: Option<f64>,
    finished: bool,
    failure: Option<&'static str>,
    failure_substep: Option<u64>,
    failure_time_s: Option<f64>,
    substeps: u64,
    dt_min_s: f64,
    dt_max_s: f64,
    energy_growth: f64,
    energy_final_ratio: f64,
    penetration_cells: u32,
    momentum_drift: f64,
    wall_s: f64,
}

impl Outcome {
    fn stable(&self) -> bool {
        self.finished && self.energy_growth <= ENERGY_TOLERANCE
    }
}

fn planes(quick: bool, auto_cfl: f64) -> Vec<Plane> {
    let (e, v, nu, c): (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) = if quick {
        // The corners of the full planes.
        (
            vec![1e3, 1e9],
            vec![0.1, 20.0],
            vec![0.0, 0.49],
            vec![0.5, 2.0],
        )
    } else {
        (
            (3..=9).map(|k| 10f64.powi(k)).collect(),
            vec![0.1, 1.0, 3.0, 10.0, 20.0],
            vec![0.0, 0.2, 0.3, 0.4, 0.45, 0.49],
            vec![
                0.1, 0.5, 0.75, 0.9, 1.0, 1.05, 1.1, 1.2, 1.3, 1.5, 1.75, 2.0,
            ],
        )
    };
    vec![
        Plane {
            name: "auto_speed",
            title: format!("automatic dt (C = {auto_cfl}), nu = {NU}"),
            x: (Param::YoungsModulus, e.clone()),
            y: (Param::Speed, v),
            forced: false,
        },
        Plane {
            name: "auto_poisson",
            title: format!("automatic dt (C = {auto_cfl}), v = {SPEED_M_S} m/s"),
            x: (Param::YoungsModulus, e.clone()),
            y: (Param::Poisson, nu),
            forced: false,
        },
        Plane {
            name: "forced_cfl",
            title: format!("forced dt = C dx / (c_p + v), nu = {NU}, v = {SPEED_M_S} m/s"),
            x: (Param::Cfl, c),
            y: (Param::YoungsModulus, e),
            forced: true,
        },
    ]
}

fn run_specs(
    p: &Plane,
    methods: &[&'static str],
    materials: &[&'static str],
    auto_cfl: f64,
) -> Vec<RunSpec> {
    let mut out = Vec::new();
    for &method in methods {
        for &material in materials {
            for (iy, &y) in p.y.1.iter().enumerate() {
                for (ix, &x) in p.x.1.iter().enumerate() {
                    let mut s = RunSpec {
                        method,
                        material,
                        youngs_modulus_pa: 1e5,
                        poisson_ratio: NU,
                        speed_m_s: SPEED_M_S,
                        cfl: auto_cfl,
                        forced: p.forced,
                        ix,
                        iy,
                    };
                    for (param, value) in [(p.x.0, x), (p.y.0, y)] {
                        match param {
                            Param::YoungsModulus => s.youngs_modulus_pa = value,
                            Param::Speed => s.speed_m_s = value,
                            Param::Poisson => s.poisson_ratio = value,
                            Param::Cfl => s.cfl = value,
                        }
                    }
                    out.push(s);
                }
            }
        }
    }
    out
}

/// Hertz contact time (s) of two equal spheres of radius `r` (m), density `rho` meeting at
/// relative speed `v` (m/s): 2.87 (m*² / (R* E*² v))^(1/5).
fn hertz_contact_s(e_pa: f64, nu: f64, rho: f64, r: f64, v: f64) -> f64 {
    let m = rho * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
    let (m_eff, r_eff) = (m / 2.0, r / 2.0);
    let e_eff = e_pa / (2.0 * (1.0 - nu * nu));
    2.87 * (m_eff * m_eff / (r_eff * e_eff * e_eff * v)).powf(0.2)
}

/// The scene of run `s`, its forced dt (s), if any, and its duration (s).
fn scene(s: &RunSpec, wave_speed_m_s: f64) -> Result<(SceneBuilder, Option<f64>, f64)> {
    let duration = DURATION_CONTACT_TIMES
        * hertz_contact_s(
            s.youngs_modulus_pa,
            s.poisson_ratio,
            DENSITY_KG_M3,
            RADIUS_M,
            s.speed_m_s,
        );
    let scene = Scene::builder()
        .method(s.method.parse()?)
        .grid_dx_m(DX_M)
        .gravity_m_s2([0.0, 0.0, 0.0]);
    let (scene, forced_dt, frame_rate, duration) = if s.forced {
        let dt = (s.cfl * DX_M / (wave_speed_m_s + s.speed_m_s)) as f32 as f64;
        // Frames hold a whole number of substeps, so every substep is exactly dt.
        let per_frame = (duration / FRAMES as f64 / dt).ceil().max(1.0);
        let frame_s = per_frame * dt;
        (
            scene.forced_dt_s(dt),
            Some(dt),
            1.0 / frame_s,
            frame_s * FRAMES as f64,
        )
    } else {
        (scene.cfl(s.cfl), None, FRAMES as f64 / duration, duration)
    };
    let material = material::MaterialSpec::new(
        s.material.parse()?,
        s.youngs_modulus_pa,
        s.poisson_ratio,
        DENSITY_KG_M3,
    );
    let sphere = |name: &str, x_m: f64| {
        SceneObject::sphere(name, [x_m as f32, 0.0, 0.0], RADIUS_M as f32)
            .spacing_m(SPACING_M as f32)
            .material(material.clone())
    };
    // The contact plane lies mid-cell (x = dx/2), where the nearest particles of the two
    // spheres (s/2 on either side of it) share a cell.
    let x0 = DX_M / 2.0;
    let scene = scene
        .duration_s(duration)
        .frame_rate_hz(frame_rate)
        .object(sphere("striker", x0 - RADIUS_M).velocity([s.speed_m_s as f32, 0.0, 0.0]))
        .object(sphere("target", x0 + RADIUS_M));
    Ok((scene, forced_dt, duration))
}

/// The model's largest dilational wave speed (m/s), as the automatic policy sees it.
fn wave_speed(s: &RunSpec) -> Result<f64> {
    let m = Material::from_spec(&material::MaterialSpec::new(
        s.material.parse()?,
        s.youngs_modulus_pa,
        s.poisson_ratio,
        DENSITY_KG_M3,
    ))?;
    Ok(m.max_wave_speed_m_s() as f64)
}

fn run_one(s: &RunSpec) -> Result<Outcome> {
    let wave = wave_speed(s)?;
    let (scene, forced_dt, duration) = scene(s, wave)?;
    let mut w = World::from_scene(&scene.build().context("generated scene")?)?;
    let t = Instant::now();
    let d0 = w.diagnostics();
    let e0 = d0.total_energy_j();
    let p0 = d0.momentum_kg_m_s;
    let p0_norm = p0.iter().map(|v| v * v).sum::<f64>().sqrt();
    let mut out = Outcome {
        particles: w.particle_count(),
        wave_speed_m_s: wave,
        duration_s: duration,
        forced_dt_s: forced_dt,
        energy_final_ratio: 1.0,
        ..Default::default()
    };
    let dx = w.dx_m();
    while !w.is_finished() {
        if let Err(e) = w.advance_frame() {
            out.failure = Some(match &e {
                WorldError::Solver { source, .. } => match source {
                    MpmError::NonFiniteParticle { .. } | MpmError::NonFiniteGrid { .. } => "nan",
                    MpmError::OutOfGrid { .. } => "left_grid",
                    MpmError::BadMaterial { .. } => "bad_material",
                },
                WorldError::TimeStep { .. } => "time_step_refused",
                _ => "other",
            });
            out.failure_substep = Some(w.stats().substeps);
            out.failure_time_s = Some(w.time_s());
            break;
        }
        let d = w.diagnostics();
        let ratio = d.total_energy_j() / e0;
        out.energy_growth = out.energy_growth.max(ratio - 1.0);
        out.energy_final_ratio = ratio;
        let p = d.momentum_kg_m_s;
        let drift = (0..3).map(|k| (p[k] - p0[k]).powi(2)).sum::<f64>().sqrt() / p0_norm;
        out.momentum_drift = out.momentum_drift.max(drift);
        let (a, b) = (
            &w.bodies()[0].particle_positions(),
            &w.bodies()[1].particle_positions(),
        );
        let depth = overlap::penetration(a, b, dx)
            .depth_cells
            .max(overlap::penetration(b, a, dx).depth_cells);
        out.penetration_cells = out.penetration_cells.max(depth);
        if !(ratio.is_finite() && ratio <= BLOWUP) {
            out.failure = Some("energy_blowup");
            out.failure_substep = Some(w.stats().substeps);
            out.failure_time_s = Some(w.time_s());
            break;
        }
    }
    out.finished = out.failure.is_none();
    out.substeps = w.stats().substeps;
    out.dt_min_s = w.stats().dt_min_s;
    out.dt_max_s = w.stats().dt_max_s;
    out.wall_s = t.elapsed().as_secs_f64();
    Ok(out)
}

/// Columns of `stability_PLANE.csv`, in order.
const COLUMNS: [&str; 26] = [
    "bench",
    "plane",
    "method",
    "material",
    "dt_policy",
    "youngs_modulus_pa",
    "poisson_ratio",
    "impact_speed_m_s",
    "cfl",
    "forced_dt_s",
    "wave_speed_m_s",
    "particles",
    "duration_s",
    "finished",
    "failure",
    "failure_substep",
    "failure_time_s",
    "substeps",
    "dt_min_s",
    "dt_max_s",
    "energy_growth",
    "energy_final_ratio",
    "penetration_cells",
    "momentum_drift",
    "stable",
    "wall_s",
];

fn row(p: &Plane, s: &RunSpec, o: &Outcome) -> Value {
    json!({
        "bench": "stability",
        "plane": p.name,
        "method": s.method,
        "material": s.material,
        "dt_policy": if s.forced { "forced" } else { "auto" },
        "youngs_modulus_pa": s.youngs_modulus_pa,
        "poisson_ratio": s.poisson_ratio,
        "impact_speed_m_s": s.speed_m_s,
        "cfl": s.cfl,
        "forced_dt_s": o.forced_dt_s,
        "wave_speed_m_s": o.wave_speed_m_s,
        "particles": o.particles,
        "duration_s": o.duration_s,
        "finished": o.finished,
        "failure": o.failure,
        "failure_substep": o.failure_substep,
        "failure_time_s": o.failure_time_s,
        "substeps": o.substeps,
        "dt_min_s": o.dt_min_s,
        "dt_max_s": o.dt_max_s,
        "energy_growth": o.energy_growth,
        "energy_final_ratio": o.energy_final_ratio,
        "penetration_cells": o.penetration_cells,
        "momentum_drift": o.momentum_drift,
        "stable": o.stable(),
        "wall_s": o.wall_s,
    })
}

/// Heat-map categories, in legend order.
fn categories() -> Vec<(String, RGBColor)> {
    vec![
        (
            "stable: finished, energy growth <= 1 %".into(),
            RGBColor(44, 160, 44),
        ),
        (
            "finished, energy growth > 1 %".into(),
            RGBColor(255, 127, 14),
        ),
        (
            "failed: NaN, left the grid or energy > 100x".into(),
            RGBColor(214, 39, 40),
        ),
    ]
}

fn category(o: &Outcome) -> usize {
    if o.stable() {
        0
    } else if o.finished {
        1
    } else {
        2
    }
}

/// Checks the method and material names.
fn names(a: &StabilityBenchArgs) -> Result<(Vec<&'static str>, Vec<&'static str>)> {
    let mut methods = Vec::new();
    for m in &a.methods {
        let method: Method = m.parse().map_err(|e| anyhow::anyhow!("--methods: {e}"))?;
        methods.push(method.name());
    }
    let mut materials = Vec::new();
    for m in &a.materials {
        let model: material::MaterialModel =
            m.parse().map_err(|e| anyhow::anyhow!("--materials: {e}"))?;
        materials.push(model.name());
    }
    if methods.is_empty() || materials.is_empty() {
        bail!("--methods and --materials need at least one name each");
    }
    Ok((methods, materials))
}

/// Runs the sweep.
pub fn run(a: &StabilityBenchArgs) -> Result<()> {
    let (methods, materials) = names(a)?;
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("creating {}", a.out_dir.display()))?;
    if !(a.auto_cfl > 0.0 && a.auto_cfl <= 1.0) {
        bail!("--auto-cfl must be in (0, 1], got {}", a.auto_cfl);
    }
    let all = planes(a.quick, a.auto_cfl);
    if let Some(bad) = a
        .planes
        .iter()
        .find(|n| !all.iter().any(|p| p.name == n.as_str()))
    {
        bail!(
            "--planes: unknown plane {bad:?} (expected some of {:?})",
            all.iter().map(|p| p.name).collect::<Vec<_>>()
        );
    }
    let planes: Vec<Plane> = all
        .into_iter()
        .filter(|p| a.planes.iter().any(|n| n == p.name))
        .collect();
    let specs: Vec<Vec<RunSpec>> = planes
        .iter()
        .map(|p| run_specs(p, &methods, &materials, a.auto_cfl))
        .collect();
    let total: usize = specs.iter().map(Vec::len).sum();
    println!(
        "{}",
        json!({
            "bench": "stability_plan",
            "quick": a.quick,
            "runs": total,
            "planes": planes.iter().zip(&specs).map(|(p, s)| json!({
                "plane": p.name, "runs": s.len(), "x": p.x.1, "y": p.y.1,
            })).collect::<Vec<_>>(),
            "methods": methods,
            "materials": materials,
            "threads": a.threads,
            "auto_cfl": a.auto_cfl,
        })
    );
    let pb = ProgressBar::new(total as u64);
    pb.set_style(
        ProgressStyle::with_template("stability {msg} [{bar:30}] {pos}/{len} {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let started = Instant::now();
    let mut cstar = Vec::new();
    for (p, runs) in planes.iter().zip(&specs) {
        pb.set_message(p.name);
        let outcomes = run_all(runs, a.threads, &pb)?;
        let rows: Vec<Value> = runs
            .iter()
            .zip(&outcomes)
            .map(|(s, o)| row(p, s, o))
            .collect();
        pb.suspend(|| {
            for r in &rows {
                println!("{r}");
            }
        });
        let stem = a.out_dir.join(format!("stability_{}", p.name));
        chart::write_columns_csv(&stem.with_extension("csv"), &COLUMNS, &rows)?;
        draw(&stem, p, &methods, &materials, runs, &outcomes)?;
        let summary = summarize(p, runs, &outcomes);
        pb.suspend(|| println!("{summary}"));
        if p.forced {
            cstar = critical_cfl(p, &methods, &materials, runs, &outcomes);
            pb.suspend(|| {
                for r in &cstar {
                    println!("{r}");
                }
            });
        }
    }
    pb.finish_and_clear();
    if let Some(p) = planes.iter().find(|p| p.forced) {
        let per_e: Vec<String> = p.y.1.iter().map(|e| cstar_key(*e)).collect();
        let mut columns = vec![
            "bench",
            "method",
            "material",
            "c_last_stable",
            "c_first_unstable",
        ];
        columns.extend(per_e.iter().map(String::as_str));
        chart::write_columns_csv(&a.out_dir.join("stability_cstar.csv"), &columns, &cstar)?;
    }
    println!(
        "{}",
        json!({
            "bench": "stability_done",
            "runs": total,
            "wall_s": started.elapsed().as_secs_f64(),
            "threads": a.threads,
        })
    );
    Ok(())
}

/// Runs `runs` on `threads` worker threads, each taking the next run and computing it on its own
/// one-thread rayon pool. (Runs of ~2,000 particles are too small to split: nesting the solver's
/// fine-grained rayon work inside parallel runs left each thread waiting on the other's jobs half
/// the time, as slow as one thread.) Outcomes come back in `runs` order.
fn run_all(runs: &[RunSpec], threads: usize, pb: &ProgressBar) -> Result<Vec<Outcome>> {
    let next = AtomicUsize::new(0);
    let mut done: Vec<(usize, Outcome)> = std::thread::scope(|scope| {
        let workers: Vec<_> = (0..threads.max(1))
            .map(|_| {
                scope.spawn(|| -> Result<Vec<(usize, Outcome)>> {
                    let pool = crate::thread_pool(1)?;
                    let mut mine = Vec::new();
                    loop {
                        let k = next.fetch_add(1, Ordering::Relaxed);
                        let Some(s) = runs.get(k) else {
                            return Ok(mine);
                        };
                        mine.push((k, pool.install(|| run_one(s))?));
                        pb.inc(1);
                    }
                })
            })
            .collect();
        workers
            .into_iter()
            .map(|w| {
                w.join()
                    .map_err(|_| anyhow::anyhow!("a stability worker panicked"))?
            })
            .collect::<Result<Vec<_>>>()
            .map(|v| v.into_iter().flatten().collect())
    })?;
    done.sort_by_key(|(k, _)| *k);
    Ok(done.into_iter().map(|(_, o)| o).collect())
}

fn summarize(p: &Plane, runs: &[RunSpec], outcomes: &[Outcome]) -> Value {
    let count = |k: usize| outcomes.iter().filter(|o| category(o) == k).count();
    let worst = runs
        .iter()
        .zip(outcomes)
        .filter(|(_, o)| o.finished)
        .max_by(|a, b| a.1.energy_growth.total_cmp(&b.1.energy_growth))
        .map(|(s, o)| {
            json!({
                "method": s.method, "material": s.material,
                "youngs_modulus_pa": s.youngs_modulus_pa, "poisson_ratio": s.poisson_ratio,
                "impact_speed_m_s": s.speed_m_s, "cfl": s.cfl,
                "energy_growth": o.energy_growth,
            })
        });
    let max = |f: fn(&Outcome) -> f64| {
        outcomes
            .iter()
            .filter(|o| o.finished)
            .map(f)
            .fold(0.0f64, f64::max)
    };
    json!({
        "bench": "stability_summary",
        "plane": p.name,
        "dt_policy": if p.forced { "forced" } else { "auto" },
        "runs": outcomes.len(),
        "stable": count(0),
        "energy_growth_over_1pct": count(1),
        "failed": count(2),
        "max_energy_growth_finished": max(|o| o.energy_growth),
        "max_momentum_drift_finished": max(|o| o.momentum_drift),
        "max_penetration_cells_finished": max(|o| o.penetration_cells as f64),
        "worst_energy_growth": worst,
        "wall_s": outcomes.iter().map(|o| o.wall_s).sum::<f64>(),
    })
}

fn draw(
    stem: &Path,
    p: &Plane,
    methods: &[&'static str],
    materials: &[&'static str],
    runs: &[RunSpec],
    outcomes: &[Outcome],
) -> Result<()> {
    let (nx, ny) = (p.x.1.len(), p.y.1.len());
    let mut panels = Vec::new();
    for &method in methods {
        for &material in materials {
            let mut cells = vec![vec![None; nx]; ny];
            for (s, o) in runs.iter().zip(outcomes) {
                if s.method == method && s.material == material {
                    cells[s.iy][s.ix] = Some(category(o));
                }
            }
            panels.push(HeatPanel {
                title: format!("{method} · {material}"),
                cells,
            });
        }
    }
    // CFL theory: explicit MPM is stable up to C = 1 (information crosses at most one cell per
    // substep); the line sits between the last swept C <= 1 and the next.
    let theory = p
        .forced
        .then(|| p.x.1.iter().filter(|c| **c <= 1.0).count());
    let x_ticks: Vec<String> = p.x.1.iter().map(|v| p.x.0.tick(*v)).collect();
    let y_ticks: Vec<String> = p.y.1.iter().map(|v| p.y.0.tick(*v)).collect();
    chart::heat_map(
        stem,
        &HeatMap {
            title: &format!("Stability map: {}", p.title),
            x_label: p.x.0.label(),
            y_label: p.y.0.label(),
            x_ticks: &x_ticks,
            y_ticks: &y_ticks,
            categories: &categories(),
            panels: &panels,
            columns: materials.len(),
            x_line: theory.map(|k| (k, "CFL theory: C = 1")),
        },
    )?;
    Ok(())
}
