//! `splatphys-probe`'s command line (clap), in a library so tests parse the commands the docs
//! show and `docs/reference/cli/` is generated from it. The binary (`src/main.rs`) does the work.

use clap::Parser;

/// Subscribe to a splatphys server and count frames.
#[derive(Parser, Debug)]
#[command(name = "splatphys-probe", version)]
pub struct Cli {
    /// Service prefix of the server.
    pub prefix: String,
    /// Ask for lossless delivery (like a recorder).
    #[arg(long)]
    pub lossless: bool,
    /// Stop after this many frames.
    #[arg(long)]
    pub frames: Option<u64>,
    /// Sleep this long after every frame, milliseconds (simulates a slow client).
    #[arg(long, default_value_t = 0)]
    pub delay_ms: u64,
    /// Connect timeout, milliseconds.
    #[arg(long, default_value_t = 5000)]
    pub connect_timeout_ms: u64,
    /// Length of a random stall after a frame, milliseconds.
    #[arg(long, default_value_t = 0)]
    pub stall_ms: u64,
    /// Probability of a stall after each frame, 0..=1.
    #[arg(long, default_value_t = 0.0)]
    pub stall_probability: f64,
    /// Seed of the stall sequence.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Send impulse commands (1e-6 N·s up, to `--object`) at this rate, per second.
    #[arg(long, default_value_t = 0.0)]
    pub commands_hz: f64,
    /// Object the commands push.
    #[arg(long, default_value_t = 0)]
    pub object: u32,
    /// Stop after this many command replies.
    #[arg(long)]
    pub replies: Option<u64>,
}
