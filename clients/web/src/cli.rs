//! The `splatphys-web` command line (clap), in the library so tests parse the commands the docs
//! show and `docs/reference/cli/` is generated from it.

use std::net::IpAddr;

use clap::Parser;

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
pub struct Cli {
    /// Service prefix of the server (`splatphys serve --prefix`).
    #[arg(long)]
    pub prefix: String,
    /// Address to listen on. Anything but loopback exposes the viewer to the network: it is
    /// then read-only unless --token is given.
    #[arg(long, default_value = "127.0.0.1")]
    pub host: IpAddr,
    /// Port (0 = any free one).
    #[arg(long, default_value_t = 8765)]
    pub port: u16,
    /// Pages must open the URL with this token (printed in the URL); they can then send
    /// commands.
    #[arg(long)]
    pub token: Option<String>,
    /// Camera position, metres "x,y,z" (with --look-at; default: the page frames the scene).
    #[arg(long, value_parser = vec3, requires = "look_at")]
    pub camera_pos: Option<[f32; 3]>,
    /// Point the camera looks at, metres "x,y,z".
    #[arg(long, value_parser = vec3, requires = "camera_pos")]
    pub look_at: Option<[f32; 3]>,
    /// Camera up direction "x,y,z".
    #[arg(long, value_parser = vec3, default_value = "0,0,1")]
    pub up: [f32; 3],
    /// Vertical field of view, degrees.
    #[arg(long, default_value_t = 50.0)]
    pub fov_deg: f32,
    /// Image width, pixels.
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    /// Image height, pixels.
    #[arg(long, default_value_t = 480)]
    pub height: u32,
    /// End when process PID ends (`splatphys serve --view` passes its own: a viewer whose server
    /// was killed would otherwise wait for it for ever). Linux only.
    #[arg(long, value_name = "PID", hide = true)]
    pub exit_with_parent: Option<u32>,
}

/// Parses `x,y,z` (clap value parser).
pub fn vec3(s: &str) -> Result<[f32; 3], String> {
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
