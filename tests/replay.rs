//! Record -> replay -> record, end to end: a short free-fall run is recorded to MCAP by a
//! `splatphys-record record` process, `splatphys-record replay` publishes the file onto a fresh
//! prefix, and a second recorder process subscribed to that prefix must get the same scene,
//! frames and objects, byte for byte (headers included: steps, times, frame indices).
//!
//! One test in this binary: it sets `SPLATPHYS_IOX2_PREFIX` for the whole process. Deadlines
//! only catch hangs; nothing here depends on wall-clock speed.

use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use splatphys_ipc::client::{ClientOptions, Connection};
use splatphys_ipc::command::{Command as SimCommand, Reply};
use splatphys_ipc::fake::FreeFall;
use splatphys_ipc::server::{ServerConfig, serve};
use splatphys_record::channels::{FRAME, OBJECTS, SCENE};
use splatphys_record::read::{RecordedMessage, frame_headers, read_all};
use splatphys_tests::{
    IOX_PREFIX_ENV, Proc, bin, iox_prefix, leftovers, service_prefix, wait_until,
};

/// Frames of the recorded run after the initial one.
const FRAMES: u64 = 300;
/// Longest wait on the lossless recorders, for the server and the replay (their default,
/// 100 ms, is the real-time choice; a loaded CI machine can keep a recorder off a core longer).
const PATIENT_LIMIT: Duration = Duration::from_secs(2);

/// `splatphys-record <args> [--out <out>]` under iceoryx2 file prefix `iox`, stderr piped.
fn record_process(iox: &str, args: &[&str], out: Option<&Path>) -> Proc {
    let mut c = Command::new(bin("splatphys-record"));
    c.args(args).env(IOX_PREFIX_ENV, iox);
    if let Some(out) = out {
        c.arg("--out").arg(out);
    }
    Proc::spawn(c.stderr(Stdio::piped()))
}

/// The raw bytes (header + payload) of every message on `topic`, in order.
fn payloads<'a>(msgs: &'a [RecordedMessage], topic: &str) -> Vec<&'a [u8]> {
    msgs.iter()
        .filter(|m| m.topic == topic)
        .map(|m| m.data.as_slice())
        .collect()
}

/// Records `FRAMES` frames of a free-fall run served under `prefix` to `out` with a recorder
/// process.
fn record_fake_run(iox: &str, prefix: &str, out: &Path) {
    let cfg = ServerConfig {
        prefix: Some(prefix.into()),
        max_frames: Some(FRAMES),
        start_paused: true,
        stop: Arc::new(AtomicBool::new(false)),
        // A recorder waiting for a core on a loaded machine is waited for, not dropped.
        lossless_limit: PATIENT_LIMIT,
        ..ServerConfig::default()
    };
    let server = std::thread::spawn(move || {
        let mut sim = FreeFall::new("rr", 2, 40, 0.002, None);
        serve(&mut sim, &cfg).expect("server").frames_published
    });
    let rec = record_process(
        iox,
        &["record", "--prefix", prefix, "--connect-timeout-s", "30"],
        Some(out),
    );
    // Resume once the recorder subscribed to frames: it then gets frames 1..=FRAMES.
    let mut opts = ClientOptions::new(prefix);
    opts.frames = false;
    opts.objects = false;
    opts.connect_timeout = Duration::from_secs(30);
    let mut conn = Connection::connect(&opts).expect("connect");
    wait_until("the recorder subscribes", Duration::from_secs(60), || {
        conn.poll_status()
            .expect("status")
            .is_some_and(|s| s.subscriber_count > 0)
    });
    let r = conn
        .command(&SimCommand::Resume, Duration::from_secs(30))
        .expect("resume");
    assert!(matches!(r, Reply::Accepted { .. }), "{r:?}");
    drop(conn);
    assert_eq!(server.join().expect("server thread"), FRAMES + 1);
    rec.wait_success(Duration::from_secs(60));
}

#[test]
fn replayed_recording_reaches_a_new_subscriber_byte_for_byte() {
    let iox = iox_prefix("rr");
    // SAFETY: the only test of this binary, set before any thread reads the environment.
    unsafe { std::env::set_var(IOX_PREFIX_ENV, &iox) };
    let (recorded, replayed_prefix) = (service_prefix("rr"), service_prefix("rr-replay"));
    let dir = tempfile::tempdir().expect("tempdir");
    let original = dir.path().join("original.mcap");
    let replayed = dir.path().join("replayed.mcap");

    record_fake_run(&iox, &recorded, &original);

    // The second recorder waits for the replay's services; the replay waits for it to
    // subscribe, then publishes as fast as the recorder takes the frames.
    let rec = record_process(
        &iox,
        &[
            "record",
            "--prefix",
            &replayed_prefix,
            "--connect-timeout-s",
            "60",
        ],
        Some(&replayed),
    );
    let original_s = original.display().to_string();
    let replay = record_process(
        &iox,
        &[
            "replay",
            &original_s,
            "--prefix",
            &replayed_prefix,
            "--fast",
            "--wait-for-subscribers",
            "1",
            "--wait-timeout-s",
            "60",
            "--lossless-limit-ms",
            "2000",
        ],
        None,
    );
    let replay_err = replay.wait_success(Duration::from_secs(120)).err;
    assert!(
        replay_err.contains(&format!("{FRAMES} frames")),
        "replay said: {replay_err}"
    );
    rec.wait_success(Duration::from_secs(60));

    let a = read_all(&original, false).unwrap();
    let b = read_all(&replayed, false).unwrap();
    let (ha, hb) = (
        frame_headers(a.iter().cloned().map(Ok), &original).unwrap(),
        frame_headers(b.iter().cloned().map(Ok), &replayed).unwrap(),
    );
    assert_eq!(ha.len() as u64, FRAMES, "original recording");
    assert_eq!(hb.len(), ha.len(), "frames seen by the replay's subscriber");
    assert_eq!(
        (hb[0].step, hb[hb.len() - 1].step),
        (ha[0].step, ha[ha.len() - 1].step)
    );
    for topic in [SCENE, FRAME, OBJECTS] {
        let (pa, pb) = (payloads(&a, topic), payloads(&b, topic));
        assert_eq!(pa.len(), pb.len(), "{topic}: message count");
        let bytes = |p: &[&[u8]]| p.iter().map(|d| d.len()).sum::<usize>();
        assert_eq!(bytes(&pa), bytes(&pb), "{topic}: total bytes");
        if let Some(i) = (0..pa.len()).find(|&i| pa[i] != pb[i]) {
            panic!("{topic}: message {i} differs after the replay");
        }
    }
    assert_eq!(leftovers(&iox), Vec::<String>::new());
}
