//! splatphys-bench: every benchmark and experiment of the `splatphys-bench` binary (which
//! `splatphys bench` runs), printed as JSON lines (never timed tests), with their charts and the
//! Taichi references in `bench/taichi/`. The shipped `splatphys` command links none of it
//! (no plotting, no rapier).
//!
//! `bench mpm` ([`crate::mpm`]) measures MLS-MPM throughput on the standard problem, optionally
//! against Taichi in the same run; `bench ipc` ([`crate::ipc`]) measures the shared-memory frame path against a Unix
//! socket and the server under a command flood; `bench compare` ([`crate::compare`]) the
//! COM method against its baselines; `bench stability` ([`crate::stability`]) maps which
//! E, nu, impact speed and time step each method and material survives; `bench contact`
//! ([`crate::contact`]) rigid stacking and piling against rapier3d and MuJoCo; `bench
//! soak` ([`crate::soak`]) memory growth of a server and a recorder over minutes. Charts
//! go through [`crate::chart`].

pub mod chart;
pub mod child;
pub mod cli;
pub mod compare;
pub mod contact;
pub mod flood;
pub mod ipc;
pub mod ipc_zenoh;
pub mod islands;
pub mod mpm;
pub mod peer;
pub mod realtime;
pub mod sag;
pub mod script;
pub mod soak;
pub mod stability;
pub mod subsets;
pub mod taichi;

use anyhow::{Context, Result};
use clap::Subcommand;
use splatphys_core::scene::Scene;
use splatphys_ipc::Simulation;

/// Benchmarks.
#[derive(Subcommand, Debug)]
pub enum BenchCommand {
    /// MLS-MPM throughput on the standard elastic-cube problem.
    #[command(
        after_help = "Examples:\n  splatphys bench mpm --particles-per-axis 40 --grid 64 --steps 200 --threads 2\n  splatphys bench mpm --vs-taichi    # also the Taichi reference (pip install taichi)"
    )]
    Mpm(crate::mpm::MpmBenchArgs),
    /// Shared-memory frame latency and publish cost against a Unix socket, and stepping under a
    /// command flood.
    #[command(
        after_help = "Example:\n  splatphys bench ipc --sizes 1000,10000,100000,1000000 --samples 200 --out-dir docs/results/bench"
    )]
    Ipc(crate::ipc::IpcBenchArgs),
    /// The COM method against the `mpm` and `multi-field` baselines: error against the
    /// restitution law versus wall time, and time per substep versus particle count (charts and
    /// CSV in --out-dir).
    #[command(
        after_help = "Examples:\n  splatphys bench compare\n  splatphys bench compare --dx-m 0.02,0.01 --particles 10000,100000 --objects 2 --out-dir out/cmp"
    )]
    Compare(crate::compare::CompareBenchArgs),
    /// The `mpm` baseline of `compare` (two elastic spheres head-on on one shared grid) at one
    /// cell size: throughput and rebound, optionally against the Taichi reference.
    #[command(after_help = "Example:\n  splatphys bench spheres --dx-m 0.02 --vs-taichi")]
    Spheres(crate::taichi::SpheresArgs),
    /// The stability map: which E, nu, impact speed and forced CFL number each method survives
    /// for every material model, on a two-sphere impact (heat maps and CSV in --out-dir).
    #[command(
        after_help = "Examples:\n  splatphys bench stability\n  splatphys bench stability --quick --out-dir out/stab\n  splatphys bench stability --methods com --materials jelly,snow --threads 2"
    )]
    Stability(crate::stability::StabilityBenchArgs),
    /// Physics-particle subsets on a captured scene: COM and per-Gaussian error against the
    /// full-particle run versus speed-up, ratios 1 to 1/64 (chart and CSV in --out-dir).
    #[command(
        after_help = "Examples:\n  splatphys bench subsets\n  splatphys bench subsets --scene scenes/guitar_topple.toml --ratios 1,4,16 --duration-s 0.5 --out-dir out/sub"
    )]
    Subsets(crate::subsets::SubsetsBenchArgs),
    /// Real time: coarser grids with particles at half the cell size on captured scenes, error
    /// in reference cells against simulated frames per wall second (chart and CSV in --out-dir).
    #[command(
        after_help = "Examples:\n  splatphys bench realtime\n  splatphys bench realtime --scenes scenes/donut_snow_push.toml --duration-s 0.6 --dx-m 0.005,0.01,0.02 --out-dir out/rt"
    )]
    Realtime(crate::realtime::RealtimeBenchArgs),
    /// The static sag of a deformable object resting under gravity at several grid cells and
    /// physics spacings, against the finest (JSON lines, `sag.csv` in --out-dir).
    #[command(
        after_help = "Examples:\n  splatphys bench sag\n  splatphys bench sag --levels 0.005,0.01:0.005,0.02:0.01 --youngs-modulus-pa 2e5 --out-dir out/sag\n  splatphys bench sag --levels 0.005:0.0025,0.02:0.01 --shift-m 0,0.005,0.01,0.015 --out-dir out/sag"
    )]
    Sag(crate::sag::SagBenchArgs),
    /// Objects out of each other's reach stepped apart, each island at its own substep, against
    /// the scene stepped as one: substeps per object, wall time, how far the outcome moved
    /// (JSON lines, `islands.csv` in --out-dir).
    #[command(after_help = "Examples:
  splatphys bench islands
  splatphys bench islands --scene scenes/stiff_and_soft.toml --duration-s 0.5 --repeat 3 --out-dir out/islands")]
    Islands(crate::islands::IslandsBenchArgs),
    /// Rigid-body contact against rapier3d (same process) and MuJoCo (python3 with `mujoco`,
    /// at its defaults; skipped when missing): a stack of 10 boxes, a pyramid of 15, a pile of
    /// 100 boxes and balls and 125 randomly turned cubes in open boxes (1,000 cubes on request);
    /// COM drift, overlap, bodies at rest, kinetic energy and time per step (table, chart and
    /// CSV in --out-dir).
    #[command(
        after_help = "Examples:\n  splatphys bench contact\n  splatphys bench contact --duration-s 1 --pile-duration-s 1 --cubes-duration-s 1 --out-dir out/contact\n  splatphys bench contact --scenes cubes,cubes1000 --seed 3 --no-mujoco\n  splatphys bench contact --scenes stack --rapier-dt-s 0.0166667 --mujoco-dt-s 0.001\n  splatphys bench contact --no-mujoco\n  splatphys bench contact --python .venv/bin/python"
    )]
    Contact(crate::contact::ContactBenchArgs),
    /// Server, lossless recorder and controller together for minutes: RSS of the server and the
    /// recorder over the run, frames lost, /dev/shm leftovers (CSV and chart in --out-dir).
    #[command(
        after_help = "Examples:\n  splatphys bench soak --minutes 30\n  splatphys bench soak --minutes 2 --sample-s 5 --commands-hz 1000 scenes/donut_drop.toml"
    )]
    Soak(crate::soak::SoakBenchArgs),
    /// A child process of `bench ipc` (subscriber, socket reader or command flood).
    #[command(hide = true)]
    IpcPeer(crate::peer::PeerArgs),
}

/// Builds the real simulation of a scene as a server-ready [`Simulation`] (the app's sim-core ↔
/// ipc adapter). The bench crate takes it as an argument so that it needs neither the app nor a
/// copy of the adapter; `bench ipc --flood-sim default` serves it.
pub type WorldSimFactory = fn(name: &str, scene: &Scene) -> Result<Box<dyn Simulation + Send>>;

/// Runs a benchmark subcommand; `world` builds the real simulation where a bench serves one.
///
/// # Errors
/// Whatever the benchmark reports (bad arguments, a failed run, an unwritable output folder).
pub fn run(cmd: &BenchCommand, world: WorldSimFactory) -> Result<()> {
    match cmd {
        BenchCommand::Mpm(a) => crate::mpm::run(a),
        BenchCommand::Ipc(a) => crate::ipc::run(a, world),
        BenchCommand::Compare(a) => crate::compare::run(a),
        BenchCommand::Spheres(a) => crate::taichi::spheres(a),
        BenchCommand::Stability(a) => crate::stability::run(a),
        BenchCommand::Subsets(a) => crate::subsets::run(a),
        BenchCommand::Realtime(a) => crate::realtime::run(a),
        BenchCommand::Sag(a) => crate::sag::run(a),
        BenchCommand::Islands(a) => crate::islands::run(a),
        BenchCommand::Contact(a) => crate::contact::run(a),
        BenchCommand::Soak(a) => crate::soak::run(a),
        BenchCommand::IpcPeer(a) => crate::peer::run(a),
    }
}

/// A rayon pool of `threads` workers for one bench (results never depend on the count).
///
/// # Errors
/// When the pool cannot be built.
pub fn thread_pool(threads: usize) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("thread pool")
}
