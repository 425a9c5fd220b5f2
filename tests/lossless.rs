//! The lossless contract across processes (`docs/reference/protocol.md`): a server told to wait for a
//! recorder publishes its first frame once the recorder is ready and stops only once the
//! recorder took the last one, so a short run of a heavy scene records every step, each once,
//! also when the recorder is stopped (SIGSTOP) for a second at the start or at the end; and a
//! recorder that never comes is a clear error, not a silent start. One test, so the process's
//! iceoryx2 file prefix is set once.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use splatphys_ipc::client::{ClientOptions, Connection};
use splatphys_record::read::{Recording, frame_headers};
use splatphys_tests::{
    IOX_PREFIX_ENV, Proc, bin, fake_server, iox_prefix, leftovers, lost_by_recorders,
    service_prefix, wait_until,
};

/// Gaussians per object of the stand-in scene (2 objects): 524,288 Gaussians, a 120 MB scene
/// message, as heavy as a 500k-Gaussian capture.
const GAUSSIANS_PER_OBJECT: &str = "262144";
/// Frames after the initial one: a run of a few frames that takes the server no time, more
/// than a subscriber buffers (4), so a stopped recorder holds the server back.
const FRAMES: u64 = 8;

/// When the recorder is stopped for a second.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Pause {
    Never,
    /// As soon as the first frame is out (the recorder said it was ready).
    AtStart,
    /// Once the server has published its last frame.
    AtEnd,
}

fn recorder(iox: &str, prefix: &str, out: &Path) -> Proc {
    Proc::spawn(
        Command::new(bin("splatphys-record"))
            .args(["record", "--prefix", prefix, "--connect-timeout-s", "60"])
            .arg("--out")
            .arg(out)
            .env(IOX_PREFIX_ENV, iox)
            .stdout(Stdio::null())
            .stderr(Stdio::piped()),
    )
}

/// Frames published so far, as the server's status says.
fn frames_published(status: &mut Connection) -> u64 {
    status
        .poll_status()
        .ok()
        .flatten()
        .map_or(0, |s| s.frames_published)
}

/// One run; returns the (step, frame index) of every frame in the recording.
fn run_once(iox: &str, pause: Pause, out: &Path) -> Vec<(u64, u64)> {
    let prefix = service_prefix("lossless");
    let frames = FRAMES.to_string();
    let server = fake_server(
        iox,
        &prefix,
        &[
            "--fake-gaussians",
            GAUSSIANS_PER_OBJECT,
            "--frames",
            &frames,
            "--wait-for-recorders=1",
            "--wait-timeout-s=60",
        ],
    );
    let rec = recorder(iox, &prefix, out);
    if pause != Pause::Never {
        let mut opts = ClientOptions::new(&prefix);
        (opts.frames, opts.objects, opts.commands) = (false, false, false);
        opts.connect_timeout = Duration::from_secs(60);
        let mut status = Connection::connect(&opts).expect("status");
        let wanted = if pause == Pause::AtStart {
            1
        } else {
            FRAMES + 1
        };
        wait_until("the frames to pause at", Duration::from_secs(60), || {
            frames_published(&mut status) >= wanted
        });
        rec.signal("STOP");
        std::thread::sleep(Duration::from_secs(1));
        rec.signal("CONT");
    }
    let s = server.wait_success(Duration::from_secs(120));
    let r = rec.wait_success(Duration::from_secs(120));
    assert_eq!(lost_by_recorders(&s.err), 0, "{pause:?}: {}", s.err);
    assert!(r.err.contains("ServerShutDown"), "{pause:?}: {}", r.err);
    let recording = Recording::open(out, false).expect("read the recording");
    let headers = frame_headers(recording, out).expect("frames");
    headers.iter().map(|h| (h.step, h.frame_index)).collect()
}

#[test]
fn a_short_run_of_a_heavy_scene_records_every_step_once_even_with_a_paused_recorder() {
    let iox = iox_prefix("lossless");
    // SAFETY: the one test of this binary sets the variable before any iceoryx2 node of this
    // process reads it, always to the same value (the test's status client uses it).
    unsafe { std::env::set_var(IOX_PREFIX_ENV, &iox) };
    let dir = tempfile::tempdir().expect("tempdir");

    // A recorder that never comes: a clear error, not a silent start.
    let server = fake_server(
        &iox,
        &service_prefix("lossless-absent"),
        &["--wait-for-recorders=1", "--wait-timeout-s=0.5"],
    );
    let e = server.wait_exit(Duration::from_secs(30));
    assert_ne!(e.code, Some(0), "{}", e.err);
    assert!(
        e.err.contains("1 lossless subscriber(s)") && e.err.contains("0 did"),
        "{}",
        e.err
    );

    let want: Vec<(u64, u64)> = (0..=FRAMES).map(|i| (i, i)).collect();
    let cases = [Pause::Never; 5]
        .into_iter()
        .chain([Pause::AtStart, Pause::AtEnd]);
    for (i, pause) in cases.enumerate() {
        let out = dir.path().join(format!("run{i}.mcap"));
        let got = run_once(&iox, pause, &out);
        assert_eq!(
            got, want,
            "run {i} ({pause:?}): (step, frame index) recorded"
        );
        std::fs::remove_file(&out).expect("remove the recording");
    }
    assert!(leftovers(&iox).is_empty(), "{:?}", leftovers(&iox));
}
