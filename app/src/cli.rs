//! The `splatphys` command line: the clap definition of every subcommand, in the library so
//! tests parse the commands the docs show and `docs/reference/cli/` is generated from it.

use clap::{Parser, Subcommand};

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
  splatphys select scenes/donut_drop.toml --out out/selection  # objects as PLY + masks
  splatphys align capture.ply --out aligned.ply              # level a capture: z up
  splatphys inspect ../shared/data/v3dg_donut.ply
  splatphys uplift --ply scene.ply --cameras transforms.json --features feats/ --out scene_feat.ply
  splatphys bench mpm --particles-per-axis 40 --grid 64 --steps 200 --threads 2
  splatphys bench mpm --vs-taichi                         # the same problem in Taichi, same run
  splatphys bench ipc --sizes 1000,10000,100000,1000000 --out-dir docs/results/bench
  splatphys bench stability --out-dir docs/results/bench"
)]
pub struct Cli {
    #[command(subcommand)]
    /// The subcommand.
    pub command: Command,
}

/// The subcommands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// The main job: server, recorder and renderer processes on a scene.
    Run(crate::run::RunArgs),
    /// Serve a scene over iceoryx2 shared memory; clients attach and detach freely.
    Serve(crate::serve::ServeArgs),
    /// Write which Gaussians form which object (PLY with object ids, a mask per object), without
    /// simulating.
    Select(crate::select::SelectArgs),
    /// Find the rotation that puts a capture's ground down (the scene keys that level it).
    Align(crate::align::AlignArgs),
    /// Describe a 3DGS file.
    Inspect(crate::inspect::InspectArgs),
    /// Stage 1: lift 2-D feature maps of the training views into per-Gaussian features.
    Uplift(crate::uplift::UpliftArgs),
    /// Benchmarks (JSON lines): runs `splatphys-bench` with the same arguments
    /// (`splatphys bench --help` lists them).
    #[command(disable_help_flag = true)]
    Bench {
        /// The benchmark and its arguments, e.g. `mpm --threads 2`.
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        args: Vec<std::ffi::OsString>,
    },
}
