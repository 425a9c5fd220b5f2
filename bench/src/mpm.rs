//! `bench mpm`: MLS-MPM throughput on the standard CPU problem Taichi MLS-MPM users run: an
//! elastic cube of n³ particles (side 0.3 m, corner (0.35, 0.35, 0.3) m) moving at 1 m/s towards
//! the floor of a 1 m cube domain, dx = 1/grid m, E = 1e5 Pa, nu = 0.3, 1000 kg/m³, fixed
//! dt = 1e-4 s, gravity 9.8 m/s², timed over `steps` substeps after 5 warm-up substeps.
//! `--domain-scale 4` puts the same cube in a domain 4× larger per axis: with the sparse grid the
//! cost must not change. `--vs-taichi` then runs the Taichi reference of the same problem
//! (`bench/taichi/mpm_cube.py`, through [`crate::taichi`]) with the same arguments and prints its
//! result and the ratio; without Taichi it says so and stops after our result. `--device gpu`
//! runs the same problem through splatphys-gpu (dense grid over the domain; the Taichi reference
//! then runs on CUDA). `--model` picks the cube's material (jelly by default).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use glam::Vec3A;
use serde_json::json;
use splatphys_core::collider::{BoxShape, Collider, Shape, Surface};
use splatphys_core::material::{Material, MaterialModel, MaterialSpec};
use splatphys_core::mpm::{MpmSystem, Particles, TimeStepPolicy};

use crate::{taichi, thread_pool};

/// Untimed substeps before the clock starts (the Taichi reference compiles its kernel there).
const WARMUP_SUBSTEPS: u32 = 5;
/// Substeps `--profile` times kernel by kernel.
#[cfg(feature = "gpu")]
const PROFILED_SUBSTEPS: u32 = 100;

/// Arguments of `bench mpm`.
#[derive(Args, Debug)]
pub struct MpmBenchArgs {
    /// Particles per cube edge (n³ particles).
    #[arg(long, default_value_t = 40)]
    pub particles_per_axis: u32,
    /// Grid cells per metre (dx = 1 / grid m).
    #[arg(long, default_value_t = 64)]
    pub grid: u32,
    /// Timed substeps.
    #[arg(long, default_value_t = 200)]
    pub steps: u32,
    /// Worker threads.
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Domain edge in metres (the cube stays where it is).
    #[arg(long, default_value_t = 1.0)]
    pub domain_scale: f32,
    /// Store the particles in a fixed pseudo-random order instead of lattice order, as a captured
    /// scene's Gaussians usually arrive: the same physics (sums run in another order, so results
    /// differ in rounding only) with a scattered memory access pattern. The Taichi reference is
    /// not affected.
    #[arg(long)]
    pub shuffle: bool,
    /// Then run the Taichi reference of the same problem (bench/taichi/mpm_cube.py, dense grid;
    /// its CPU backend, or CUDA with --device gpu) with the same arguments and print its result
    /// and the ratio; skipped with a message when Taichi is not installed.
    #[arg(long)]
    pub vs_taichi: bool,
    /// The Taichi script (default: bench/taichi/mpm_cube.py in the current directory or the
    /// repository the executable was built in).
    #[arg(long, requires = "vs_taichi")]
    pub taichi_script: Option<PathBuf>,
    /// Python interpreter for --vs-taichi.
    #[arg(long, default_value = "python3", requires = "vs_taichi")]
    pub python: String,
    /// Where the kernels run: `cpu` (the sparse grid, `--threads` workers) or `gpu` (WGSL
    /// compute shaders through wgpu on the first adapter: a GPU, or Mesa's lavapipe; a dense
    /// grid over the domain).
    #[arg(long, value_enum, default_value_t = Device::Cpu)]
    pub device: Device,
    /// The cube's material model (jelly, neo-hookean, snow, sand, metal, plasticine, foam), with
    /// the problem's E, ν and density and the model's default parameters. The Taichi reference
    /// runs jelly only.
    #[arg(long, default_value_t = MaterialModel::FixedCorotated)]
    pub model: MaterialModel,
    /// With `--device gpu`: after the timed run, time each kernel over 100 more substeps
    /// (GPU timestamps, each kernel in a pass of its own), the two kernels of the moments a
    /// scene reads back after every substep (`moments`, `moments_total`), and on the host's
    /// clock a substep followed by that read-back, as a scene takes it
    /// (`substep_and_report_wall`: queueing the substep, `substep_queue_wall`, then the report,
    /// `report_wall`), and a bare 16-byte read-back polling and blocking (`bare_read_wall`,
    /// `bare_read_blocking_wall`); the mean µs of each are added to the line (`phases_us`).
    /// Needs an adapter with timestamp queries.
    #[arg(long)]
    pub profile: bool,
}

/// Where `bench mpm` runs the kernels.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum Device {
    /// The CPU solver.
    Cpu,
    /// The GPU backend (splatphys-gpu).
    Gpu,
}

/// The standard problem's elastic cube: n³ particles filling (0.35, 0.35, 0.3)..(0.65, 0.65,
/// 0.6) m, moving at 1 m/s towards the floor, grid spacing `dx_m`, in a cube domain of edge
/// `domain_m` metres; E = 1e5 Pa, nu = 0.3, 1000 kg/m³, fixed dt = 1e-4 s, gravity 9.8 m/s².
///
/// # Errors
/// When the domain is too small for its 3-cell bound.
pub fn elastic_cube(particles_per_axis: u32, dx_m: f32, domain_m: f32) -> Result<MpmSystem> {
    cube_of(
        MaterialModel::FixedCorotated,
        particles_per_axis,
        dx_m,
        domain_m,
    )
}

/// [`elastic_cube`] of material `model` (its default parameters beside the problem's E, ν and
/// density).
///
/// # Errors
/// When the domain is too small for its 3-cell bound.
pub fn cube_of(
    model: MaterialModel,
    particles_per_axis: u32,
    dx_m: f32,
    domain_m: f32,
) -> Result<MpmSystem> {
    let n = particles_per_axis.max(1);
    let spacing = 0.3 / n as f32;
    let material = Material::from_spec(&MaterialSpec::new(model, 1e5, 0.3, 1000.0))?;
    let mut p = Particles::lattice_box(
        Vec3A::new(0.35, 0.35, 0.3),
        Vec3A::new(0.65, 0.65, 0.6),
        spacing,
        1000.0,
        0,
        0,
    );
    p.v.iter_mut().for_each(|v| *v = Vec3A::new(0.0, 0.0, -1.0));
    let mut sys = MpmSystem::new(p, vec![material], dx_m);
    sys.gravity_m_s2 = Vec3A::new(0.0, 0.0, -9.8);
    sys.policy = TimeStepPolicy::Fixed {
        dt_s: 1e-4,
        force: false,
    };
    let bound = BoxShape::new(
        Vec3A::splat(3.0 * dx_m),
        Vec3A::splat(domain_m - 3.0 * dx_m),
    )
    .context("domain too small")?;
    sys.colliders.push(Collider::fixed(
        Shape::DomainBound(bound),
        Surface::Separate,
        0.0,
    ));
    Ok(sys)
}

/// The particles in a fixed pseudo-random order (ChaCha8, seed 0).
fn shuffled(p: &Particles) -> Particles {
    use rand::SeedableRng;
    use rand::seq::SliceRandom;
    let mut order: Vec<usize> = (0..p.len()).collect();
    order.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(0));
    p.permuted(&order)
        .expect("a shuffle of 0..N is a permutation")
}

/// Runs `bench mpm`.
///
/// # Errors
/// A bad domain, a failed Taichi reference, unwritable output.
pub fn run(a: &MpmBenchArgs) -> Result<()> {
    // Resolved first: a broken checkout fails before the run, not after it.
    let script = if a.vs_taichi {
        Some(taichi::find_script(
            "mpm_cube.py",
            a.taichi_script.as_deref(),
        )?)
    } else {
        None
    };
    let pool = thread_pool(a.threads)?;
    let dx = 1.0 / a.grid.max(1) as f32;
    if a.vs_taichi && a.model != MaterialModel::FixedCorotated {
        anyhow::bail!(
            "--vs-taichi runs the jelly cube only (the Taichi reference has no {} model)",
            a.model
        );
    }
    let mut sys = cube_of(a.model, a.particles_per_axis, dx, a.domain_scale)
        .context("--domain-scale too small")?;
    if a.shuffle {
        sys.particles = shuffled(&sys.particles);
    }
    let count = sys.particles.len();
    if a.device == Device::Gpu {
        let line = gpu_run(a, &mut sys)?;
        println!("{line}");
        return match script {
            Some(script) => vs_taichi(a, &script, &line),
            None => Ok(()),
        };
    }
    let seconds = pool.install(|| -> Result<f64> {
        for _ in 0..WARMUP_SUBSTEPS {
            sys.substep(1.0)?;
        }
        let t = Instant::now();
        for _ in 0..a.steps {
            sys.substep(1.0)?;
        }
        Ok(t.elapsed().as_secs_f64())
    })?;
    let rate = (count as f64 * a.steps as f64) / seconds;
    let (com_z, momentum_z) = com_and_momentum_z(&sys.particles);
    let ours = json!({
        "bench": "mpm",
        "impl": "splatphys",
        "device": "cpu",
        "model": a.model.name(),
        "particles": count,
        "steps": a.steps,
        "threads": a.threads,
        "grid": a.grid,
        "domain_scale": a.domain_scale,
        "shuffled": a.shuffle,
        "grid_blocks": sys.last.grid_blocks,
        "seconds": seconds,
        "particle_substeps_per_s": rate,
        "com_z_m": com_z,
        "momentum_z_kg_m_s": momentum_z,
    });
    println!("{ours}");
    match script {
        Some(script) => vs_taichi(a, &script, &ours),
        None => Ok(()),
    }
}

/// The particles' COM height (m) and z momentum (kg m/s).
fn com_and_momentum_z(p: &Particles) -> (f64, f64) {
    let mass: f64 = p.mass_kg.iter().map(|&m| m as f64).sum();
    let com_z =
        p.x.iter()
            .zip(&p.mass_kg)
            .map(|(x, &m)| x.z as f64 * m as f64)
            .sum::<f64>()
            / mass.max(f64::MIN_POSITIVE);
    let momentum_z: f64 =
        p.v.iter()
            .zip(&p.mass_kg)
            .map(|(v, &m)| v.z as f64 * m as f64)
            .sum();
    (com_z, momentum_z)
}

/// The same problem on the GPU: warm-up substeps, then `--steps` queued at once and timed until
/// the GPU has finished them; the JSON line of [`run`] with the adapter's name.
#[cfg(feature = "gpu")]
fn gpu_run(a: &MpmBenchArgs, sys: &mut MpmSystem) -> Result<serde_json::Value> {
    use splatphys_gpu::{GpuContext, GpuMpm};
    let ctx = GpuContext::new()?;
    let device = ctx.name();
    let mut gpu = GpuMpm::new(ctx, sys)?;
    let dt = 1e-4;
    gpu.substeps(WARMUP_SUBSTEPS, dt);
    gpu.check()?;
    let t = Instant::now();
    gpu.substeps(a.steps, dt);
    gpu.check()?;
    let seconds = t.elapsed().as_secs_f64();
    gpu.read_particles(&mut sys.particles)?;
    let count = sys.particles.len();
    let (com_z, momentum_z) = com_and_momentum_z(&sys.particles);
    let phases = if a.profile {
        let profile = gpu.profile(PROFILED_SUBSTEPS, dt)?;
        gpu.check()?;
        let mut phases: serde_json::Map<String, serde_json::Value> = (profile.phases_us.iter())
            .map(|(name, us)| (name.clone(), json!(us)))
            .collect();
        // A substep as a scene takes it on the device: then its report, read back.
        let reference = glam::Vec3A::splat(0.5);
        let trip = gpu.round_trip(PROFILED_SUBSTEPS, dt, reference)?;
        phases.insert("substep_and_report_wall".into(), json!(trip.total_us));
        phases.insert("substep_queue_wall".into(), json!(trip.queue_us));
        phases.insert("report_wall".into(), json!(trip.report_us));
        phases.insert("bare_read_wall".into(), json!(trip.bare_read_us));
        phases.insert(
            "bare_read_blocking_wall".into(),
            json!(trip.bare_read_blocking_us),
        );
        Some(phases)
    } else {
        None
    };
    Ok(json!({
        "bench": "mpm",
        "impl": "splatphys",
        "device": device,
        "model": a.model.name(),
        "particles": count,
        "steps": a.steps,
        "grid": a.grid,
        "domain_scale": a.domain_scale,
        "shuffled": a.shuffle,
        "grid_nodes": gpu.grid_nodes(),
        "seconds": seconds,
        "particle_substeps_per_s": (count as f64 * a.steps as f64) / seconds,
        "com_z_m": com_z,
        "momentum_z_kg_m_s": momentum_z,
        "phases_us": phases,
    }))
}

/// Without the `gpu` feature: says so.
#[cfg(not(feature = "gpu"))]
fn gpu_run(_: &MpmBenchArgs, _: &mut MpmSystem) -> Result<serde_json::Value> {
    anyhow::bail!(
        "--device gpu: this build has no GPU backend (build splatphys-bench with the `gpu` feature)"
    )
}

/// Runs the Taichi reference with `a`'s arguments and prints its line and the comparison.
fn vs_taichi(a: &MpmBenchArgs, script: &std::path::Path, ours: &serde_json::Value) -> Result<()> {
    let args = [
        ("--particles-per-axis", a.particles_per_axis.to_string()),
        ("--grid", a.grid.to_string()),
        ("--steps", a.steps.to_string()),
        ("--threads", a.threads.to_string()),
        ("--warmup", WARMUP_SUBSTEPS.to_string()),
        ("--domain-scale", a.domain_scale.to_string()),
        (
            "--arch",
            match a.device {
                Device::Cpu => "cpu",
                Device::Gpu => "cuda",
            }
            .to_string(),
        ),
    ];
    let Some(theirs) = taichi::run_reference(&a.python, script, &args)? else {
        return Ok(());
    };
    if theirs["particles"] != ours["particles"] {
        anyhow::bail!(
            "the Taichi reference ran {} particles, splatphys {}: not the same problem",
            theirs["particles"],
            ours["particles"]
        );
    }
    let key = "particle_substeps_per_s";
    let ours_rate = taichi::number(ours, key, "splatphys")?;
    let taichi_rate = taichi::number(&theirs, key, "Taichi")?;
    let com_diff = taichi::number(ours, "com_z_m", "splatphys")?
        - taichi::number(&theirs, "com_z_m", "Taichi")?;
    let momentum_diff = taichi::number(ours, "momentum_z_kg_m_s", "splatphys")?
        - taichi::number(&theirs, "momentum_z_kg_m_s", "Taichi")?;
    println!(
        "{}",
        json!({
            "bench": "mpm-vs-taichi",
            "particles": ours["particles"],
            "threads": a.threads,
            "splatphys_per_s": ours_rate,
            "taichi_per_s": taichi_rate,
            "ratio": ours_rate / taichi_rate,
            "com_z_diff_m": com_diff,
            "momentum_z_diff_kg_m_s": momentum_diff,
            "taichi_version": theirs["taichi_version"],
            "taichi_arch": theirs["arch"],
            "device": ours["device"],
        })
    );
    Ok(())
}
