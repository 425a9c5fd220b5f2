//! The `splatphys-record` command line (clap), in the library so tests parse the commands the
//! docs show and `docs/reference/cli/` is generated from it.

use std::path::PathBuf;

use clap::{Parser, Subcommand};

/// Record, replay and export splatphys runs (MCAP).
#[derive(Parser, Debug)]
#[command(version, about)]
pub struct Cli {
    /// The subcommand.
    #[command(subcommand)]
    pub command: Cmd,
}

/// The subcommands.
#[derive(Subcommand, Debug)]
pub enum Cmd {
    /// Record a live server losslessly until it shuts down (or Ctrl-C).
    Record {
        /// Service prefix of the server (e.g. `splatphys/<scene>`).
        #[arg(long)]
        prefix: String,
        /// Output MCAP file.
        #[arg(long, short)]
        out: PathBuf,
        /// Use lz4 instead of zstd.
        #[arg(long)]
        lz4: bool,
        /// Stop after this many frames.
        #[arg(long)]
        frames: Option<u64>,
        /// Write a /pointcloud every N frames (0 = never).
        #[arg(long, default_value_t = 1)]
        pointcloud_every: u64,
        /// Seconds to wait for the server.
        #[arg(long, default_value_t = 5.0)]
        connect_timeout_s: f64,
        /// Target size of an MCAP chunk (uncompressed), MiB. The recorder keeps one index entry
        /// (about 300 B) per chunk in memory until the file is finished, for the file's summary:
        /// larger chunks mean fewer entries. A chunk is also closed every second, so a killed
        /// recorder loses at most that.
        #[arg(long, default_value_t = 4)]
        chunk_mb: u64,
    },
    /// Publish a recording back onto the services.
    Replay {
        /// The MCAP file.
        file: PathBuf,
        /// Service prefix to publish under.
        #[arg(long, default_value = "splatphys/replay")]
        prefix: String,
        /// As fast as possible instead of the recorded timing.
        #[arg(long)]
        fast: bool,
        /// Publish nothing before this many clients subscribed (frames keep no history).
        #[arg(long, default_value_t = 0)]
        wait_for_subscribers: usize,
        /// Longest wait for those clients, seconds; the replay then starts anyway.
        #[arg(long, default_value_t = 10.0)]
        wait_timeout_s: f64,
        /// Longest wait on a lagging lossless subscriber (recorder) per message, milliseconds.
        #[arg(long, default_value_t = 2000)]
        lossless_limit_ms: u64,
        /// Replay a truncated or corrupt file (a killed recorder) up to the damage instead of
        /// refusing it.
        #[arg(long)]
        recover: bool,
    },
    /// Export chosen frames as 3DGS files (INRIA PLY, SPZ) that a splat viewer opens.
    ///
    /// Each frame's Gaussians in world metres (z up): centres, scales and rotations from the
    /// simulated covariance, SH colours turned with the material, opacity and, in PLY, each
    /// Gaussian's `object_id` (-1 for the captured background). Files are
    /// `OUT/frame_<index>.<ext>`.
    #[command(after_help = "Examples:
  splatphys-record export out/donut/recording.mcap --out out/donut/ply --every 10
  splatphys-record export run.mcap --out frames --steps 100..200 --format ply --format spz")]
    Export {
        /// The MCAP file.
        file: PathBuf,
        /// Output folder (created; existing files of the same names are overwritten).
        #[arg(long, short)]
        out: PathBuf,
        /// Export one frame in N (frame index divisible by N).
        #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..))]
        every: u64,
        /// Only frames whose step lies in A..B (B excluded), A.., ..B, or the one step A.
        #[arg(long, value_parser = crate::export::parse_steps)]
        steps: Option<std::ops::Range<u64>>,
        /// File format; repeat for several.
        #[arg(long = "format", value_enum, default_values_t = [crate::export::ExportFormat::Ply])]
        formats: Vec<crate::export::ExportFormat>,
        /// Read a truncated or corrupt file up to the damage instead of refusing it.
        #[arg(long)]
        recover: bool,
    },
    /// Export the objects of every frame as CSV.
    ExportObjects {
        /// The MCAP file.
        file: PathBuf,
        /// Output CSV (stdout if absent).
        #[arg(long, short)]
        out: Option<PathBuf>,
        /// Read a truncated or corrupt file up to the damage instead of refusing it.
        #[arg(long)]
        recover: bool,
    },
}
