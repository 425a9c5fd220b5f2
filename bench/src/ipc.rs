//! `splatphys bench ipc`: what serving a frame over iceoryx2 costs, against a Unix socket and
//! Zenoh.
//!
//! For each payload size (Gaussians per frame) and in one run:
//! - **latency**: the real `frame` service and the server's own publisher
//!   ([`splatphys_ipc::server::frame_publisher`]) send `--samples` frames, 1 ms apart, to a
//!   subscriber in another process that busy-polls (`bench ipc-peer --role iox`); latency is the
//!   time from just before `send` to the subscriber holding the sample (header and last Gaussian
//!   read), on the host's wall clock;
//! - **publisher cost**: loan + write every Gaussian (a copy of a prepared frame, standing in for
//!   the simulation writing its output in place) + send, per frame, and loan + send alone;
//! - **step**: one MLS-MPM substep of an elastic cube with about as many particles (8 per cell,
//!   the `bench mpm` problem), all cores. A published step has at least one substep, so
//!   `publish_fraction_of_step` = publish cost / one substep is an upper bound on what publishing
//!   adds to a step;
//! - **socket baseline**: the same bytes through a Unix-domain stream socket to another process
//!   (`--role socket`), from the start of the write to the last byte read;
//! - **Zenoh**: the same bytes through Zenoh over TCP loopback to another process (`--role
//!   zenoh`), latency one sample at a time and back-to-back throughput ([`crate::ipc_zenoh`]).
//!
//! Then, with `--command-flood-hz`, the server runs for `--flood-seconds` with and without a
//! controller process sending that many impulse commands per second, on each of
//! `--flood-sims`; the ratio of the step rates is reported (issue: a 10,000/s flood may not
//! slow stepping by more than 10 %). See [`crate::flood`].
//!
//! Output: one JSON line per size and one for the flood on stdout; `ipc.csv`, `ipc.svg` and
//! `ipc.png` in `--out-dir`.

use std::io::{Read, Write};
use std::os::unix::net::UnixListener;
use std::path::PathBuf;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::{Context, Result, ensure};
use clap::Args;
use iceoryx2::service::port_factory::PortFactory;
use serde_json::{Value, json};
use splatphys_ipc::backpressure::LagBook;
use splatphys_ipc::server::frame_publisher;
use splatphys_ipc::services::{Role, ServiceNames, create_node, frame_service};
use splatphys_ipc::wire::{FrameGaussian, FrameHeader, LAYOUT_VERSION};

use crate::peer::Peer;

use crate::chart::{Series, line_chart, write_csv};
use crate::peer::now_s;

/// Arguments of `bench ipc`.
#[derive(Args, Debug)]
pub struct IpcBenchArgs {
    /// Payload sizes, Gaussians per frame (52 bytes each).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "1000,10000,100000,1000000"
    )]
    pub sizes: Vec<usize>,
    /// Measured samples per size and transport.
    #[arg(long, default_value_t = 200)]
    pub samples: u64,
    /// Warm-up samples per size and transport, not measured.
    #[arg(long, default_value_t = 20)]
    pub warmup: u64,
    /// Where `ipc.csv`, `ipc.svg` and `ipc.png` go.
    #[arg(long, default_value = "docs/results/bench")]
    pub out_dir: PathBuf,
    /// Commands per second of the flood runs (0 skips them).
    #[arg(long, default_value_t = 10_000.0)]
    pub command_flood_hz: f64,
    /// Simulations the flood runs serve, one JSON line each.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "default,fake"
    )]
    pub flood_sims: Vec<crate::flood::FloodSim>,
    /// Wall-clock seconds of stepping per flood run (each run starts from the same state).
    #[arg(long, default_value_t = 8.0)]
    pub flood_seconds: f64,
    /// Runs with and without the flood, alternating; medians are reported.
    #[arg(long, default_value_t = 2)]
    pub flood_repeats: u32,
}

/// Nearest-rank percentile `q` in 0..=1 of `v` (sorted in place); NaN when empty.
fn percentile(v: &mut [f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

pub(crate) fn latencies(v: &Value) -> Result<Vec<f64>> {
    let gaps = v["gaps"].as_u64().unwrap_or(0);
    ensure!(gaps == 0, "the subscriber missed {gaps} samples");
    Ok(v["latencies_us"]
        .as_array()
        .context("no latencies_us")?
        .iter()
        .filter_map(Value::as_f64)
        .collect())
}

/// Timings of one size on iceoryx2.
struct IoxRun {
    latency_us: Vec<f64>,
    publish_us: Vec<f64>,
    loan_send_us: Vec<f64>,
}

/// A frame of `n` Gaussians in a recognisable pattern (what the simulation would write).
fn source_frame(n: usize) -> Vec<FrameGaussian> {
    (0..n)
        .map(|i| FrameGaussian {
            position_m: [i as f32 * 1e-3, 0.5, 1.0],
            covariance_m2: [1e-4, 0.0, 0.0, 1e-4, 0.0, 1e-4],
            rotation_wxyz: [1.0, 0.0, 0.0, 0.0],
        })
        .collect()
}

fn iox_run(a: &IpcBenchArgs, src: &[FrameGaussian], epoch_ns: u64) -> Result<IoxRun> {
    let n = src.len();
    let epoch = UNIX_EPOCH + Duration::from_nanos(epoch_ns);
    let names = ServiceNames::new(&format!("splatphys-bench/ipc-{}-{n}", std::process::id()));
    let node = create_node("splatphys-bench")?;
    let service = frame_service(&node, &names, Role::Owner)?;
    let book = LagBook::new(Duration::from_millis(100));
    let publisher = frame_publisher(&service, &names, n, &book)?;
    let total = a.warmup + a.samples;
    let peer = Peer::spawn(&[
        "--role".into(),
        "iox".into(),
        "--prefix".into(),
        names.prefix().into(),
        "--samples".into(),
        total.to_string(),
        "--warmup".into(),
        a.warmup.to_string(),
        "--epoch-ns".into(),
        epoch_ns.to_string(),
    ])?;
    let t0 = Instant::now();
    while service.dynamic_config().number_of_subscribers() == 0 {
        ensure!(
            t0.elapsed() < Duration::from_secs(30),
            "the subscriber process did not connect"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    let mut run = IoxRun {
        latency_us: Vec::new(),
        publish_us: Vec::new(),
        loan_send_us: Vec::new(),
    };
    for i in 0..total {
        let t_loan = Instant::now();
        let sample = publisher
            .loan_slice_uninit(n)
            .map_err(|e| anyhow::anyhow!("loaning a frame: {e:?}"))?;
        // SAFETY: as in the server's `publish_frame`: shared memory is always initialised and
        // `FrameGaussian` is Pod; every element is overwritten below.
        let mut sample = unsafe { sample.assume_init() };
        let t_write = Instant::now();
        sample.payload_mut().copy_from_slice(src);
        let write = t_write.elapsed();
        *sample.user_header_mut() = FrameHeader {
            step: i,
            frame_index: i,
            count: n as u32,
            layout_version: LAYOUT_VERSION,
            time_s: now_s(epoch),
            ..FrameHeader::default()
        };
        sample
            .send()
            .map_err(|e| anyhow::anyhow!("sending a frame: {e:?}"))?;
        let total_time = t_loan.elapsed();
        if i >= a.warmup {
            run.publish_us.push(total_time.as_secs_f64() * 1e6);
            run.loan_send_us
                .push(total_time.saturating_sub(write).as_secs_f64() * 1e6);
        }
        // Let the subscriber go idle again, so every sample meets a waiting reader.
        std::thread::sleep(Duration::from_millis(1));
    }
    let v = peer.finish(Duration::from_secs(60))?;
    run.latency_us = latencies(&v)?;
    Ok(run)
}

fn socket_run(a: &IpcBenchArgs, bytes: &[u8], epoch_ns: u64) -> Result<Vec<f64>> {
    let epoch = UNIX_EPOCH + Duration::from_nanos(epoch_ns);
    let path = std::env::temp_dir().join(format!(
        "splatphys-bench-{}-{}.sock",
        std::process::id(),
        bytes.len()
    ));
    let _ = std::fs::remove_file(&path);
    let listener =
        UnixListener::bind(&path).with_context(|| format!("binding {}", path.display()))?;
    listener.set_nonblocking(true)?;
    let total = a.warmup + a.samples;
    let peer = Peer::spawn(&[
        "--role".into(),
        "socket".into(),
        "--socket".into(),
        path.display().to_string(),
        "--bytes".into(),
        bytes.len().to_string(),
        "--samples".into(),
        total.to_string(),
        "--warmup".into(),
        a.warmup.to_string(),
        "--epoch-ns".into(),
        epoch_ns.to_string(),
    ])?;
    let t0 = Instant::now();
    let mut stream = loop {
        match listener.accept() {
            Ok((s, _)) => break s,
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                ensure!(
                    t0.elapsed() < Duration::from_secs(30),
                    "the socket reader did not connect"
                );
                std::thread::sleep(Duration::from_millis(2));
            }
            Err(e) => return Err(e).context("accepting the socket reader"),
        }
    };
    let _ = std::fs::remove_file(&path);
    stream.set_nonblocking(false)?;
    stream.set_read_timeout(Some(Duration::from_secs(30)))?;
    let mut ack = [0u8; 1];
    for _ in 0..total {
        let t = now_s(epoch);
        stream.write_all(&t.to_le_bytes())?;
        stream.write_all(bytes)?;
        stream
            .read_exact(&mut ack)
            .context("waiting for the reader")?;
    }
    let v = peer.finish(Duration::from_secs(60))?;
    latencies(&v)
}

/// Median time of one MLS-MPM substep of about `n` particles (8 per cell), microseconds, and
/// the exact particle count.
fn step_us(n: usize) -> Result<(usize, f64)> {
    let per_axis = (n as f64).cbrt().round().max(1.0) as u32;
    let dx = 2.0 * 0.3 / per_axis as f32;
    let mut sys = crate::mpm::elastic_cube(per_axis, dx, 1.0)?;
    sys.substep(1.0)?; // warm-up: grid allocation
    let mut times = Vec::new();
    let t0 = Instant::now();
    while times.len() < 3 || (t0.elapsed() < Duration::from_millis(300) && times.len() < 50) {
        let t = Instant::now();
        sys.substep(1.0)?;
        times.push(t.elapsed().as_secs_f64() * 1e6);
    }
    Ok((sys.particles.len(), percentile(&mut times, 0.5)))
}

/// Runs `bench ipc`.
pub fn run(a: &IpcBenchArgs, world: crate::WorldSimFactory) -> Result<()> {
    ensure!(a.samples > 0, "--samples must be at least 1");
    ensure!(!a.sizes.is_empty(), "--sizes is empty");
    let epoch_ns = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .context("clock before 1970")?
        .as_nanos() as u64;
    let mut rows = Vec::new();
    let mut series: [Series; 5] = [
        "iceoryx2 latency, median",
        "iceoryx2 latency, p99",
        "Unix socket latency, median",
        "Zenoh (TCP loopback) latency, median",
        "publish cost (loan + write + send), median",
    ]
    .map(|name| Series {
        name: name.into(),
        points: Vec::new(),
    });
    for &n in &a.sizes {
        ensure!(n > 0 && n <= u32::MAX as usize, "size {n} out of range");
        let (step_particles, step_us) = step_us(n)?;
        let src = source_frame(n);
        let mut iox = iox_run(a, &src, epoch_ns).with_context(|| format!("iceoryx2, {n}"))?;
        let bytes: &[u8] = bytemuck::cast_slice(&src);
        let mut sock = socket_run(a, bytes, epoch_ns).with_context(|| format!("socket, {n}"))?;
        let mut zenoh = crate::ipc_zenoh::run(a.samples, a.warmup, bytes, epoch_ns)
            .with_context(|| format!("Zenoh, {n}"))?;
        let zenoh_med = percentile(&mut zenoh.latency_us, 0.5);
        let zenoh_p99 = percentile(&mut zenoh.latency_us, 0.99);
        let iox_med = percentile(&mut iox.latency_us, 0.5);
        let iox_p99 = percentile(&mut iox.latency_us, 0.99);
        let sock_med = percentile(&mut sock, 0.5);
        let sock_p99 = percentile(&mut sock, 0.99);
        let publish = percentile(&mut iox.publish_us, 0.5);
        let publish_p99 = percentile(&mut iox.publish_us, 0.99);
        let loan_send = percentile(&mut iox.loan_send_us, 0.5);
        let row = [
            n as f64,
            bytes.len() as f64,
            iox_med,
            iox_p99,
            sock_med,
            sock_p99,
            sock_med / iox_med,
            publish,
            publish_p99,
            loan_send,
            step_us,
            step_particles as f64,
            publish / step_us,
            zenoh_med,
            zenoh_p99,
            zenoh.frames_per_s,
        ];
        let json = json!({
            "bench": "ipc",
            "gaussians": n,
            "bytes": bytes.len(),
            "samples": a.samples,
            "iox_median_latency_us": iox_med,
            "iox_p99_latency_us": iox_p99,
            "socket_median_latency_us": sock_med,
            "socket_p99_latency_us": sock_p99,
            "speedup_vs_socket": sock_med / iox_med,
            "publish_us": publish,
            "publish_p99_us": publish_p99,
            "loan_send_us": loan_send,
            "step_us": step_us,
            "step_particles": step_particles,
            "step_threads": rayon::current_num_threads(),
            "publish_fraction_of_step": publish / step_us,
            "zenoh_median_latency_us": zenoh_med,
            "zenoh_p99_latency_us": zenoh_p99,
            "zenoh_frames_per_s": zenoh.frames_per_s,
        });
        println!("{json}");
        for (s, y) in series
            .iter_mut()
            .zip([iox_med, iox_p99, sock_med, zenoh_med, publish])
        {
            s.points.push((n as f64, y));
        }
        rows.push(row.to_vec());
    }
    let csv = a.out_dir.join("ipc.csv");
    write_csv(&csv, &CSV_COLUMNS, &rows)?;
    let files = line_chart(
        &a.out_dir.join("ipc"),
        "Frame latency and publish cost: iceoryx2 vs Unix socket and Zenoh",
        "Gaussians per frame (52 bytes each)",
        "microseconds",
        &series,
        true,
        true,
    )?;
    eprintln!(
        "bench ipc: wrote {}, {}{}",
        csv.display(),
        files.svg.display(),
        files
            .png
            .as_ref()
            .map_or_else(String::new, |p| format!(", {}", p.display()))
    );
    if a.command_flood_hz > 0.0 {
        for &sim in &a.flood_sims {
            let line = crate::flood::run(
                sim,
                world,
                a.command_flood_hz,
                a.flood_seconds,
                a.flood_repeats,
            )?;
            println!("{line}");
        }
    }
    Ok(())
}

/// Columns of `ipc.csv` (one row per size; times in microseconds).
const CSV_COLUMNS: [&str; 16] = [
    "gaussians",
    "bytes",
    "iox_median_latency_us",
    "iox_p99_latency_us",
    "socket_median_latency_us",
    "socket_p99_latency_us",
    "speedup_vs_socket",
    "publish_us",
    "publish_p99_us",
    "loan_send_us",
    "step_us",
    "step_particles",
    "publish_fraction_of_step",
    "zenoh_median_latency_us",
    "zenoh_p99_latency_us",
    "zenoh_frames_per_s",
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_use_the_nearest_rank() {
        let mut v = vec![5.0, 1.0, 3.0, 2.0, 4.0];
        assert_eq!(percentile(&mut v, 0.5), 3.0);
        assert_eq!(percentile(&mut v, 1.0), 5.0);
        assert!(percentile(&mut [], 0.5).is_nan());
    }

    #[test]
    fn a_subscriber_that_missed_samples_is_an_error() {
        assert!(latencies(&json!({"latencies_us": [1.0], "gaps": 2})).is_err());
        assert_eq!(
            latencies(&json!({"latencies_us": [1.0, 2.0], "gaps": 0})).unwrap(),
            vec![1.0, 2.0]
        );
    }
}
