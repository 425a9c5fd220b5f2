//! `splatphys-probe`: a minimal client that subscribes to a server and counts what it gets.
//!
//! Used by the multi-process tests and handy for checking a server by hand. Prints one JSON
//! line when it stops: frames received, first and last frame index, gaps in the frame index
//! (frames it never saw), commands sent and accepted, and the exit reason. Exit status: 0 after
//! a clean server shutdown or `--frames` frames, 2 when the server is gone (no heartbeat for
//! 1 s), 1 on other errors.
//!
//! Load options: `--stall-ms` with `--stall-probability` stalls after a frame at random (a
//! seeded SplitMix64 stream, so a run is reproducible with `--seed`), like a recorder whose disk
//! hiccups; `--commands-hz` makes it a controller that sends impulses at that rate (stopping
//! after `--replies` replies if given).

use std::time::{Duration, Instant};

use anyhow::Result;
use clap::Parser;
use splatphys_ipc::IpcError;
use splatphys_ipc::client::{ClientOptions, Connection, PendingCommand};
use splatphys_ipc::command::{Command, Reply};
use splatphys_probe::Cli as Args;

/// SplitMix64 (Steele et al. 2014): a tiny seeded generator, enough to place stalls.
struct SplitMix64(u64);

impl SplitMix64 {
    /// Uniform in [0, 1).
    fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Commands sent at a fixed rate and their replies.
#[derive(Default)]
struct Controller {
    sent: u64,
    accepted: u64,
    rejected: u64,
    send_errors: u64,
    pending: Vec<PendingCommand>,
}

impl Controller {
    /// Sends what is due at `hz` after `elapsed`, then collects the replies that arrived.
    fn tick(&mut self, conn: &mut Connection, hz: f64, object: u32, elapsed: Duration) {
        let due = (elapsed.as_secs_f64() * hz) as u64;
        let cmd = Command::Impulse {
            object,
            impulse_n_s: [0.0, 0.0, 1e-6],
            point_m: None,
        };
        while self.sent + self.send_errors < due {
            match conn.send_command(&cmd) {
                Ok((_, p)) => {
                    self.sent += 1;
                    self.pending.push(p);
                }
                Err(_) => self.send_errors += 1,
            }
        }
        self.pending.retain(|p| match conn.poll_reply(p) {
            Ok(Some(Reply::Accepted { .. })) => {
                self.accepted += 1;
                false
            }
            Ok(Some(Reply::Rejected { .. })) => {
                self.rejected += 1;
                false
            }
            Ok(None) | Err(_) => true,
        });
    }
}

fn main() -> Result<()> {
    let args = Args::parse();
    let mut opts = ClientOptions::new(&args.prefix);
    opts.node_name = "splatphys-probe".into();
    opts.connect_timeout = Duration::from_millis(args.connect_timeout_ms);
    opts.commands = args.commands_hz > 0.0;
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
    let mut stalls = (SplitMix64(args.seed), 0u64);
    let mut control = Controller::default();
    let wait = if args.commands_hz > 0.0 {
        Duration::from_secs_f64((1.0 / args.commands_hz).min(0.05))
    } else {
        Duration::from_millis(50)
    };
    let started = Instant::now();
    let outcome: Result<(), IpcError> = loop {
        if let Ok(Some(scene)) = conn.recv_scene() {
            scene_gaussians = Some(scene.payload().len());
        }
        if args.commands_hz > 0.0 {
            control.tick(&mut conn, args.commands_hz, args.object, started.elapsed());
            if args
                .replies
                .is_some_and(|n| control.accepted + control.rejected >= n)
            {
                break Ok(());
            }
        }
        // Objects go out right after their frame; take them like a recorder would.
        while let Ok(Some(_)) = conn.recv_objects() {}
        match conn.wait_frame(wait) {
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
                if args.stall_ms > 0 && stalls.0.next_f64() < args.stall_probability {
                    stalls.1 += 1;
                    std::thread::sleep(Duration::from_millis(args.stall_ms));
                }
            }
            Ok(None) => {}
            Err(e) => break Err(e),
        }
    };
    let (code, reason) = match &outcome {
        Ok(()) if args.replies.is_some() => (0, "replies".to_owned()),
        Ok(()) => (0, "frames".to_owned()),
        Err(IpcError::ServerShutDown { .. }) => (0, "shutdown".to_owned()),
        Err(e @ IpcError::ServerGone { .. }) => (2, e.to_string()),
        Err(e) => (1, e.to_string()),
    };
    println!(
        "{{\"frames\":{frames},\"first\":{},\"last\":{last},\"gaps\":{gaps},\"scene_gaussians\":{},\"stalls\":{},\"commands_sent\":{},\"commands_accepted\":{},\"commands_rejected\":{},\"elapsed_s\":{:.3},\"reason\":{reason:?}}}",
        first.map_or(-1, |f| f as i64),
        scene_gaussians.map_or(-1, |n| n as i64),
        stalls.1,
        control.sent,
        control.accepted,
        control.rejected,
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
