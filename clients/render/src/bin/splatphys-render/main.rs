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
use clap::Parser;
use splatphys_render::cli::{Cli, Command};

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
