//! `splatphys-render`: renders 3DGS scenes and splatphys runs with the splatphys CPU rasterizer
//! (3DGS EWA splatting, Kerbl et al. 2023).
//!
//! ```text
//! splatphys-render image SCENE.ply --out frame.png [camera flags] [--repeat 20]
//! splatphys-render orbit SCENE.ply --out-dir DIR --frames 36 [--fps 12] [--mp4]
//! splatphys-render live --prefix P --out-dir DIR [sequence flags] [--timeout-s 10]
//! splatphys-render mcap RUN.mcap --out-dir DIR [sequence flags]
//! ```
//!
//! `image` and `orbit` ([`files`]) read a 3DGS file. `live` ([`live`]) subscribes to a running
//! `splatphys serve` and renders the newest frame each time; `mcap` ([`mcap`]) renders every
//! frame of a recording. Both write `DIR/frame_{step:05}.png`, an animated GIF (and an MP4 when
//! ffmpeg is installed) and print one JSON line on stdout:
//! `{"frames_rendered":N,"frames_dropped":M,"last_step":S,"seconds":T}` ([`sequence`]).

mod files;
mod live;
mod mcap;
mod sequence;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use glam::Vec3;
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "splatphys-render",
    version,
    about = "Render 3D Gaussian Splatting scenes and splatphys runs on the CPU"
)]
struct Cli {
    /// Worker threads (default: all cores).
    #[arg(long, global = true)]
    threads: Option<usize>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render one frame of a 3DGS file (INRIA PLY, compressed PLY or .splat) to PNG.
    Image {
        /// The 3DGS file.
        scene: PathBuf,
        /// Output PNG.
        #[arg(long, short)]
        out: PathBuf,
        #[command(flatten)]
        view: files::ViewArgs,
        /// Render this many times and report the median frame time.
        #[arg(long, default_value_t = 1)]
        repeat: usize,
    },
    /// Render an orbit around a 3DGS file: N PNGs, an animated GIF and, with ffmpeg, an MP4.
    Orbit {
        /// The 3DGS file.
        scene: PathBuf,
        /// Output folder (created): frame_0000.png ..., orbit.gif, orbit.mp4.
        #[arg(long)]
        out_dir: PathBuf,
        /// Number of frames in one turn.
        #[arg(long, default_value_t = 36)]
        frames: usize,
        /// Animation frame rate, frames/s.
        #[arg(long, default_value_t = 12.0)]
        fps: f32,
        /// Also write orbit.mp4 (needs ffmpeg on PATH; skipped with a note otherwise).
        #[arg(long)]
        mp4: bool,
        #[command(flatten)]
        view: files::ViewArgs,
    },
    /// Subscribe to a running server and render the newest frame each time (PNGs, GIF, MP4).
    Live(live::LiveArgs),
    /// Render every frame of an MCAP recording (PNGs, GIF, MP4).
    Mcap(mcap::McapArgs),
}

/// Parses `x,y,z` into a finite vector.
fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let parts: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("`{s}`: {e}; expected x,y,z"))?;
    match parts[..] {
        [x, y, z] if x.is_finite() && y.is_finite() && z.is_finite() => Ok(Vec3::new(x, y, z)),
        _ => Err(format!("`{s}`: expected three finite numbers x,y,z")),
    }
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    if let Some(threads) = cli.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build_global()
            .context("setting up the thread pool")?;
    }
    match cli.command {
        Command::Image {
            scene,
            out,
            view,
            repeat,
        } => files::image(&scene, &out, &view, repeat),
        Command::Orbit {
            scene,
            out_dir,
            frames,
            fps,
            mp4,
            view,
        } => files::orbit(&scene, &out_dir, frames, fps, mp4, &view),
        Command::Live(args) => live::live(&args),
        Command::Mcap(args) => mcap::mcap(&args),
    }
}
