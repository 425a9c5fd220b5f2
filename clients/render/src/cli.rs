//! The `splatphys-render` command line (clap), in the library so tests parse the commands the
//! docs show and `docs/reference/cli/` is generated from it. The binary does the work.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};
use glam::Vec3;

/// The `splatphys-render` command line.
#[derive(Parser)]
#[command(
    name = "splatphys-render",
    version,
    about = "Render 3D Gaussian Splatting scenes and splatphys runs on the CPU"
)]
pub struct Cli {
    /// Worker threads (default: all cores).
    #[arg(long, global = true)]
    pub threads: Option<usize>,
    /// The subcommand.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Subcommand)]
pub enum Command {
    /// Render one frame of a 3DGS file (INRIA PLY, compressed PLY or .splat) to PNG.
    Image {
        /// The 3DGS file.
        scene: PathBuf,
        /// Output PNG.
        #[arg(long, short)]
        out: PathBuf,
        /// Camera and image flags.
        #[command(flatten)]
        view: ViewArgs,
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
        /// Camera and image flags.
        #[command(flatten)]
        view: ViewArgs,
    },
    /// Subscribe to a running server and render the newest frame each time (PNGs, GIF, MP4).
    Live(LiveArgs),
    /// Render every frame of an MCAP recording (PNGs, GIF, MP4).
    Mcap(McapArgs),
}

/// Parses `x,y,z` into a finite vector.
pub fn parse_vec3(s: &str) -> Result<Vec3, String> {
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

/// Camera and image flags of `image` and `orbit`.
#[derive(Args)]
pub struct ViewArgs {
    /// Image width, px.
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    /// Image height, px.
    #[arg(long, default_value_t = 480)]
    pub height: u32,
    /// Vertical field of view, degrees.
    #[arg(long, default_value_t = 50.0)]
    pub fov_deg: f32,
    /// Up direction `x,y,z` (z up in the world; PlayCanvas captures are y-down: use 0,-1,0).
    #[arg(long, default_value = "0,0,1", value_parser = parse_vec3)]
    pub up: Vec3,
    /// Camera azimuth about `--up` for automatic framing, degrees (first orbit frame).
    #[arg(long, default_value_t = 30.0)]
    pub azimuth_deg: f32,
    /// Camera elevation above the plane normal to `--up` for automatic framing, degrees.
    #[arg(long, default_value_t = 20.0)]
    pub elevation_deg: f32,
    /// Camera distance from the look-at point, m (default: the whole scene in view).
    #[arg(long)]
    pub distance_m: Option<f32>,
    /// Explicit camera position `x,y,z`, m (overrides automatic framing in `image`).
    #[arg(long, value_parser = parse_vec3)]
    pub eye: Option<Vec3>,
    /// Look-at point `x,y,z`, m (default: the centre of the trimmed bounds).
    #[arg(long, value_parser = parse_vec3)]
    pub look_at: Option<Vec3>,
    /// Fraction of Gaussians ignored at each end of each axis when framing (0 to 0.49).
    #[arg(long, default_value_t = 0.01)]
    pub trim: f32,
    /// Near plane, m (default: 0.2 m, less when the camera is closer to the scene).
    #[arg(long)]
    pub near_m: Option<f32>,
    /// Background colour `r,g,b` in [0, 1].
    #[arg(long, default_value = "0,0,0", value_parser = parse_vec3)]
    pub background: Vec3,
    /// Highest SH degree evaluated.
    #[arg(long, default_value_t = 3)]
    pub sh_degree: u8,
}

/// Output, camera and selection flags shared by `live` and `mcap`.
#[derive(Args, Debug, Clone)]
pub struct SequenceArgs {
    /// Output folder (created): frame_{step:05}.png for each rendered frame, the GIF and MP4.
    #[arg(long)]
    pub out_dir: PathBuf,
    /// Animated GIF of the rendered frames (default: OUT_DIR/animation.gif).
    #[arg(long)]
    pub gif: Option<PathBuf>,
    /// MP4 of the rendered frames, written when ffmpeg is on PATH (default: OUT_DIR/animation.mp4).
    #[arg(long)]
    pub mp4: Option<PathBuf>,
    /// Animation frame rate, frames/s.
    #[arg(long, default_value_t = 25.0)]
    pub fps: f32,
    /// Most frames put into the GIF and MP4 (evenly subsampled beyond; every PNG is kept).
    #[arg(long, default_value_t = 300)]
    pub max_animation_frames: usize,
    /// Camera position `x,y,z`, m (default: framed automatically from the first frame, looking
    /// from direction (1,-1,0.6) towards the centre of its trimmed bounds).
    #[arg(long, value_parser = parse_vec3)]
    pub camera_pos: Option<Vec3>,
    /// Look-at point `x,y,z`, m (default: the centre of the first frame's trimmed bounds).
    #[arg(long, value_parser = parse_vec3)]
    pub look_at: Option<Vec3>,
    /// Up direction `x,y,z`.
    #[arg(long, default_value = "0,0,1", value_parser = parse_vec3)]
    pub up: Vec3,
    /// Vertical field of view, degrees.
    #[arg(long, default_value_t = 50.0)]
    pub fov_deg: f32,
    /// Image width, px.
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    /// Image height, px.
    #[arg(long, default_value_t = 480)]
    pub height: u32,
    /// Render at most one frame in N published frames (frame indices at least N apart).
    #[arg(long, default_value_t = 1)]
    pub every: u64,
    /// Background colour `r,g,b` in [0, 1].
    #[arg(long, default_value = "0,0,0", value_parser = parse_vec3)]
    pub background: Vec3,
    /// Highest SH degree evaluated (0 to 3).
    #[arg(long, default_value_t = 3)]
    pub sh_degree: u8,
}

/// Arguments of `live`.
#[derive(Args, Debug, Clone)]
pub struct LiveArgs {
    /// Service prefix of the server (as given to `splatphys serve --prefix`).
    #[arg(long)]
    pub prefix: String,
    /// How long to wait for the server to appear, seconds.
    #[arg(long, default_value_t = 10.0)]
    pub timeout_s: f64,
    /// Output, camera and selection flags.
    #[command(flatten)]
    pub seq: SequenceArgs,
}

/// Arguments of `mcap`.
#[derive(Args, Debug, Clone)]
pub struct McapArgs {
    /// The recording (`splatphys-record record --out RUN.mcap`).
    pub recording: PathBuf,
    /// Output, camera and selection flags.
    #[command(flatten)]
    pub seq: SequenceArgs,
}
