//! The `splatphys-bench` command line (clap), in the library so tests parse the commands the docs
//! show and `docs/reference/cli/` is generated from it.

use clap::Parser;

use crate::BenchCommand;

/// splatphys benchmarks: MPM throughput, IPC, the COM method against its baselines, stability,
/// subsets, real time, contact against rapier, soak. Each prints JSON lines; most write charts
/// and CSV to --out-dir.
#[derive(Parser, Debug)]
#[command(
    version,
    about,
    after_help = "Examples:
  splatphys-bench mpm --particles-per-axis 40 --grid 64 --steps 200 --threads 2
  splatphys-bench mpm --vs-taichi                      # the same problem in Taichi, same run
  splatphys-bench ipc --sizes 1000,10000,100000,1000000 --out-dir docs/results/bench
  splatphys-bench stability --out-dir docs/results/bench
  splatphys-bench soak --minutes 30                    # also `splatphys bench soak --minutes 30`"
)]
pub struct Cli {
    /// The benchmark.
    #[command(subcommand)]
    pub command: BenchCommand,
}
