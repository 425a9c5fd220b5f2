//! `splatphys bench`: benchmarks printed as JSON lines (never timed tests).
//!
//! `bench mpm` is the standard CPU problem Taichi MLS-MPM users run: an elastic cube of n³
//! particles (side 0.3 m, corner (0.35, 0.35, 0.3) m) moving at 1 m/s towards the floor of a 1 m
//! cube domain, dx = 1/grid m, E = 1e5 Pa, nu = 0.3, 1000 kg/m³, fixed dt = 1e-4 s, gravity
//! 9.8 m/s², timed over `steps` substeps after 5 warm-up substeps. `--domain-scale 4` puts the same
//! cube in a domain 4× larger per axis: with the sparse grid the cost must not change.

use std::time::Instant;

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use glam::Vec3A;
use serde_json::json;
use splatphys_core::collider::{BoxShape, Collider, Shape, Surface};
use splatphys_core::material::Material;
use splatphys_core::mpm::{MpmSystem, Particles, TimeStepPolicy};

/// Benchmarks.
#[derive(Subcommand, Debug)]
pub enum BenchCommand {
    /// MLS-MPM throughput on the standard elastic-cube problem.
    #[command(
        after_help = "Example:\n  splatphys bench mpm --particles-per-axis 40 --grid 64 --steps 200 --threads 2"
    )]
    Mpm(MpmBenchArgs),
}

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
}

/// Runs a benchmark subcommand.
pub fn run(cmd: &BenchCommand) -> Result<()> {
    match cmd {
        BenchCommand::Mpm(a) => mpm(a),
    }
}

fn mpm(a: &MpmBenchArgs) -> Result<()> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads)
        .build()
        .context("thread pool")?;
    let n = a.particles_per_axis.max(1);
    let dx = 1.0 / a.grid.max(1) as f32;
    let spacing = 0.3 / n as f32;
    let jelly = Material::jelly(1e5, 0.3, 1000.0)?;
    let mut p = Particles::lattice_box(
        Vec3A::new(0.35, 0.35, 0.3),
        Vec3A::new(0.65, 0.65, 0.6),
        spacing,
        1000.0,
        0,
        0,
    );
    p.v.iter_mut().for_each(|v| *v = Vec3A::new(0.0, 0.0, -1.0));
    let count = p.len();
    let mut sys = MpmSystem::new(p, vec![jelly], dx);
    sys.gravity_m_s2 = Vec3A::new(0.0, 0.0, -9.8);
    sys.policy = TimeStepPolicy::Fixed {
        dt_s: 1e-4,
        force: false,
    };
    let bound = BoxShape::new(
        Vec3A::splat(3.0 * dx),
        Vec3A::splat(a.domain_scale - 3.0 * dx),
    )
    .context("--domain-scale too small")?;
    sys.colliders.push(Collider::fixed(
        Shape::DomainBound(bound),
        Surface::Separate,
        0.0,
    ));
    let seconds = pool.install(|| -> Result<f64> {
        for _ in 0..5 {
            sys.substep(1.0)?;
        }
        let t = Instant::now();
        for _ in 0..a.steps {
            sys.substep(1.0)?;
        }
        Ok(t.elapsed().as_secs_f64())
    })?;
    let rate = (count as f64 * a.steps as f64) / seconds;
    println!(
        "{}",
        json!({
            "bench": "mpm",
            "particles": count,
            "steps": a.steps,
            "threads": a.threads,
            "grid": a.grid,
            "domain_scale": a.domain_scale,
            "grid_blocks": sys.last.grid_blocks,
            "seconds": seconds,
            "particle_substeps_per_s": rate,
        })
    );
    Ok(())
}
