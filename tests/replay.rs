//! Record -> replay -> record, end to end: a short free-fall run is recorded to MCAP by a
//! `splatphys-record record` process, `splatphys-record replay` publishes the file onto a fresh
//! prefix, and a second recorder process subscribed to that prefix must get the same scene,
//! frames and objects, byte for byte (headers included: steps, times, frame indices).
//!
//! One test in this binary: it sets `SPLATPHYS_IOX2_PREFIX` for the whole process. Deadlines
//! only catch hangs; nothing here depends on wall-clock speed.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use splatphys_ipc::client::{ClientOptions, Connection};
use splatphys_ipc::command::{Command as SimCommand, Reply};
use splatphys_ipc::fake::FreeFall;
use splatphys_ipc::server::{ServerConfig, serve};
use splatphys_record::channels::{FRAME, OBJECTS, SCENE};
use splatphys_record::read::{RecordedMessage, frame_headers, messages, read_file};

const RECORDER: &str = env!("CARGO_BIN_EXE_splatphys-record");
/// Frames of the recorded run after the initial one.
const FRAMES: u64 = 300;
/// Longest wait on the lossless recorders, for the server and the replay (their default,
/// 100 ms, is the real-time choice; a loaded CI machine can keep a recorder off a core longer).
const PATIENT_LIMIT: Duration = Duration::from_secs(2);

/// A child process, killed when dropped (only matters when a test fails half-way).
struct Proc(Child);

impl Drop for Proc {
    fn drop(&mut self) {
        if let Ok(None) = self.0.try_wait() {
            let _ = self.0.kill();
        }
        let _ = self.0.wait();
    }
}

impl Proc {
    fn spawn(iox: &str, args: &[&str], out: Option<&Path>) -> Self {
        let mut c = Command::new(RECORDER);
        c.args(args).env("SPLATPHYS_IOX2_PREFIX", iox);
        if let Some(out) = out {
            c.arg("--out").arg(out);
        }
        Self(
            c.stderr(Stdio::piped())
                .spawn()
                .expect("spawn splatphys-record"),
        )
    }

    /// Waits for a successful exit; returns stderr.
    fn success(mut self, what: &str, timeout: Duration) -> String {
        let t0 = Instant::now();
        let status = loop {
            if let Some(st) = self.0.try_wait().expect("try_wait") {
                break st;
            }
            assert!(
                t0.elapsed() < timeout,
                "{what} still running after {timeout:?}"
            );
            std::thread::sleep(Duration::from_millis(5));
        };
        let mut err = String::new();
        if let Some(mut e) = self.0.stderr.take() {
            use std::io::Read;
            let _ = e.read_to_string(&mut err);
        }
        assert!(status.success(), "{what} failed ({status}): {err}");
        err
    }
}

/// Files of iceoryx2 prefix `iox` left in /dev/shm (iceoryx2 keeps one 16-byte
/// `*.global_mgmt` node counter per prefix on purpose).
fn leftovers(iox: &str) -> Vec<String> {
    std::fs::read_dir("/dev/shm")
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(iox) && !n.ends_with(".global_mgmt"))
        .collect()
}

/// The raw bytes (header + payload) of every message on `topic`, in order.
fn payloads<'a>(msgs: &'a [RecordedMessage], topic: &str) -> Vec<&'a [u8]> {
    msgs.iter()
        .filter(|m| m.topic == topic)
        .map(|m| m.data.as_slice())
        .collect()
}

/// Records `FRAMES` frames of a free-fall run to `out` with a recorder process.
fn record_fake_run(iox: &str, out: &Path) {
    let cfg = ServerConfig {
        prefix: Some("t/rr".into()),
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
    let rec = Proc::spawn(
        iox,
        &["record", "--prefix", "t/rr", "--connect-timeout-s", "30"],
        Some(out),
    );
    // Resume once the recorder subscribed to frames: it then gets frames 1..=FRAMES.
    let mut opts = ClientOptions::new("t/rr");
    opts.frames = false;
    opts.objects = false;
    opts.connect_timeout = Duration::from_secs(30);
    let mut conn = Connection::connect(&opts).expect("connect");
    let t0 = Instant::now();
    while conn
        .poll_status()
        .expect("status")
        .map_or(0, |s| s.subscriber_count)
        == 0
    {
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "recorder never subscribed"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    let r = conn
        .command(&SimCommand::Resume, Duration::from_secs(30))
        .expect("resume");
    assert!(matches!(r, Reply::Accepted { .. }), "{r:?}");
    drop(conn);
    assert_eq!(server.join().expect("server thread"), FRAMES + 1);
    rec.success("recorder", Duration::from_secs(60));
}

#[test]
fn replayed_recording_reaches_a_new_subscriber_byte_for_byte() {
    let iox = format!("spxrr_{}_", std::process::id());
    // SAFETY: the only test of this binary, set before any thread reads the environment.
    unsafe { std::env::set_var("SPLATPHYS_IOX2_PREFIX", &iox) };
    let dir = tempfile::tempdir().expect("tempdir");
    let original = dir.path().join("original.mcap");
    let replayed = dir.path().join("replayed.mcap");

    record_fake_run(&iox, &original);

    // The second recorder waits for the replay's services; the replay waits for it to
    // subscribe, then publishes as fast as the recorder takes the frames.
    let rec = Proc::spawn(
        &iox,
        &[
            "record",
            "--prefix",
            "t/rr-replay",
            "--connect-timeout-s",
            "60",
        ],
        Some(&replayed),
    );
    let original_s = original.display().to_string();
    let replay = Proc::spawn(
        &iox,
        &[
            "replay",
            &original_s,
            "--prefix",
            "t/rr-replay",
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
    let replay_err = replay.success("replay", Duration::from_secs(120));
    assert!(
        replay_err.contains(&format!("{FRAMES} frames")),
        "replay said: {replay_err}"
    );
    rec.success("recorder of the replay", Duration::from_secs(60));

    let a_bytes = read_file(&original).unwrap();
    let b_bytes = read_file(&replayed).unwrap();
    let a = messages(&a_bytes, &original, false).unwrap();
    let b = messages(&b_bytes, &replayed, false).unwrap();
    let (ha, hb) = (
        frame_headers(&a, &original).unwrap(),
        frame_headers(&b, &replayed).unwrap(),
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
