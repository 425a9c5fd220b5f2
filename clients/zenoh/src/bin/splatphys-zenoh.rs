//! `splatphys-zenoh`: the bridge (see the library).

use std::time::Duration;

use anyhow::{Result, bail};
use clap::Parser;
use splatphys_zenoh::bridge::{BridgeEnd, BridgeOptions, run};
use splatphys_zenoh::cli::Cli;

fn main() -> Result<()> {
    let cli = Cli::parse();
    let seconds = |s: f64, flag: &str| -> Result<Duration> {
        if !(s.is_finite() && s >= 0.0) {
            bail!("{flag} must be a number of seconds >= 0");
        }
        Ok(Duration::from_secs_f64(s))
    };
    let opts = BridgeOptions {
        prefix: cli.prefix,
        key: cli.key,
        allow_commands: cli.allow_commands,
        listen: cli.listen,
        connect: cli.connect,
        config: cli.config,
        connect_timeout: seconds(cli.connect_timeout_s, "--connect-timeout-s")?,
        command_timeout: seconds(cli.command_timeout_s, "--command-timeout-s")?,
    };
    eprintln!(
        "splatphys-zenoh: bridging {} (commands {})",
        opts.prefix,
        if opts.allow_commands {
            "allowed"
        } else {
            "refused"
        }
    );
    match run(&opts)? {
        BridgeEnd::ServerShutDown => eprintln!("splatphys-zenoh: the server shut down"),
        BridgeEnd::Interrupted => eprintln!("splatphys-zenoh: stopped (signal)"),
    }
    Ok(())
}
