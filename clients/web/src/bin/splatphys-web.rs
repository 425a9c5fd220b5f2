//! `splatphys-web`: a live browser viewer for a running splatphys server.

use std::net::IpAddr;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use anyhow::{Result, bail};
use clap::Parser;
use splatphys_web::{CameraJson, WebConfig, serve};

/// Watch a running splatphys server live in the browser, and push it.
///
/// Serves a page (WebGL2 Gaussian splatting, orbit camera, object picking, impulses, material
/// edits, pause/step/reset) and a WebSocket on localhost; open the printed URL.
///
/// Examples:
///   splatphys serve scenes/donut_drop.toml --prefix splatphys/donut &
///   splatphys-web --prefix splatphys/donut
///   splatphys-web --prefix splatphys/donut --host 0.0.0.0 --token s3cret   (other machines)
#[derive(Parser, Debug)]
#[command(version, verbatim_doc_comment)]
struct Cli {
    /// Service prefix of the server (`splatphys serve --prefix`).
    #[arg(long)]
    prefix: String,
    /// Address to listen on. Anything but loopback exposes the viewer to the network: it is
    /// then read-only unless --token is given.
    #[arg(long, default_value = "127.0.0.1")]
    host: IpAddr,
    /// Port (0 = any free one).
    #[arg(long, default_value_t = 8765)]
    port: u16,
    /// Pages must open the URL with this token (printed in the URL); they can then send
    /// commands.
    #[arg(long)]
    token: Option<String>,
    /// Camera position, metres "x,y,z" (with --look-at; default: the page frames the scene).
    #[arg(long, value_parser = vec3, requires = "look_at")]
    camera_pos: Option<[f32; 3]>,
    /// Point the camera looks at, metres "x,y,z".
    #[arg(long, value_parser = vec3, requires = "camera_pos")]
    look_at: Option<[f32; 3]>,
    /// Camera up direction "x,y,z".
    #[arg(long, value_parser = vec3, default_value = "0,0,1")]
    up: [f32; 3],
    /// Vertical field of view, degrees.
    #[arg(long, default_value_t = 50.0)]
    fov_deg: f32,
    /// Image width, pixels.
    #[arg(long, default_value_t = 640)]
    width: u32,
    /// Image height, pixels.
    #[arg(long, default_value_t = 480)]
    height: u32,
}

fn vec3(s: &str) -> Result<[f32; 3], String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|x| x.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("{s:?} is not x,y,z: {e}"))?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([*x, *y, *z]),
        _ => Err(format!("{s:?} is not three finite numbers x,y,z")),
    }
}

fn main() -> Result<()> {
    let cli = Cli::parse();
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
        eprintln!(
            "splatphys-web: showing `{}` at {} (Ctrl-C to stop)",
            url_cfg.prefix,
            url_cfg.url(addr)
        );
    })?;
    eprintln!("splatphys-web: stopped; {}", stats.summary());
    Ok(())
}
