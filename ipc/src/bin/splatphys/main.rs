//! `splatphys`: the main job, the server, inspection and benchmarks.

use anyhow::Result;
use clap::{Parser, Subcommand};

mod serve;

/// splatphys: captured 3D Gaussian Splatting scenes made physical.
#[derive(Parser, Debug)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Serve a scene over iceoryx2 shared memory; clients attach and detach freely.
    Serve(serve::ServeArgs),
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Serve(args) => serve::run(&args),
    }
}
