//! `splatphys-bench`: the benchmarks and experiments (JSON lines, charts, CSV). `splatphys bench`
//! runs this binary; the `splatphys` command itself links no benchmark code.

use anyhow::Result;
use clap::Parser;
use splatphys_bench::cli::Cli;

fn main() -> Result<()> {
    splatphys_bench::run(&Cli::parse().command, splatphys::world_sim::boxed)
}
