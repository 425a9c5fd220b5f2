//! `splatphys`: the main job, the server, inspection and benchmarks.

use anyhow::{Context, Result, bail};
use clap::Parser;
use splatphys::cli::{Cli, Command};
use splatphys::{align, inspect, run, select, serve, uplift};

fn main() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Run(args) => run::run(&args),
        Command::Serve(args) => serve::run(&args),
        Command::Select(args) => select::run(&args),
        Command::Align(args) => align::run(&args),
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
