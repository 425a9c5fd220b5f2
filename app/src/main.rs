//! `splatphys`: the main job, the server, inspection and benchmarks.

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};

mod inspect;
mod run;
mod serve;
mod uplift;

/// splatphys: captured 3D Gaussian Splatting scenes made physical.
///
/// Loads a 3DGS scene, simulates its objects with MPM and a centre-of-mass object layer, and
/// serves every step over iceoryx2 shared memory to renderer, recorder and controller processes.
#[derive(Parser, Debug)]
#[command(
    version,
    about,
    long_about,
    after_help = "Examples:
  splatphys run --out out/default                         # built-in scene: server + recorder + renderer
  splatphys run scenes/donut_drop.toml --out out/donut    # a captured donut on a table
  splatphys serve scenes/donut_drop.toml                  # the server alone
  splatphys inspect ../shared/data/v3dg_donut.ply
  splatphys uplift --ply scene.ply --cameras transforms.json --features feats/ --out scene_feat.ply
  splatphys bench mpm --particles-per-axis 40 --grid 64 --steps 200 --threads 2
  splatphys bench mpm --vs-taichi                         # the same problem in Taichi, same run
  splatphys bench ipc --sizes 1000,10000,100000,1000000 --out-dir docs/results/bench
  splatphys bench stability --out-dir docs/results/bench"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// The main job: server, recorder and renderer processes on a scene.
    Run(run::RunArgs),
    /// Serve a scene over iceoryx2 shared memory; clients attach and detach freely.
    Serve(serve::ServeArgs),
    /// Describe a 3DGS file.
    Inspect(inspect::InspectArgs),
    /// Stage 1: lift 2-D feature maps of the training views into per-Gaussian features.
    Uplift(uplift::UpliftArgs),
    /// Benchmarks (JSON lines): runs `splatphys-bench` with the same arguments
    /// (`splatphys bench --help` lists them).
    #[command(disable_help_flag = true)]
    Bench {
        /// The benchmark and its arguments, e.g. `mpm --threads 2`.
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        args: Vec<std::ffi::OsString>,
    },
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Run(args) => run::run(&args),
        Command::Serve(args) => serve::run(&args),
        Command::Inspect(args) => inspect::run(&args),
        Command::Bench { args } => bench(&args),
        Command::Uplift(args) => uplift::run(&args),
    }
}

/// `splatphys bench ARGS`: runs the `splatphys-bench` binary beside this one with `ARGS` and
/// exits as it does (the benchmarks, their plotting and the rapier reference live there).
fn bench(args: &[std::ffi::OsString]) -> Result<()> {
    let me = std::env::current_exe().context("locating the splatphys executable")?;
    let bin = me.with_file_name("splatphys-bench");
    if !bin.exists() {
        bail!(
            "{} not found: build it with `cargo build --release -p splatphys-bench` (or the whole \
             workspace)",
            bin.display()
        );
    }
    let status = std::process::Command::new(&bin)
        .args(args)
        .status()
        .with_context(|| format!("running {}", bin.display()))?;
    if !status.success() {
        std::process::exit(status.code().unwrap_or(1));
    }
    Ok(())
}
