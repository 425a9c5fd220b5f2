//! `splatphys-web`: a live browser viewer for a running splatphys server.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use anyhow::{Result, bail};
use clap::Parser;
use splatphys_web::cli::Cli;
use splatphys_web::{CameraJson, WebConfig, serve};

fn main() -> Result<()> {
    let cli = Cli::parse();
    if let Some(parent) = cli.exit_with_parent {
        follow_parent(parent);
    }
    if !(cli.fov_deg > 0.0 && cli.fov_deg < 180.0) {
        bail!("--fov-deg {} is not in (0, 180)", cli.fov_deg);
    }
    if cli.width == 0 || cli.height == 0 {
        bail!("--width and --height must be positive");
    }
    let camera = match (cli.camera_pos, cli.look_at) {
        (Some(position_m), Some(look_at_m)) => Some(CameraJson {
            position_m,
            look_at_m,
            up: cli.up,
            fov_y_deg: cli.fov_deg,
            width_px: cli.width,
            height_px: cli.height,
        }),
        _ => None,
    };
    if !cli.host.is_loopback() && cli.token.is_none() {
        eprintln!(
            "splatphys-web: listening on {} without --token: the viewer is read-only",
            cli.host
        );
    }
    let cfg = WebConfig {
        prefix: cli.prefix.clone(),
        host: cli.host,
        port: cli.port,
        token: cli.token,
        camera,
    };
    let url_cfg = cfg.clone();
    let stop = Arc::new(AtomicBool::new(false));
    let stats = serve(cfg, stop, |addr| {
        // The one line on stdout: scripts and `splatphys run --view` read the URL from it.
        println!("{}", url_cfg.url(addr));
        // One write: a parent that shares this stream cannot split the line.
        let line = format!(
            "splatphys-web: showing `{}` at {} (Ctrl-C to stop)\n",
            url_cfg.prefix,
            url_cfg.url(addr)
        );
        let _ = std::io::Write::write_all(&mut std::io::stderr().lock(), line.as_bytes());
    })?;
    eprintln!("splatphys-web: stopped; {}", stats.summary());
    Ok(())
}

/// Asks the kernel for SIGTERM when the parent ends (the viewer then stops as on any SIGTERM),
/// and ends now if `parent` has already gone (it died before the request took effect).
#[cfg(target_os = "linux")]
fn follow_parent(parent: u32) {
    use rustix::process::{Signal, getppid, set_parent_process_death_signal};
    if let Err(e) = set_parent_process_death_signal(Some(Signal::TERM)) {
        eprintln!("splatphys-web: cannot follow the parent process: {e}");
        return;
    }
    if getppid().map(|p| p.as_raw_nonzero().get() as u32) != Some(parent) {
        eprintln!("splatphys-web: process {parent} has already ended");
        std::process::exit(0);
    }
}

/// Elsewhere the viewer outlives a killed parent (it is stopped with it on a clean exit).
#[cfg(not(target_os = "linux"))]
fn follow_parent(_parent: u32) {}
