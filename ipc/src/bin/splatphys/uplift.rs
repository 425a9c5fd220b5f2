//! `splatphys uplift`: stage 1's feature uplift. The uplift reuses the renderer's rasterizer,
//! which depends on this crate, so it lives in its own crate (`stage1/`, executable
//! `splatphys-uplift`) and this subcommand runs that executable beside this one with the same
//! arguments and exit status.

use std::process::Command;

use anyhow::{Context, Result};
use clap::Args;

/// Everything after `uplift`, passed on unchanged (`--help` included).
#[derive(Args, Debug)]
#[command(disable_help_flag = true)]
pub struct UpliftArgs {
    /// Arguments of splatphys-uplift (see `splatphys uplift --help`).
    #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
    pub args: Vec<String>,
}

/// Runs `splatphys-uplift` with `args.args`; exits with its status when it fails.
pub fn run(args: &UpliftArgs) -> Result<()> {
    let bin = crate::run::sibling("splatphys-uplift")?;
    let status = Command::new(&bin)
        .args(&args.args)
        .status()
        .with_context(|| format!("starting {}", bin.display()))?;
    if !status.success() {
        std::process::exit(status.code().unwrap_or(1));
    }
    Ok(())
}
