//! `splatphys bench contact`: rigid-body contact of the COM layer against rapier3d on the same
//! scenes in the same process: a stack of 10 boxes, a pyramid of 15 and a pile of 100 boxes and
//! balls in an open box ([`scenes`]).
//!
//! Per scene, splatphys runs first ([`ours`]): a [`splatphys_core::world::World`] from the scene
//! builder, substeps chosen by the world (CFL), sleeping kept off. Rapier then runs the same
//! scene ([`rapier`], feature `rapier`, on by default) with the masses, centres of mass and
//! inertia tensors the world computed from its particles, the same friction, restitution and
//! gravity, sleeping off, and a fixed step that is by default the world's mean substep (so both
//! take about as many steps; `--rapier-dt-s` sets another).
//!
//! Measured per scene and engine, at the end of the run:
//! - **COM drift** (stack, pyramid): per body |COM − rest COM| in mm, its max and mean, where
//!   the rest COM is the start COM lowered by the gaps below the body (for the stack k·0.1 +
//!   0.05 m up to the lattice's COM offset, which both engines share);
//! - **deepest overlap** of any two bodies or a body and the ground or a wall, on the exact
//!   shapes at the final poses ([`penetration`], needs the `rapier` feature for parry);
//! - **largest COM speed** and **kinetic energy** (translation and rotation; what a pile that has
//!   not come to rest still holds);
//! - **time**: steps, wall time per step and per simulated second, CPU time of the loop.
//!
//! Splatphys bodies are particle clouds (one particle per Gaussian or lattice point), so its cost
//! per step follows the particle count; rapier's follows bodies and contacts.
//!
//! Output: one JSON line per scene and engine, then a table with the ratio splatphys / rapier;
//! `contact.csv` (those rows), `contact_bodies.csv` (per body) and the chart `contact.svg` /
//! `contact.png` in `--out-dir`.

pub mod ours;
#[cfg(feature = "rapier")]
pub mod penetration;
#[cfg(feature = "rapier")]
pub mod rapier;
pub mod scenes;

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;
use glam::{DMat3, DQuat, DVec3};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use crate::chart::{self, BarPanel};
use scenes::{ContactScene, ContactSettings, SceneKind};

/// Arguments of `bench contact`.
#[derive(Args, Debug)]
pub struct ContactBenchArgs {
    /// Scenes to run, in order.
    #[arg(long, value_delimiter = ',', default_value = "stack,pyramid,pile")]
    pub scenes: Vec<SceneKind>,
    /// Simulated time of the stack and the pyramid (s).
    #[arg(long, default_value_t = 10.0)]
    pub duration_s: f64,
    /// Simulated time of the pile (s).
    #[arg(long, default_value_t = 4.0)]
    pub pile_duration_s: f64,
    /// Objects in the pile (25 per layer).
    #[arg(long, default_value_t = 100)]
    pub pile_count: usize,
    /// Grid cell size of the splatphys world and lattice spacing of its particles (m).
    #[arg(long, default_value_t = 0.01)]
    pub dx_m: f64,
    /// Coulomb friction of every surface, both engines.
    #[arg(long, default_value_t = 0.5)]
    pub friction: f32,
    /// Restitution of every surface, both engines.
    #[arg(long, default_value_t = 0.0)]
    pub restitution: f32,
    /// Density of every body (kg/m³): a 10 cm box of 1000 kg/m³ weighs 1 kg.
    #[arg(long, default_value_t = 1000.0)]
    pub density_kg_m3: f64,
    /// Seed of the pile layout and the particle lattice jitter.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Rapier's fixed step (s); default: the splatphys world's mean substep on each scene.
    #[arg(long)]
    pub rapier_dt_s: Option<f64>,
    /// Worker threads of the splatphys world (rapier runs single-threaded).
    #[arg(long, default_value_t = 1)]
    pub threads: usize,
    /// Where `contact.csv`, `contact_bodies.csv`, `.svg` and `.png` go.
    #[arg(long, default_value = "docs/bench")]
    pub out_dir: PathBuf,
}

/// Mass properties of a body at the start, as the splatphys world computed them from its
/// particles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassProps {
    /// Mass (kg).
    pub mass_kg: f64,
    /// Centre of mass at the start, world frame (m).
    pub com_m: DVec3,
    /// Inertia tensor about the centre of mass, world axes at the start (kg m²).
    pub inertia_kg_m2: DMat3,
}

/// A body's state at the end of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FinalBody {
    /// Centre of mass (m).
    pub com_m: DVec3,
    /// Rotation from the start pose.
    pub orientation: DQuat,
    /// COM velocity (m/s).
    pub velocity_m_s: DVec3,
    /// Angular velocity (rad/s).
    pub omega_rad_s: DVec3,
    /// Asleep at the end (never, with sleeping kept off; reported as a check).
    pub asleep: bool,
}

/// One engine's run of one scene.
#[derive(Debug, Clone, PartialEq)]
pub struct EngineRun {
    /// Steps (splatphys: substeps).
    pub steps: u64,
    /// Simulated time (s).
    pub simulated_s: f64,
    /// Smallest and largest step (s).
    pub dt_range_s: [f64; 2],
    /// Wall time of the steps (s).
    pub wall_s: f64,
    /// CPU time of the step loop, all threads (s); `None` off Linux.
    pub cpu_s: Option<f64>,
    /// Particles (splatphys only).
    pub particles: Option<usize>,
    /// Bodies at the end, in scene order.
    pub bodies: Vec<FinalBody>,
}

/// Progress of one run on the shared bar, in simulated milliseconds.
pub struct Progress<'a> {
    pb: Option<&'a ProgressBar>,
    base_ms: u64,
}

impl Progress<'_> {
    /// No bar (tests).
    pub fn hidden() -> Progress<'static> {
        Progress {
            pb: None,
            base_ms: 0,
        }
    }

    /// The run has simulated `t_s` seconds.
    pub fn at(&self, t_s: f64) {
        if let Some(pb) = self.pb {
            pb.set_position(self.base_ms + (t_s * 1e3) as u64);
        }
    }
}

/// One row of `contact.csv` and of the JSON lines: one scene, one engine.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ContactRow {
    /// "contact".
    pub bench: &'static str,
    /// Scene name.
    pub scene: &'static str,
    /// "splatphys" or "rapier3d" with its version.
    pub engine: String,
    /// Rigid bodies.
    pub bodies: usize,
    /// Particles (splatphys only).
    pub particles: Option<usize>,
    /// Worker threads.
    pub threads: usize,
    /// Simulated time (s).
    pub simulated_s: f64,
    /// Steps (splatphys: substeps).
    pub steps: u64,
    /// Simulated time / steps (s).
    pub dt_mean_s: f64,
    /// Smallest step (s).
    pub dt_min_s: f64,
    /// Largest step (s).
    pub dt_max_s: f64,
    /// Wall time of the steps (s).
    pub wall_s: f64,
    /// CPU time of the step loop (s).
    pub cpu_s: Option<f64>,
    /// Wall time per step (µs).
    pub us_per_step: f64,
    /// Wall seconds per simulated second.
    pub wall_s_per_sim_s: f64,
    /// Largest |COM − rest COM| over bodies (mm; stack and pyramid).
    pub max_drift_mm: Option<f64>,
    /// Mean |COM − rest COM| over bodies (mm; stack and pyramid).
    pub mean_drift_mm: Option<f64>,
    /// Deepest overlap at the end (mm; needs the `rapier` feature).
    pub max_penetration_mm: Option<f64>,
    /// Largest COM speed at the end (m/s).
    pub max_speed_m_s: f64,
    /// Kinetic energy at the end, translation and rotation (J).
    pub kinetic_energy_j: f64,
    /// Bodies asleep at the end.
    pub asleep_at_end: usize,
}

/// One row of `contact_bodies.csv`: one body of one scene in one engine, at the end.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BodyRow {
    /// Scene name.
    pub scene: &'static str,
    /// Engine.
    pub engine: String,
    /// Body name.
    pub body: String,
    /// "box" or "ball".
    pub shape: &'static str,
    /// Mass (kg).
    pub mass_kg: f64,
    /// |COM − rest COM| (mm); empty for the pile.
    pub drift_mm: Option<f64>,
    /// Final COM x (m).
    pub com_x_m: f64,
    /// Final COM y (m).
    pub com_y_m: f64,
    /// Final COM z (m).
    pub com_z_m: f64,
    /// COM speed (m/s).
    pub speed_m_s: f64,
}

/// Per body |COM − rest COM| (m), `None` where the scene knows no rest pose.
fn drifts_m(scene: &ContactScene, mass: &[MassProps], run: &EngineRun) -> Vec<Option<f64>> {
    scene
        .bodies
        .iter()
        .zip(mass)
        .zip(&run.bodies)
        .map(|((b, m), f)| {
            b.settle_drop_m.map(|d| {
                let rest = m.com_m - DVec3::Z * f64::from(d);
                (f.com_m - rest).length()
            })
        })
        .collect()
}

/// ½ m |v|² + ½ ωᵀ (R I₀ Rᵀ) ω summed over bodies (J).
fn kinetic_energy_j(mass: &[MassProps], run: &EngineRun) -> f64 {
    mass.iter()
        .zip(&run.bodies)
        .map(|(m, f)| {
            let r = DMat3::from_quat(f.orientation);
            let i = r * m.inertia_kg_m2 * r.transpose();
            0.5 * m.mass_kg * f.velocity_m_s.length_squared()
                + 0.5 * f.omega_rad_s.dot(i * f.omega_rad_s)
        })
        .sum()
}

/// The row and the per-body rows of one run.
fn rows(
    scene: &ContactScene,
    mass: &[MassProps],
    engine: &str,
    threads: usize,
    run: &EngineRun,
) -> (ContactRow, Vec<BodyRow>) {
    let drifts = drifts_m(scene, mass, run);
    let known: Vec<f64> = drifts.iter().flatten().copied().collect();
    let (max_drift_mm, mean_drift_mm) = if known.is_empty() {
        (None, None)
    } else {
        let max = known.iter().copied().fold(0.0, f64::max);
        let mean = known.iter().sum::<f64>() / known.len() as f64;
        (Some(max * 1e3), Some(mean * 1e3))
    };
    #[cfg(feature = "rapier")]
    let max_penetration_mm = Some(penetration::max_penetration_m(scene, mass, &run.bodies) * 1e3);
    #[cfg(not(feature = "rapier"))]
    let max_penetration_mm = None;
    let steps = run.steps.max(1);
    let row = ContactRow {
        bench: "contact",
        scene: scene.kind.name(),
        engine: engine.to_owned(),
        bodies: scene.bodies.len(),
        particles: run.particles,
        threads,
        simulated_s: run.simulated_s,
        steps: run.steps,
        dt_mean_s: run.simulated_s / steps as f64,
        dt_min_s: run.dt_range_s[0],
        dt_max_s: run.dt_range_s[1],
        wall_s: run.wall_s,
        cpu_s: run.cpu_s,
        us_per_step: 1e6 * run.wall_s / steps as f64,
        wall_s_per_sim_s: run.wall_s / run.simulated_s,
        max_drift_mm,
        mean_drift_mm,
        max_penetration_mm,
        max_speed_m_s: run
            .bodies
            .iter()
            .map(|f| f.velocity_m_s.length())
            .fold(0.0, f64::max),
        kinetic_energy_j: kinetic_energy_j(mass, run),
        asleep_at_end: run.bodies.iter().filter(|f| f.asleep).count(),
    };
    let bodies = scene
        .bodies
        .iter()
        .zip(mass)
        .zip(&run.bodies)
        .zip(drifts)
        .map(|(((b, m), f), d)| BodyRow {
            scene: scene.kind.name(),
            engine: engine.to_owned(),
            body: b.name.clone(),
            shape: b.shape.name(),
            mass_kg: m.mass_kg,
            drift_mm: d.map(|d| d * 1e3),
            com_x_m: f.com_m.x,
            com_y_m: f.com_m.y,
            com_z_m: f.com_m.z,
            speed_m_s: f.velocity_m_s.length(),
        })
        .collect();
    (row, bodies)
}

/// The splatphys engine name.
const OURS: &str = "splatphys";

/// The rapier engine name, with its version.
fn rapier_name() -> String {
    #[cfg(feature = "rapier")]
    return format!("rapier3d {}", rapier::VERSION);
    #[cfg(not(feature = "rapier"))]
    return "rapier3d (not built: feature `rapier` off)".into();
}

/// Runs `bench contact`.
///
/// # Errors
/// Bad arguments, a scene or world that cannot be built, a failed substep, unwritable output.
pub fn run(a: &ContactBenchArgs) -> Result<()> {
    let positive = |v: f64| v.is_finite() && v > 0.0;
    if a.scenes.is_empty() {
        bail!("--scenes: name at least one of stack, pyramid, pile");
    }
    if !(positive(a.duration_s) && positive(a.pile_duration_s) && positive(a.dx_m)) {
        bail!("--duration-s, --pile-duration-s and --dx-m must be positive");
    }
    if a.rapier_dt_s.is_some_and(|dt| !positive(dt)) {
        bail!("--rapier-dt-s must be positive");
    }
    if a.pile_count == 0 && a.scenes.contains(&SceneKind::Pile) {
        bail!("--pile-count must be at least 1");
    }
    let settings = ContactSettings {
        friction: a.friction,
        restitution: a.restitution,
        density_kg_m3: a.density_kg_m3,
        dx_m: a.dx_m,
        seed: a.seed,
    };
    let pool = crate::thread_pool(a.threads)?;
    let plans: Vec<(ContactScene, f64)> = a
        .scenes
        .iter()
        .map(|&k| {
            let d = if k == SceneKind::Pile {
                a.pile_duration_s
            } else {
                a.duration_s
            };
            (ContactScene::new(k, a.pile_count, a.seed), d)
        })
        .collect();
    let engines = if cfg!(feature = "rapier") { 2 } else { 1 };
    let total_ms: u64 = plans.iter().map(|(_, d)| (d * 1e3) as u64 * engines).sum();
    let pb = ProgressBar::new(total_ms);
    pb.set_style(
        ProgressStyle::with_template("contact {msg} [{bar:30}] {pos}/{len} simulated ms {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut table = Vec::new();
    let mut body_rows = Vec::new();
    let mut base_ms = 0;
    for (scene, duration_s) in &plans {
        let name = scene.kind.name();
        pb.set_message(format!("{name}: {OURS}"));
        let (mut world, mass) = ours::build(scene, &settings, *duration_s)?;
        let gravity = world.gravity_m_s2.as_dvec3();
        let progress = Progress {
            pb: Some(&pb),
            base_ms,
        };
        let ours_run = pool.install(|| ours::run(&mut world, &progress))?;
        base_ms += (duration_s * 1e3) as u64;
        let (ours_row, bodies) = rows(scene, &mass, OURS, a.threads, &ours_run);
        pb.suspend(|| println!("{}", serde_json::to_string(&ours_row).unwrap_or_default()));
        body_rows.extend(bodies);
        #[cfg(feature = "rapier")]
        let theirs_row = {
            pb.set_message(format!("{name}: rapier3d"));
            let dt = a
                .rapier_dt_s
                .unwrap_or(ours_run.simulated_s / ours_run.steps.max(1) as f64);
            let (mut rw, handles) = rapier::build(scene, &settings, &mass, gravity, dt)?;
            let progress = Progress {
                pb: Some(&pb),
                base_ms,
            };
            let theirs = rapier::run(&mut rw, &handles, *duration_s, &progress);
            base_ms += (duration_s * 1e3) as u64;
            let (row, bodies) = rows(scene, &mass, &rapier_name(), 1, &theirs);
            pb.suspend(|| println!("{}", serde_json::to_string(&row).unwrap_or_default()));
            body_rows.extend(bodies);
            Some(row)
        };
        #[cfg(not(feature = "rapier"))]
        let theirs_row = {
            let _ = gravity;
            None
        };
        table.push((ours_row, theirs_row));
    }
    pb.finish_and_clear();
    if !cfg!(feature = "rapier") {
        eprintln!("contact: built without the `rapier` feature: splatphys only, no reference");
    }
    print!("{}", format_table(&table));
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("creating {}", a.out_dir.display()))?;
    let stem = a.out_dir.join("contact");
    let all: Vec<&ContactRow> = table
        .iter()
        .flat_map(|(o, t)| std::iter::once(o).chain(t))
        .collect();
    write_csv(&stem.with_extension("csv"), &all)?;
    write_csv(&a.out_dir.join("contact_bodies.csv"), &body_rows)?;
    draw(&stem, &table, a)?;
    Ok(())
}

/// Writes `rows` as CSV with a header of their field names.
fn write_csv<T: Serialize>(path: &Path, rows: &[T]) -> Result<()> {
    let mut w =
        csv::Writer::from_path(path).with_context(|| format!("creating {}", path.display()))?;
    for r in rows {
        w.serialize(r)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    w.flush()
        .with_context(|| format!("writing {}", path.display()))
}

/// The metrics of the table: label and how to read it from a row.
type Metric = (&'static str, fn(&ContactRow) -> Option<f64>);

const METRICS: [Metric; 10] = [
    ("steps", |r| Some(r.steps as f64)),
    ("mean step, ms", |r| Some(r.dt_mean_s * 1e3)),
    ("wall time per step, µs", |r| Some(r.us_per_step)),
    ("wall s per simulated s", |r| Some(r.wall_s_per_sim_s)),
    ("max COM drift, mm", |r| r.max_drift_mm),
    ("mean COM drift, mm", |r| r.mean_drift_mm),
    ("deepest overlap, mm", |r| r.max_penetration_mm),
    ("max COM speed at end, m/s", |r| Some(r.max_speed_m_s)),
    ("kinetic energy at end, J", |r| Some(r.kinetic_energy_j)),
    ("asleep at end", |r| Some(r.asleep_at_end as f64)),
];

fn cell(v: Option<f64>) -> String {
    match v {
        None => "-".into(),
        Some(v) if v == v.trunc() && v.abs() < 1e9 => format!("{v:.0}"),
        Some(v) if v != 0.0 && (v.abs() < 1e-2 || v.abs() >= 1e5) => format!("{v:.3e}"),
        Some(v) => format!("{v:.3}"),
    }
}

/// The comparison table: per scene, each metric for both engines and their ratio.
fn format_table(table: &[(ContactRow, Option<ContactRow>)]) -> String {
    let theirs = rapier_name();
    let mut s = format!(
        "{:<8} {:<27} {:>12} {:>12} {:>12}\n",
        "scene", "metric", OURS, "rapier3d", "ours/rapier"
    );
    for (ours, rapier) in table {
        let head = format!(
            "{} ({} bodies, {} particles, {:.2} s simulated; rapier: {theirs})",
            ours.scene,
            ours.bodies,
            ours.particles.unwrap_or(0),
            ours.simulated_s
        );
        s.push_str(&format!("{head}\n"));
        for (label, get) in METRICS {
            let o = get(ours);
            let t = rapier.as_ref().and_then(get);
            let ratio = o.zip(t).and_then(|(o, t)| (t != 0.0).then(|| o / t));
            s.push_str(&format!(
                "{:<8} {:<27} {:>12} {:>12} {:>12}\n",
                ours.scene,
                label,
                cell(o),
                cell(t),
                cell(ratio)
            ));
        }
    }
    s
}

/// Smallest value drawn on the chart's log axes (a rapier drift of exactly 0 still shows).
const CHART_FLOOR: f64 = 1e-4;

/// Bars of max COM drift, deepest overlap and time per step per scene, both engines.
fn draw(
    stem: &Path,
    table: &[(ContactRow, Option<ContactRow>)],
    a: &ContactBenchArgs,
) -> Result<()> {
    let panel = |title: &str, y: &str, get: fn(&ContactRow) -> Option<f64>| {
        let used: Vec<&(ContactRow, Option<ContactRow>)> =
            table.iter().filter(|(o, _)| get(o).is_some()).collect();
        BarPanel {
            title: title.into(),
            y_label: y.into(),
            categories: used.iter().map(|(o, _)| o.scene.to_owned()).collect(),
            values: vec![
                used.iter()
                    .map(|(o, _)| get(o).map(|v| v.max(CHART_FLOOR)))
                    .collect(),
                used.iter()
                    .map(|(_, t)| t.as_ref().and_then(get).map(|v| v.max(CHART_FLOOR)))
                    .collect(),
            ],
            log_y: true,
        }
    };
    let panels: Vec<BarPanel> = [
        panel("max COM drift at the end", "mm", |r| r.max_drift_mm),
        panel("deepest overlap at the end", "mm", |r| r.max_penetration_mm),
        panel("wall time per step", "µs", |r| Some(r.us_per_step)),
    ]
    .into_iter()
    .filter(|p| !p.categories.is_empty())
    .collect();
    let durations: Vec<String> = table
        .iter()
        .map(|(o, _)| format!("{} {:.2} s", o.scene, o.simulated_s))
        .collect();
    chart::bar_chart(
        stem,
        &format!(
            "Contact: splatphys ({} thread{}) vs {} ({})",
            a.threads,
            if a.threads == 1 { "" } else { "s" },
            rapier_name(),
            durations.join(", ")
        ),
        &[OURS.to_owned(), rapier_name()],
        &panels,
    )?;
    Ok(())
}
