//! `splatphys bench contact`: rigid-body contact of the COM layer against two reference
//! engines, rapier3d (in the same process) and MuJoCo (a Python child process), on the same
//! scenes ([`scenes`]): a stack of 10 boxes, a pyramid of 15, a pile of 100 boxes and balls in
//! an open box, 125 randomly turned 5 cm cubes dropped into an open box (`cubes`) and, on
//! request only (it is slow), 1,000 of them (`cubes1000`).
//!
//! Per scene, splatphys runs first ([`ours`]): a [`splatphys_core::world::World`] from the scene
//! builder, substeps chosen by the world (CFL), sleeping kept off. Rapier then runs the same
//! scene ([`rapier`], feature `rapier`, on by default) with the masses, centres of mass and
//! inertia tensors the world computed from its particles, the same start poses, friction,
//! restitution and gravity, sleeping off, and a fixed step that is by default the world's mean
//! substep (so both take about as many steps; `--rapier-dt-s` sets another). MuJoCo runs it
//! third ([`mujoco`], `bench/mujoco/contact.py` through `--python`) with the same masses,
//! poses, friction and gravity and otherwise at its defaults: its 0.002 s step (unless
//! `--mujoco-dt-s`), Euler integrator, Newton solver, pyramidal cone, soft contacts. MuJoCo has
//! no restitution coefficient, so `--restitution` does not reach it. A Python without `mujoco`
//! (or no Python) skips MuJoCo with one line on stderr; `--no-mujoco` skips it outright. On
//! `cubes1000` MuJoCo's default Newton solver slows to seconds per step once the cubes land
//! (measured: 4 to 8 s per step at about 3,000 contacts, 0.3 s into the run, 2-core machine):
//! run that scene with `--no-mujoco`.
//!
//! Measured per scene and engine, at the end of the run:
//! - **COM drift** (stack, pyramid): per body |COM − rest COM| in mm, its max and mean, where
//!   the rest COM is the start COM lowered by the gaps below the body (for the stack k·0.1 +
//!   0.05 m up to the lattice's COM offset, which all engines share);
//! - **deepest overlap** of any two bodies or a body and the ground or a wall, on the exact
//!   shapes at the final poses ([`penetration`], needs the `rapier` feature for parry), the
//!   same way for every engine; MuJoCo also reports the **deepest contact during the run**
//!   (its own contact depths, every 10 steps), which the others leave '-';
//! - **largest COM speed**, **kinetic energy** (translation and rotation; what a pile that has
//!   not come to rest still holds) and the **bodies below 1 cm/s** (COM speed; the target is
//!   every cube below it at 3 s);
//! - **time**: steps, wall time per step and per simulated second, CPU time of the loop
//!   (splatphys and rapier; MuJoCo's wall time is that of its `mj_step` calls only).
//!
//! Splatphys bodies are particle clouds (one particle per Gaussian or lattice point), so its cost
//! per step follows the particle count; rapier's and MuJoCo's follow bodies and contacts.
//!
//! Output: one JSON line per scene and engine, then a table with a column per engine and the
//! ratios splatphys / rapier and splatphys / mujoco ([`report`]); `contact.csv` (those rows),
//! `contact_bodies.csv` (per body) and the chart `contact.svg` / `contact.png` in `--out-dir`.

pub mod mujoco;
pub mod ours;
#[cfg(feature = "rapier")]
pub mod penetration;
#[cfg(feature = "rapier")]
pub mod rapier;
pub mod report;
pub mod scenes;

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use glam::{DMat3, DQuat, DVec3};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use report::SceneRows;
use scenes::{ContactScene, ContactSettings, SceneKind};
use splatphys_core::contact::ContactSolver;

/// Arguments of `bench contact`.
#[derive(Args, Debug)]
pub struct ContactBenchArgs {
    /// Scenes to run, in order (cubes1000 is slow: only on request, and with --no-mujoco, as
    /// MuJoCo at its defaults takes seconds per step there).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "stack,pyramid,pile,cubes"
    )]
    pub scenes: Vec<SceneKind>,
    /// Simulated time of the stack and the pyramid (s).
    #[arg(long, default_value_t = 10.0)]
    pub duration_s: f64,
    /// Simulated time of the pile (s).
    #[arg(long, default_value_t = 4.0)]
    pub pile_duration_s: f64,
    /// Simulated time of the cube scenes, cubes and cubes1000 (s).
    #[arg(long, default_value_t = 3.0)]
    pub cubes_duration_s: f64,
    /// Objects in the pile (25 per layer).
    #[arg(long, default_value_t = 100)]
    pub pile_count: usize,
    /// Grid cell size of the splatphys world and lattice spacing of its particles (m).
    #[arg(long, default_value_t = 0.01)]
    pub dx_m: f64,
    /// Coulomb friction of every surface, every engine.
    #[arg(long, default_value_t = 0.5)]
    pub friction: f32,
    /// Restitution of every surface, splatphys and rapier (MuJoCo has none).
    #[arg(long, default_value_t = 0.0)]
    pub restitution: f32,
    /// Density of every body (kg/m³): a 10 cm box of 1000 kg/m³ weighs 1 kg.
    #[arg(long, default_value_t = 1000.0)]
    pub density_kg_m3: f64,
    /// Seed of the pile layout, the cubes' orientations and the particle lattice jitter.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Rapier's fixed step (s); default: the splatphys world's mean substep on each scene.
    #[arg(long)]
    pub rapier_dt_s: Option<f64>,
    /// MuJoCo's fixed step (s); default: MuJoCo's own, 0.002 s.
    #[arg(long)]
    pub mujoco_dt_s: Option<f64>,
    /// The Python that runs MuJoCo (needs the `mujoco` package; without it MuJoCo is skipped).
    #[arg(long, default_value = "python3")]
    pub python: String,
    /// The MuJoCo script; default: bench/mujoco/contact.py of this checkout.
    #[arg(long)]
    pub mujoco_script: Option<PathBuf>,
    /// Do not run MuJoCo.
    #[arg(long, conflicts_with = "mujoco_script")]
    pub no_mujoco: bool,
    /// How the splatphys world solves contacts: `sequential-impulses` (its default) or
    /// `soft-step` (the scheme of Box2D v3 and rapier).
    #[arg(long, value_enum, default_value_t = SolverChoice::SequentialImpulses)]
    pub contact_solver: SolverChoice,
    /// Worker threads of the splatphys world (rapier and MuJoCo run single-threaded).
    #[arg(long, default_value_t = 1)]
    pub threads: usize,
    /// Where `contact.csv`, `contact_bodies.csv`, `.svg` and `.png` go.
    #[arg(long, default_value = "docs/results/bench")]
    pub out_dir: PathBuf,
}

/// `--contact-solver`: the world's [`ContactSolver`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SolverChoice {
    /// Sequential impulses to convergence (the world's default).
    SequentialImpulses,
    /// The soft step of Box2D v3 and rapier.
    SoftStep,
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
    /// "splatphys", or "rapier3d" or "mujoco" with its version.
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
    /// Deepest contact during the run, as the engine measures it (mm; MuJoCo only).
    pub deepest_contact_during_run_mm: Option<f64>,
    /// Largest COM speed at the end (m/s).
    pub max_speed_m_s: f64,
    /// Kinetic energy at the end, translation and rotation (J).
    pub kinetic_energy_j: f64,
    /// Bodies whose COM moves slower than [`REST_SPEED_M_S`] at the end.
    pub below_1cm_s_at_end: usize,
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

/// The speed a body at rest stays below at the end (m/s): 1 cm/s.
pub const REST_SPEED_M_S: f64 = 0.01;

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

/// The row and the per-body rows of one run; `deepest_contact_m` is the deepest contact the
/// engine saw during the run (m), where it reports one.
fn rows(
    scene: &ContactScene,
    mass: &[MassProps],
    engine: &str,
    threads: usize,
    run: &EngineRun,
    deepest_contact_m: Option<f64>,
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
        deepest_contact_during_run_mm: deepest_contact_m.map(|d| d * 1e3),
        max_speed_m_s: run
            .bodies
            .iter()
            .map(|f| f.velocity_m_s.length())
            .fold(0.0, f64::max),
        kinetic_energy_j: kinetic_energy_j(mass, run),
        below_1cm_s_at_end: run
            .bodies
            .iter()
            .filter(|f| f.velocity_m_s.length() < REST_SPEED_M_S)
            .count(),
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
pub const OURS: &str = "splatphys";

/// The rapier engine name, with its version.
#[cfg(feature = "rapier")]
fn rapier_name() -> String {
    format!("rapier3d {}", rapier::VERSION)
}

/// Runs `bench contact`.
///
/// # Errors
/// Bad arguments, a scene or world that cannot be built, a failed substep, a MuJoCo script that
/// is missing or fails, unwritable output.
pub fn run(a: &ContactBenchArgs) -> Result<()> {
    let positive = |v: f64| v.is_finite() && v > 0.0;
    if a.scenes.is_empty() {
        bail!("--scenes: name at least one of stack, pyramid, pile, cubes, cubes1000");
    }
    if ![a.duration_s, a.pile_duration_s, a.cubes_duration_s, a.dx_m]
        .into_iter()
        .all(positive)
    {
        bail!("--duration-s, --pile-duration-s, --cubes-duration-s and --dx-m must be positive");
    }
    if a.rapier_dt_s.is_some_and(|dt| !positive(dt)) {
        bail!("--rapier-dt-s must be positive");
    }
    if a.mujoco_dt_s.is_some_and(|dt| !positive(dt)) {
        bail!("--mujoco-dt-s must be positive");
    }
    if a.pile_count == 0 && a.scenes.contains(&SceneKind::Pile) {
        bail!("--pile-count must be at least 1");
    }
    // A missing script is a broken checkout (an error); a missing mujoco a skip, below.
    let mujoco_script = if a.no_mujoco {
        None
    } else {
        Some(mujoco::find_script(
            mujoco::SCRIPT,
            a.mujoco_script.as_deref(),
        )?)
    };
    let settings = ContactSettings {
        friction: a.friction,
        restitution: a.restitution,
        density_kg_m3: a.density_kg_m3,
        dx_m: a.dx_m,
        seed: a.seed,
        contact_solver: match a.contact_solver {
            SolverChoice::SequentialImpulses => ContactSolver::SequentialImpulses,
            SolverChoice::SoftStep => ContactSolver::SoftStep,
        },
    };
    let pool = crate::thread_pool(a.threads)?;
    let plans: Vec<(ContactScene, f64)> = a
        .scenes
        .iter()
        .map(|&k| {
            let d = match k {
                SceneKind::Pile => a.pile_duration_s,
                k if k.is_cubes() => a.cubes_duration_s,
                _ => a.duration_s,
            };
            (ContactScene::new(k, a.pile_count, a.seed), d)
        })
        .collect();
    let mujoco_on = mujoco_script.is_some();
    let engines = 1 + u64::from(cfg!(feature = "rapier")) + u64::from(mujoco_on);
    let total_ms: u64 = plans.iter().map(|(_, d)| (d * 1e3) as u64 * engines).sum();
    let pb = ProgressBar::new(total_ms);
    pb.set_style(
        ProgressStyle::with_template("contact {msg} [{bar:30}] {pos}/{len} simulated ms {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let json_line = |row: &ContactRow| {
        pb.suspend(|| println!("{}", serde_json::to_string(row).unwrap_or_default()));
    };
    let mut table = Vec::new();
    let mut body_rows = Vec::new();
    let mut base_ms = 0;
    // Cleared when MuJoCo turns out missing, so it is skipped (and said so) once.
    let mut mujoco_script = mujoco_script;
    for (scene, duration_s) in &plans {
        let name = scene.kind.name();
        let span_ms = (duration_s * 1e3) as u64;
        pb.set_message(format!("{name}: {OURS}"));
        let (mut world, mass) = ours::build(scene, &settings, *duration_s)?;
        let gravity = world.gravity_m_s2().as_dvec3();
        let progress = Progress {
            pb: Some(&pb),
            base_ms,
        };
        let ours_run = pool.install(|| ours::run(&mut world, &progress))?;
        drop(world);
        base_ms += span_ms;
        let (ours_row, bodies) = rows(scene, &mass, OURS, a.threads, &ours_run, None);
        json_line(&ours_row);
        body_rows.extend(bodies);
        #[cfg(feature = "rapier")]
        let rapier_row = {
            pb.set_message(format!("{name}: rapier3d"));
            let dt = a
                .rapier_dt_s
                .unwrap_or(ours_run.simulated_s / ours_run.steps.max(1) as f64);
            let (mut rw, handles) = rapier::build(scene, &settings, &mass, gravity, dt)?;
            let progress = Progress {
                pb: Some(&pb),
                base_ms,
            };
            let start: Vec<_> = scene
                .bodies
                .iter()
                .map(scenes::BodySpec::orientation)
                .collect();
            let theirs = rapier::run(&mut rw, &handles, &start, *duration_s, &progress);
            base_ms += span_ms;
            let (row, bodies) = rows(scene, &mass, &rapier_name(), 1, &theirs, None);
            json_line(&row);
            body_rows.extend(bodies);
            Some(row)
        };
        #[cfg(not(feature = "rapier"))]
        let rapier_row = None;
        let mut mujoco_row = None;
        if let Some(script) = &mujoco_script {
            pb.set_message(format!("{name}: mujoco"));
            let r = mujoco::run(
                scene,
                &mass,
                &settings,
                gravity,
                *duration_s,
                a.mujoco_dt_s,
                &a.python,
                script,
            )
            .with_context(|| format!("MuJoCo on the {name} scene"))?;
            match r {
                Some(m) => {
                    let (row, bodies) = rows(
                        scene,
                        &mass,
                        &m.engine,
                        1,
                        &m.run,
                        Some(m.deepest_contact_m),
                    );
                    json_line(&row);
                    body_rows.extend(bodies);
                    mujoco_row = Some(row);
                }
                None => mujoco_script = None,
            }
        }
        // Skipped or not, MuJoCo's share of the bar is done.
        base_ms += span_ms * u64::from(mujoco_on);
        pb.set_position(base_ms);
        table.push(SceneRows {
            ours: ours_row,
            rapier: rapier_row,
            mujoco: mujoco_row,
        });
    }
    pb.finish_and_clear();
    if !cfg!(feature = "rapier") {
        eprintln!("contact: built without the `rapier` feature: no rapier3d reference");
    }
    print!("{}", report::format_table(&table));
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("creating {}", a.out_dir.display()))?;
    let stem = a.out_dir.join("contact");
    let all: Vec<&ContactRow> = table.iter().flat_map(SceneRows::all).collect();
    report::write_csv(&stem.with_extension("csv"), &all)?;
    report::write_csv(&a.out_dir.join("contact_bodies.csv"), &body_rows)?;
    report::draw(&stem, &table, a)?;
    Ok(())
}
