//! `splatphys-zenoh`: the bridge (see the library).

use std::time::Duration;

use anyhow::{Result, bail};
use clap::Parser;
use splatphys_zenoh::bridge::{BridgeEnd, BridgeOptions, run};
use splatphys_zenoh::cli::Cli;
use splatphys_zenoh::ros2::Ros2Options;
use splatphys_zenoh::ros2::graph::is_ros_token;

fn main() -> Result<()> {
    let cli = Cli::parse();
    let seconds = |s: f64, flag: &str| -> Result<Duration> {
        if !(s.is_finite() && s >= 0.0) {
            bail!("{flag} must be a number of seconds >= 0");
        }
        Ok(Duration::from_secs_f64(s))
    };
    if cli.ros2 {
        let ns = cli.ros2_namespace.trim_end_matches('/');
        if !(ns.is_empty() || ns.starts_with('/') && ns[1..].split('/').all(is_ros_token)) {
            bail!(
                "--ros2-namespace {:?}: give an absolute ROS name such as /splatphys \
                 (letters, digits and _ between slashes, not starting with a digit)",
                cli.ros2_namespace
            );
        }
        if cli.ros2_frame.is_empty() {
            bail!("--ros2-frame is empty");
        }
    }
    let opts = BridgeOptions {
        prefix: cli.prefix,
        key: cli.key,
        allow_commands: cli.allow_commands,
        listen: cli.listen,
        connect: cli.connect,
        config: cli.config,
        connect_timeout: seconds(cli.connect_timeout_s, "--connect-timeout-s")?,
        command_timeout: seconds(cli.command_timeout_s, "--command-timeout-s")?,
        ros2: cli.ros2.then(|| Ros2Options {
            domain: cli.ros2_domain,
            namespace: cli.ros2_namespace,
            frame_id: cli.ros2_frame,
            ..Ros2Options::default()
        }),
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
