//! The Zenoh side of `splatphys bench ipc`: the same frame bytes as the iceoryx2 and socket
//! runs, through Zenoh over TCP loopback (what `splatphys-zenoh` does for a remote client).
//!
//! The bench process opens a Zenoh peer listening on a loopback port and publishes on
//! `splatphys-bench/frame` (reliable, congestion control *block*, so nothing is dropped and
//! every sample is measured); the far side (`bench ipc-peer --role zenoh`, its own process)
//! connects as a Zenoh client.
//! - **latency**: one sample at a time; each carries its send time (f64 seconds after
//!   `--epoch-ns`) in its first 8 bytes and the peer answers on `splatphys-bench/ack` once it
//!   holds the whole payload, so every sample meets an idle reader (as the socket baseline);
//! - **throughput**: then `--samples` more back to back; the peer acknowledges the last one, and
//!   frames per second = samples / (last ack − first send).

use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow, bail, ensure};
use serde_json::{Value, json};
use zenoh::Wait;
use zenoh::handlers::FifoChannel;
use zenoh::qos::CongestionControl;

use crate::peer::{PeerArgs, epoch_from_ns, now_s};

const FRAME_KEY: &str = "splatphys-bench/frame";
const ACK_KEY: &str = "splatphys-bench/ack";
/// Gives up when nothing arrives for this long.
const IDLE_TIMEOUT: Duration = Duration::from_secs(30);

/// What one size measured over Zenoh.
pub struct ZenohRun {
    /// Latency per measured sample, microseconds.
    pub latency_us: Vec<f64>,
    /// Back-to-back frames per second, send of the first to the ack of the last.
    pub frames_per_s: f64,
}

fn zerr(what: &'static str) -> impl FnOnce(zenoh::Error) -> anyhow::Error {
    move |e| anyhow!("zenoh: {what}: {e}")
}

fn config(mode: &str, endpoint_key: &str, endpoint: &str) -> Result<zenoh::Config> {
    let mut c = zenoh::Config::default();
    c.insert_json5("mode", &format!("{mode:?}"))
        .map_err(zerr("mode"))?;
    c.insert_json5("scouting/multicast/enabled", "false")
        .map_err(zerr("scouting"))?;
    c.insert_json5(endpoint_key, &format!("[{endpoint:?}]"))
        .map_err(zerr("endpoints"))?;
    Ok(c)
}

fn free_port() -> Result<u16> {
    Ok(std::net::TcpListener::bind("127.0.0.1:0")?
        .local_addr()?
        .port())
}

/// Publishes `bytes` (one frame's payload) `warmup + samples` times one at a time, then
/// `samples` times back to back, to a peer process.
///
/// # Errors
/// Zenoh could not start, or the peer did not connect, answer or finish.
pub fn run(samples: u64, warmup: u64, bytes: &[u8], epoch_ns: u64) -> Result<ZenohRun> {
    let epoch = epoch_from_ns(epoch_ns);
    let endpoint = format!("tcp/127.0.0.1:{}", free_port()?);
    let session = zenoh::open(config("peer", "listen/endpoints", &endpoint)?)
        .wait()
        .map_err(zerr("opening the session"))?;
    let publisher = session
        .declare_publisher(FRAME_KEY)
        .congestion_control(CongestionControl::Block)
        .wait()
        .map_err(zerr("publisher"))?;
    let acks = session
        .declare_subscriber(ACK_KEY)
        .wait()
        .map_err(zerr("ack subscriber"))?;
    let total = warmup + samples;
    let peer = crate::peer::Peer::spawn(&[
        "--role".into(),
        "zenoh".into(),
        "--connect".into(),
        endpoint,
        "--bytes".into(),
        bytes.len().to_string(),
        "--samples".into(),
        total.to_string(),
        "--warmup".into(),
        warmup.to_string(),
        "--stream".into(),
        samples.to_string(),
        "--epoch-ns".into(),
        epoch_ns.to_string(),
    ])?;
    let t0 = Instant::now();
    while !publisher
        .matching_status()
        .wait()
        .map_err(zerr("matching status"))?
        .matching()
    {
        ensure!(
            t0.elapsed() < IDLE_TIMEOUT,
            "the Zenoh reader did not connect"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    // What the bridge does per frame: the header's and the payload's bytes into one buffer.
    let frame = |time_s: f64| {
        let mut out = Vec::with_capacity(8 + bytes.len());
        out.extend_from_slice(&time_s.to_le_bytes());
        out.extend_from_slice(bytes);
        out
    };
    let wait_ack = || -> Result<()> {
        acks.recv_timeout(IDLE_TIMEOUT)
            .map_err(|e| anyhow!("waiting for the reader's ack: {e}"))?
            .context("the reader sent no ack")?;
        Ok(())
    };
    for _ in 0..total {
        publisher
            .put(frame(now_s(epoch)))
            .wait()
            .map_err(zerr("publishing"))?;
        wait_ack()?;
    }
    let t_stream = Instant::now();
    for _ in 0..samples {
        publisher
            .put(frame(now_s(epoch)))
            .wait()
            .map_err(zerr("publishing"))?;
    }
    wait_ack()?;
    let frames_per_s = samples as f64 / t_stream.elapsed().as_secs_f64();
    let v = peer.finish(Duration::from_secs(60))?;
    Ok(ZenohRun {
        latency_us: crate::ipc::latencies(&v)?,
        frames_per_s,
    })
}

/// `bench ipc-peer --role zenoh`: the reader of [`run`].
///
/// # Errors
/// Zenoh could not connect, or samples stopped coming or had the wrong size.
pub fn peer(a: &PeerArgs) -> Result<()> {
    let epoch = epoch_from_ns(a.epoch_ns);
    let endpoint = a.connect.as_deref().context("--connect is required")?;
    let session = zenoh::open(config("client", "connect/endpoints", endpoint)?)
        .wait()
        .map_err(zerr("opening the session"))?;
    // A short queue: a 52 MB frame per slot is enough to hold.
    let frames = session
        .declare_subscriber(FRAME_KEY)
        .with(FifoChannel::new(4))
        .wait()
        .map_err(zerr("subscriber"))?;
    let ack = session
        .declare_publisher(ACK_KEY)
        .congestion_control(CongestionControl::Block)
        .wait()
        .map_err(zerr("ack publisher"))?;
    // The time the sample was sent and its last byte: the whole payload is here and read.
    let recv = || -> Result<(f64, u8)> {
        let sample = frames
            .recv_timeout(IDLE_TIMEOUT)
            .map_err(|e| anyhow!("receiving a frame: {e}"))?
            .context("no frame")?;
        let bytes = sample.payload().to_bytes();
        if bytes.len() != 8 + a.bytes {
            bail!("a frame of {} bytes; expected {}", bytes.len(), 8 + a.bytes);
        }
        let sent = f64::from_le_bytes(bytes[..8].try_into().expect("8 bytes"));
        Ok((sent, bytes[bytes.len() - 1]))
    };
    let mut latencies_us = Vec::with_capacity(a.samples as usize);
    for i in 0..a.samples {
        let (sent, last) = recv()?;
        std::hint::black_box(last);
        let latency_s = now_s(epoch) - sent;
        if i >= a.warmup {
            latencies_us.push(latency_s * 1e6);
        }
        ack.put(vec![1u8]).wait().map_err(zerr("ack"))?;
    }
    for _ in 0..a.stream {
        std::hint::black_box(recv()?);
    }
    ack.put(vec![2u8]).wait().map_err(zerr("ack"))?;
    drop(ack);
    session.close().wait().map_err(zerr("closing"))?;
    let out: Value = json!({"latencies_us": latencies_us, "gaps": 0});
    println!("{out}");
    Ok(())
}
