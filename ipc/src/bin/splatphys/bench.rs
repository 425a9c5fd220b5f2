//! `splatphys bench`: benchmarks printed as JSON lines (never timed tests).
//!
//! `bench mpm` is the standard CPU problem Taichi MLS-MPM users run: an elastic cube of n³
//! particles (side 0.3 m, corner (0.35, 0.35, 0.3) m) moving at 1 m/s towards the floor of a 1 m
//! cube domain, dx = 1/grid m, E = 1e5 Pa, nu = 0.3, 1000 kg/m³, fixed dt = 1e-4 s, gravity
//! 9.8 m/s², timed over `steps` substeps after 5 warm-up substeps. `--domain-scale 4` puts the same
//! cube in a domain 4× larger per axis: with the sparse grid the cost must not change.
//!
//! `bench ipc` ([`crate::bench_ipc`]) measures the shared-memory frame path against a Unix
//! socket and the server under a command flood; `bench compare` ([`crate::bench_compare`]) the
//! COM method against its baselines. Charts go through [`crate::chart`].

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
    /// Shared-memory frame latency and publish cost against a Unix socket, and stepping under a
    /// command flood.
    #[command(
        after_help = "Example:\n  splatphys bench ipc --sizes 1000,10000,100000,1000000 --samples 200 --out-dir docs/bench"
    )]
    Ipc(crate::bench_ipc::IpcBenchArgs),
    /// The COM method against the `mpm` and `multi-field` baselines: error against the
    /// restitution law versus wall time, and time per substep versus particle count (charts and
    /// CSV in --out-dir).
    #[command(
        after_help = "Examples:\n  splatphys bench compare\n  splatphys bench compare --dx-m 0.02,0.01 --particles 10000,100000 --objects 2 --out-dir /tmp/cmp"
    )]
    Compare(crate::bench_compare::CompareBenchArgs),
    /// A child process of `bench ipc` (subscriber, socket reader or command flood).
    #[command(hide = true)]
    IpcPeer(crate::bench_peer::PeerArgs),
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
        BenchCommand::Ipc(a) => crate::bench_ipc::run(a),
        BenchCommand::Compare(a) => crate::bench_compare::run(a),
        BenchCommand::IpcPeer(a) => crate::bench_peer::run(a),
    }
}

/// The standard problem's elastic cube: n³ particles filling (0.35, 0.35, 0.3)..(0.65, 0.65,
/// 0.6) m, moving at 1 m/s towards the floor, grid spacing `dx_m`, in a cube domain of edge
/// `domain_m` metres; E = 1e5 Pa, nu = 0.3, 1000 kg/m³, fixed dt = 1e-4 s, gravity 9.8 m/s².
///
/// # Errors
/// When the domain is too small for its 3-cell bound.
pub fn elastic_cube(particles_per_axis: u32, dx_m: f32, domain_m: f32) -> Result<MpmSystem> {
    let n = particles_per_axis.max(1);
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
    let mut sys = MpmSystem::new(p, vec![jelly], dx_m);
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

fn mpm(a: &MpmBenchArgs) -> Result<()> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads)
        .build()
        .context("thread pool")?;
    let dx = 1.0 / a.grid.max(1) as f32;
    let mut sys = elastic_cube(a.particles_per_axis, dx, a.domain_scale)
        .context("--domain-scale too small")?;
    let count = sys.particles.len();
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
