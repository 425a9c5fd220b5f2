//! The recorder as a separate process against an in-process server running the free-fall
//! stand-in: a clean run records every frame; a kill -9'd recorder's file still yields every
//! closed chunk, and the objects export to CSV.

use std::process::{Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use splatphys_ipc::fake::FreeFall;
use splatphys_ipc::server::{ServerConfig, serve};
use splatphys_record::read::{frame_headers, object_names, objects_csv, read_all};
use splatphys_tests::{IOX_PREFIX_ENV, Proc, bin, iox_prefix, service_prefix};

fn start_server(
    iox: &str,
    prefix: &str,
    max_frames: Option<u64>,
) -> (Arc<AtomicBool>, std::thread::JoinHandle<u64>) {
    // SAFETY: the only test of this binary sets the variable before any iceoryx2 node of this
    // process reads it (every node reads it), always to the same value.
    unsafe { std::env::set_var(IOX_PREFIX_ENV, iox) };
    let stop = Arc::new(AtomicBool::new(false));
    let cfg = ServerConfig {
        prefix: Some(prefix.to_owned()),
        max_frames,
        start_paused: true,
        stop: stop.clone(),
        ..ServerConfig::default()
    };
    let handle = std::thread::spawn(move || {
        let mut sim = FreeFall::new("rec", 2, 50, 0.001, None);
        serve(&mut sim, &cfg).expect("server").frames_published
    });
    (stop, handle)
}

fn resume(prefix: &str) {
    let mut conn = splatphys_ipc::client::Connection::connect(
        &splatphys_ipc::client::ClientOptions::new(prefix),
    )
    .expect("connect");
    let r = conn
        .command(
            &splatphys_ipc::command::Command::Resume,
            Duration::from_secs(2),
        )
        .expect("resume");
    assert!(matches!(r, splatphys_ipc::command::Reply::Accepted { .. }));
}

#[test]
fn recorder_gets_every_frame_and_a_killed_recorder_keeps_closed_chunks() {
    let iox = iox_prefix("rec");
    let dir = tempfile::tempdir().expect("tempdir");

    // 1. Clean run: 2,000 frames after the initial one, recorder stops on shutdown.
    let prefix = service_prefix("rec");
    let (_stop, server) = start_server(&iox, &prefix, Some(2000));
    let out = dir.path().join("run.mcap");
    let rec = Proc::spawn(
        Command::new(bin("splatphys-record"))
            .args(["record", "--prefix", &prefix, "--out"])
            .arg(&out)
            .env(IOX_PREFIX_ENV, &iox)
            .stderr(Stdio::piped()),
    );
    std::thread::sleep(Duration::from_millis(500)); // let the recorder subscribe
    resume(&prefix);
    let published = server.join().expect("server thread");
    // Exits 0 (it stops on the server's shutdown).
    rec.wait_success(Duration::from_secs(60));
    let msgs = read_all(&out, false).unwrap();
    let frames = frame_headers(msgs.iter().cloned().map(Ok), &out).unwrap();
    assert_eq!(published, 2001);
    // The initial frame (index 0) went out before the recorder subscribed (frames keep no
    // history); every frame after the resume is in the file, in order, without a gap.
    assert_eq!(
        frames.len() as u64,
        published - 1,
        "lossless: every frame after subscribing"
    );
    assert_eq!(
        (frames[0].frame_index, frames[frames.len() - 1].frame_index),
        (1, 2000)
    );
    assert!(
        frames
            .windows(2)
            .all(|w| w[1].frame_index == w[0].frame_index + 1)
    );
    let mut csv = Vec::new();
    let names = object_names(msgs.iter().cloned().map(Ok)).unwrap();
    let rows = objects_csv(msgs.into_iter().map(Ok), &out, names, &mut csv).unwrap();
    assert_eq!(rows, 2 * 2000, "2 objects per frame");

    // 2. kill -9 the recorder mid-run: every closed chunk is still readable.
    let prefix = service_prefix("rec2");
    let (stop, server) = start_server(&iox, &prefix, None);
    let out2 = dir.path().join("killed.mcap");
    let mut rec = Proc::spawn(
        Command::new(bin("splatphys-record"))
            .args(["record", "--prefix", &prefix, "--out"])
            .arg(&out2)
            .env(IOX_PREFIX_ENV, &iox),
    );
    std::thread::sleep(Duration::from_millis(500));
    resume(&prefix);
    std::thread::sleep(Duration::from_millis(2500)); // > 2 flush periods of 1 s
    rec.kill9();
    let t0 = Instant::now();
    std::thread::sleep(Duration::from_millis(200));
    stop.store(true, Ordering::Release);
    let _ = server.join();
    assert!(
        t0.elapsed() < Duration::from_secs(30),
        "server did not stop"
    );
    let bytes = std::fs::read(&out2).unwrap();
    assert!(
        read_all(&out2, false).is_err() || bytes.len() < 8,
        "no summary"
    );
    let frames = frame_headers(read_all(&out2, true).unwrap().into_iter().map(Ok), &out2).unwrap();
    assert!(frames.len() > 100, "recovered {} frames", frames.len());
    assert!(
        frames
            .windows(2)
            .all(|w| w[1].frame_index == w[0].frame_index + 1)
    );
}
