//! `splatphys bench ipc-peer` (hidden): the far side of `bench ipc`, in its own process.
//!
//! - `--role iox`: subscribes to the `frame` service (the real service from
//!   `splatphys_ipc::services`), busy-polls it, and for every frame computes the latency from the
//!   publisher's timestamp (carried in [`FrameHeader::time_s`], seconds after `--epoch-ns`) to
//!   the moment it holds the sample and has read its last Gaussian.
//! - `--role socket`: connects to the Unix socket at `--socket`, reads an 8-byte f64 send
//!   timestamp then `--bytes` payload bytes per sample (the copy), and answers one byte so the
//!   writer starts the next sample on an idle reader.
//! - `--role flood`: connects as a controller and sends `--hz` impulse commands per second until
//!   the server shuts down, counting replies.
//!
//! Both sides read the wall clock (`CLOCK_REALTIME`, one clock for all processes of a host)
//! relative to `--epoch-ns`, so latencies stay in f64 seconds with sub-nanosecond resolution.
//! Every role prints one JSON line on stdout when it ends; [`Peer`] starts one and reads it.

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::path::PathBuf;
use std::process::{Command as Process, Stdio};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::{Context, Result, bail, ensure};
use clap::{Args, ValueEnum};
use serde_json::{Value, json};
use splatphys_ipc::IpcError;
use splatphys_ipc::client::{ClientOptions, Connection};
use splatphys_ipc::command::{Command, Reply};
use splatphys_ipc::services::{MAX_FRAME_BUFFER, Role, ServiceNames, create_node, frame_service};
#[cfg(doc)]
use splatphys_ipc::wire::FrameHeader;

use crate::child::KillOnDrop;

/// Gives up when nothing arrives for this long (the parent died or failed).
const IDLE_TIMEOUT: Duration = Duration::from_secs(30);

/// Which far side to play.
#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum PeerRole {
    /// `frame` subscriber measuring latency.
    Iox,
    /// Unix socket reader measuring latency.
    Socket,
    /// Controller sending a command flood.
    Flood,
    /// Zenoh subscriber measuring latency and throughput ([`crate::ipc_zenoh`]).
    Zenoh,
}

/// Arguments of `bench ipc-peer`.
#[derive(Args, Debug)]
pub struct PeerArgs {
    /// The role.
    #[arg(long, value_enum)]
    pub role: PeerRole,
    /// Service prefix (iox, flood).
    #[arg(long, default_value = "")]
    pub prefix: String,
    /// Socket path (socket).
    #[arg(long)]
    pub socket: Option<PathBuf>,
    /// Payload bytes per sample (socket).
    #[arg(long, default_value_t = 0)]
    pub bytes: usize,
    /// Samples to receive, warm-up included (iox, socket).
    #[arg(long, default_value_t = 0)]
    pub samples: u64,
    /// Leading samples left out of the latencies (iox, socket).
    #[arg(long, default_value_t = 0)]
    pub warmup: u64,
    /// Time origin of the timestamps, nanoseconds since the Unix epoch (iox, socket).
    #[arg(long, default_value_t = 0)]
    pub epoch_ns: u64,
    /// Commands per second (flood).
    #[arg(long, default_value_t = 10_000.0)]
    pub hz: f64,
    /// Object the flood's impulses push (flood).
    #[arg(long, default_value_t = 0)]
    pub object: u32,
    /// Zenoh endpoint of the publisher (zenoh).
    #[arg(long)]
    pub connect: Option<String>,
    /// Samples received back to back after the measured ones (zenoh).
    #[arg(long, default_value_t = 0)]
    pub stream: u64,
}

/// Seconds since `epoch` on the wall clock (shared by all processes of the host).
pub fn now_s(epoch: SystemTime) -> f64 {
    SystemTime::now()
        .duration_since(epoch)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// The time origin `epoch_ns` nanoseconds after the Unix epoch.
pub fn epoch_from_ns(epoch_ns: u64) -> SystemTime {
    UNIX_EPOCH + Duration::from_nanos(epoch_ns)
}

/// Runs the role.
pub fn run(a: &PeerArgs) -> Result<()> {
    match a.role {
        PeerRole::Iox => iox(a),
        PeerRole::Socket => socket(a),
        PeerRole::Flood => flood(a),
        PeerRole::Zenoh => crate::ipc_zenoh::peer(a),
    }
}

fn iox(a: &PeerArgs) -> Result<()> {
    let epoch = epoch_from_ns(a.epoch_ns);
    let node = create_node("splatphys-bench-peer")?;
    let names = ServiceNames::new(&a.prefix);
    let service = frame_service(&node, &names, Role::User)?;
    let sub = service
        .subscriber_builder()
        .buffer_size(MAX_FRAME_BUFFER)
        .create()
        .map_err(|e| anyhow::anyhow!("creating the frame subscriber: {e:?}"))?;
    let mut latencies_us = Vec::with_capacity(a.samples as usize);
    let (mut received, mut gaps, mut next) = (0u64, 0u64, 0u64);
    let mut last_arrival = Instant::now();
    while received < a.samples {
        let Some(sample) = sub
            .receive()
            .map_err(|e| anyhow::anyhow!("receiving a frame: {e:?}"))?
        else {
            if last_arrival.elapsed() > IDLE_TIMEOUT {
                bail!(
                    "no frame for {IDLE_TIMEOUT:?} after {received} of {}",
                    a.samples
                );
            }
            std::hint::spin_loop();
            continue;
        };
        let h = *sample.user_header();
        // "Sees it": the header, the slice length and the last Gaussian are read.
        let last = sample.payload().last().map_or(0.0, |g| g.position_m[0]);
        std::hint::black_box((sample.payload().len() == h.count as usize, last));
        let latency_s = now_s(epoch) - h.time_s;
        drop(sample);
        last_arrival = Instant::now();
        gaps += h.step.saturating_sub(next);
        next = h.step + 1;
        received = next;
        if h.step >= a.warmup {
            latencies_us.push(latency_s * 1e6);
        }
    }
    println!("{}", json!({"latencies_us": latencies_us, "gaps": gaps}));
    Ok(())
}

fn socket(a: &PeerArgs) -> Result<()> {
    let epoch = epoch_from_ns(a.epoch_ns);
    let path = a.socket.as_ref().context("--socket is required")?;
    let mut s = std::os::unix::net::UnixStream::connect(path)
        .with_context(|| format!("connecting to {}", path.display()))?;
    s.set_read_timeout(Some(IDLE_TIMEOUT))?;
    let mut stamp = [0u8; 8];
    let mut payload = vec![0u8; a.bytes];
    let mut latencies_us = Vec::with_capacity(a.samples as usize);
    for i in 0..a.samples {
        s.read_exact(&mut stamp).context("reading a timestamp")?;
        s.read_exact(&mut payload).context("reading a payload")?;
        let latency_s = now_s(epoch) - f64::from_le_bytes(stamp);
        std::hint::black_box(payload.last());
        if i >= a.warmup {
            latencies_us.push(latency_s * 1e6);
        }
        s.write_all(&[1]).context("acknowledging")?;
    }
    println!("{}", json!({"latencies_us": latencies_us, "gaps": 0}));
    Ok(())
}

/// Commands sent, answered and refused by a flood.
#[derive(Debug, Default)]
struct FloodCounts {
    sent: u64,
    accepted: u64,
    rejected: u64,
    /// Sends refused locally (too many commands in flight: the server drains them once per
    /// step).
    send_errors: u64,
}

fn flood(a: &PeerArgs) -> Result<()> {
    let mut opts = ClientOptions::new(&a.prefix);
    opts.node_name = "splatphys-bench-flood".into();
    opts.frames = false;
    opts.objects = false;
    opts.connect_timeout = Duration::from_secs(30);
    let mut conn = Connection::connect(&opts)?;
    println!("ready");
    std::io::stdout().flush()?;
    let cmd = Command::Impulse {
        object: a.object,
        impulse_n_s: [0.0, 0.0, 1e-9],
        point_m: None,
    };
    let mut c = FloodCounts::default();
    let mut pending = VecDeque::new();
    let start = Instant::now();
    let end = loop {
        let due = (start.elapsed().as_secs_f64() * a.hz) as u64;
        while c.sent + c.send_errors < due {
            match conn.send_command(&cmd) {
                Ok((_, p)) => {
                    c.sent += 1;
                    pending.push_back(p);
                }
                Err(_) => c.send_errors += 1,
            }
        }
        let mut i = 0;
        while i < pending.len() {
            match conn.poll_reply(&pending[i])? {
                Some(Reply::Accepted { .. }) => c.accepted += 1,
                Some(Reply::Rejected { .. }) => c.rejected += 1,
                None => {
                    i += 1;
                    continue;
                }
            }
            pending.remove(i);
        }
        match conn.poll_status() {
            Ok(_) if conn.server_shutting_down() => break "shutdown".to_owned(),
            Ok(_) => {}
            Err(e @ IpcError::ServerGone { .. }) => break e.to_string(),
            Err(e) => return Err(e.into()),
        }
        if conn.node().wait(Duration::from_micros(200)).is_err() {
            break "interrupted".to_owned();
        }
    };
    let seconds = start.elapsed().as_secs_f64();
    println!(
        "{}",
        json!({
            "sent": c.sent,
            "accepted": c.accepted,
            "rejected": c.rejected,
            "send_errors": c.send_errors,
            "seconds": seconds,
            "end": end,
        })
    );
    Ok(())
}

/// A child process (a `bench ipc-peer`), killed if still running when dropped.
pub struct Peer(pub KillOnDrop);

impl Peer {
    /// Starts `splatphys bench ipc-peer ARGS` with stdout piped.
    pub fn spawn(args: &[String]) -> Result<Self> {
        let exe = std::env::current_exe().context("locating the splatphys-bench binary")?;
        let child = Process::new(exe)
            .arg("ipc-peer")
            .args(args)
            .stdout(Stdio::piped())
            .spawn()
            .context("starting bench ipc-peer")?;
        Ok(Self(KillOnDrop(child)))
    }

    /// Waits (up to `timeout`) for the peer to exit successfully; returns its last stdout line
    /// parsed as JSON.
    pub fn finish(mut self, timeout: Duration) -> Result<Value> {
        let status = self
            .0
            .wait_for("bench ipc-peer", timeout, Duration::from_millis(5))?;
        let mut out = String::new();
        if let Some(mut o) = self.0.stdout.take() {
            o.read_to_string(&mut out)?;
        }
        ensure!(status.success(), "bench ipc-peer failed ({status})");
        let line = out.lines().last().unwrap_or("{}");
        serde_json::from_str(line).with_context(|| format!("bench ipc-peer printed {line:?}"))
    }
}
