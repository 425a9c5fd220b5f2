//! `splatphys-probe`: a minimal client that subscribes to a server and counts what it gets.
//!
//! Used by the multi-process tests and handy for checking a server by hand. Prints one JSON
//! line when it stops: frames received, first and last frame index, gaps in the frame index
//! (frames it never saw) and the exit reason. Exit status: 0 after a clean server shutdown or
//! `--frames` frames, 2 when the server is gone (no heartbeat for 1 s), 1 on other errors.

use std::time::{Duration, Instant};

use anyhow::Result;
use clap::Parser;
use splatphys_ipc::IpcError;
use splatphys_ipc::client::{ClientOptions, Connection};

/// Subscribe to a splatphys server and count frames.
#[derive(Parser, Debug)]
struct Args {
    /// Service prefix of the server.
    prefix: String,
    /// Ask for lossless delivery (like a recorder).
    #[arg(long)]
    lossless: bool,
    /// Stop after this many frames.
    #[arg(long)]
    frames: Option<u64>,
    /// Sleep this long after every frame, milliseconds (simulates a slow client).
    #[arg(long, default_value_t = 0)]
    delay_ms: u64,
    /// Connect timeout, milliseconds.
    #[arg(long, default_value_t = 5000)]
    connect_timeout_ms: u64,
}

fn main() -> Result<()> {
    let args = Args::parse();
    let mut opts = ClientOptions::new(&args.prefix);
    opts.node_name = "splatphys-probe".into();
    opts.connect_timeout = Duration::from_millis(args.connect_timeout_ms);
    opts.commands = false;
    if args.lossless {
        opts = opts.lossless();
    }
    let mut conn = match Connection::connect(&opts) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("splatphys-probe: {e}");
            std::process::exit(1);
        }
    };
    let (mut frames, mut first, mut last, mut gaps) = (0u64, None::<u64>, 0u64, 0u64);
    let mut scene_gaussians = None;
    let started = Instant::now();
    let outcome: Result<(), IpcError> = loop {
        if let Ok(Some(scene)) = conn.recv_scene() {
            scene_gaussians = Some(scene.payload().len());
        }
        match conn.wait_frame(Duration::from_millis(50)) {
            Ok(Some(f)) => {
                let i = f.user_header().frame_index;
                if let Some(_f0) = first {
                    gaps += i.saturating_sub(last + 1);
                } else {
                    first = Some(i);
                }
                last = i;
                frames += 1;
                drop(f);
                if frames == 1 {
                    println!("{{\"event\":\"first_frame\",\"frame_index\":{i}}}");
                }
                if args.frames.is_some_and(|n| frames >= n) {
                    break Ok(());
                }
                if args.delay_ms > 0 {
                    std::thread::sleep(Duration::from_millis(args.delay_ms));
                }
            }
            Ok(None) => {}
            Err(e) => break Err(e),
        }
    };
    let (code, reason) = match &outcome {
        Ok(()) => (0, "frames".to_owned()),
        Err(IpcError::ServerShutDown { .. }) => (0, "shutdown".to_owned()),
        Err(e @ IpcError::ServerGone { .. }) => (2, e.to_string()),
        Err(e) => (1, e.to_string()),
    };
    println!(
        "{{\"frames\":{frames},\"first\":{},\"last\":{last},\"gaps\":{gaps},\"scene_gaussians\":{},\"elapsed_s\":{:.3},\"reason\":{reason:?}}}",
        first.map_or(-1, |f| f as i64),
        scene_gaussians.map_or(-1, |n| n as i64),
        started.elapsed().as_secs_f64()
    );
    drop(conn);
    if code == 2 {
        // The dead server's resources can only go once nobody holds its services.
        let _ = splatphys_ipc::services::cleanup_dead_nodes();
    }
    if code != 0 {
        eprintln!("splatphys-probe: {reason}");
    }
    std::process::exit(code);
}
