//! The recording under faults, every process real: a recorder stopped by SIGINT while it is the
//! bottleneck leaves a whole file; a recording across two resets holds, and replays, all three
//! scene generations; a `splatphys run` whose recorder was held up past the backpressure limit
//! exits non-zero and says how many steps the file lacks.
//!
//! Deadlines only catch hangs; nothing here depends on wall-clock speed except the last test,
//! which holds the recorder still (SIGSTOP) for longer than the 2 s limit.

use std::collections::BTreeSet;
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::OnceLock;
use std::time::Duration;

use splatphys_ipc::client::{ClientOptions, Connection};
use splatphys_ipc::command::{Command as SimCommand, Reply};
use splatphys_ipc::wire::{FrameHeader, SceneHeader};
use splatphys_record::channels::{FRAME, OBJECTS, SCENE};
use splatphys_record::read::{frame_headers, read_all, verify};
use splatphys_tests::{
    IOX_PREFIX_ENV, Proc, bin, iox_prefix, service_prefix, stepping_server, stop_server, wait_until,
};

/// One iceoryx2 file prefix for this binary (in-process clients read it from the environment).
fn iox() -> &'static str {
    static IOX: OnceLock<String> = OnceLock::new();
    IOX.get_or_init(|| {
        let iox = iox_prefix("recf");
        // SAFETY: set once, before any iceoryx2 node of this process exists, to one value.
        unsafe { std::env::set_var(IOX_PREFIX_ENV, &iox) };
        iox
    })
}

/// `splatphys-record record --prefix <prefix> --out <out>`, stderr piped.
fn recorder(prefix: &str, out: &Path) -> Proc {
    Proc::spawn(
        Command::new(bin("splatphys-record"))
            .args([
                "record",
                "--prefix",
                prefix,
                "--connect-timeout-s",
                "30",
                "--out",
            ])
            .arg(out)
            .env(IOX_PREFIX_ENV, iox())
            .stderr(Stdio::piped()),
    )
}

/// Connects to `prefix` and waits until `n` clients subscribe to its frames.
fn connect_when_subscribed(prefix: &str, n: u32) -> Connection {
    let mut opts = ClientOptions::new(prefix);
    opts.frames = false;
    opts.objects = false;
    opts.connect_timeout = Duration::from_secs(30);
    let mut conn = Connection::connect(&opts).expect("connect");
    wait_until("the recorder subscribes", Duration::from_secs(60), || {
        conn.poll_status()
            .expect("status")
            .is_some_and(|s| s.subscriber_count >= n)
    });
    conn
}

fn accepted(conn: &mut Connection, c: &SimCommand) {
    let r = conn.command(c, Duration::from_secs(30)).expect("command");
    assert!(matches!(r, Reply::Accepted { .. }), "{c:?}: {r:?}");
}

#[test]
fn a_recorder_interrupted_while_it_is_the_bottleneck_leaves_a_whole_file() {
    let prefix = service_prefix("recf-int");
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("int.mcap");
    // 2 x 250k Gaussians, as fast as the server can: 26 MB a frame, the recorder is the slow one.
    let server = stepping_server(iox(), &prefix, 250_000, &["--lossless-limit-ms", "2000"]);
    let rec = recorder(&prefix, &out);
    drop(connect_when_subscribed(&prefix, 1));
    std::thread::sleep(Duration::from_secs(3));
    rec.signal("INT");
    let e = rec.wait_exit(Duration::from_secs(60));
    assert_eq!(e.code, Some(0), "recorder: {}", e.err);
    stop_server(server);
    verify(&out).expect("the file is whole: summary, CRCs, end magic");
    assert_in_frame_order(&out);
    let frames = frame_headers(
        read_all(&out, false).expect("read").into_iter().map(Ok),
        &out,
    )
    .expect("frames");
    assert!(!frames.is_empty(), "{}", e.err);
    assert!(
        frames
            .windows(2)
            .all(|w| w[1].frame_index == w[0].frame_index + 1),
        "no gap while the server waited for the recorder"
    );
}

/// Checks the file is in frame order: a generation's scene before its frames and after the
/// previous generation's; objects after their own frame and before the next one (objects whose
/// frame was not recorded, such as those of the frame in flight at an interrupt, keep their
/// place in the order).
fn assert_in_frame_order(path: &Path) {
    let mut generation = None;
    let mut last_frame: Option<FrameHeader> = None;
    let mut last_objects = None;
    for m in read_all(path, false).expect("read") {
        match m.topic.as_str() {
            SCENE => {
                let g = bytemuck_read::<SceneHeader>(&m.data).scene_generation;
                assert!(
                    generation.is_none_or(|p| g > p),
                    "scene {g} after {generation:?}"
                );
                assert!(
                    last_frame.is_none_or(|f| f.scene_generation < g),
                    "scene {g} after a frame of its own generation"
                );
                generation = Some(g);
            }
            FRAME => {
                let h: FrameHeader = bytemuck_read(&m.data);
                assert_eq!(
                    Some(h.scene_generation),
                    generation,
                    "frame before its scene"
                );
                assert!(
                    last_objects.is_none_or(|o| o < h.frame_index),
                    "frame {} after objects of frame {last_objects:?}",
                    h.frame_index
                );
                last_frame = Some(h);
            }
            OBJECTS => {
                let h: FrameHeader = bytemuck_read(&m.data);
                assert!(
                    last_frame.is_some_and(|f| f.frame_index <= h.frame_index)
                        && last_objects.is_none_or(|o| o < h.frame_index),
                    "objects of frame {} after frame {:?}",
                    h.frame_index,
                    last_frame.map(|f| f.frame_index)
                );
                last_objects = Some(h.frame_index);
            }
            _ => {}
        }
    }
}

/// (generation, step) of every frame, and the generations of the scenes, in file order.
fn generations(path: &Path) -> (Vec<(u32, u64)>, Vec<u32>) {
    assert_in_frame_order(path);
    let msgs = read_all(path, false).expect("read");
    let frames = msgs
        .iter()
        .filter(|m| m.topic == FRAME)
        .map(|m| {
            let h: FrameHeader = bytemuck_read(&m.data);
            (h.scene_generation, h.step)
        })
        .collect();
    let scenes = msgs
        .iter()
        .filter(|m| m.topic == SCENE)
        .map(|m| bytemuck_read::<SceneHeader>(&m.data).scene_generation)
        .collect();
    (frames, scenes)
}

fn bytemuck_read<T: bytemuck::Pod>(data: &[u8]) -> T {
    bytemuck::pod_read_unaligned(&data[..size_of::<T>()])
}

#[test]
fn two_resets_while_recording_are_recorded_and_replayed_with_every_generation() {
    let prefix = service_prefix("recf-reset");
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("resets.mcap");
    let server = stepping_server(iox(), &prefix, 200, &["--lossless-limit-ms", "2000"]);
    let rec = recorder(&prefix, &out);
    let mut conn = connect_when_subscribed(&prefix, 1);
    for _ in 0..2 {
        std::thread::sleep(Duration::from_millis(300));
        accepted(&mut conn, &SimCommand::Reset);
    }
    std::thread::sleep(Duration::from_millis(300));
    accepted(&mut conn, &SimCommand::Shutdown);
    drop(conn);
    rec.wait_success(Duration::from_secs(60));
    let _ = server.wait_exit(Duration::from_secs(30));

    let (frames, scenes) = generations(&out);
    assert_eq!(scenes, [0, 1, 2], "one scene per generation, in order");
    for g in 0..3 {
        let steps: Vec<u64> = frames.iter().filter(|f| f.0 == g).map(|f| f.1).collect();
        assert!(steps.len() > 1, "generation {g}: {} frames", steps.len());
        assert!(
            steps.windows(2).all(|w| w[1] == w[0] + 1),
            "generation {g}: steps in order without a gap"
        );
        if g > 0 {
            assert_eq!(steps[0], 0, "a reset starts generation {g} at step 0");
        }
    }
    assert!(
        frames.windows(2).all(|w| w[1].0 >= w[0].0),
        "frames in generation order"
    );

    // Replayed onto a fresh prefix, a second recorder gets the same generations and steps.
    let replayed_prefix = service_prefix("recf-replay");
    let replayed = dir.path().join("replayed.mcap");
    let rec2 = recorder(&replayed_prefix, &replayed);
    let out_s = out.display().to_string();
    let replay = Proc::spawn(
        Command::new(bin("splatphys-record"))
            .args(["replay", &out_s, "--prefix", &replayed_prefix, "--fast"])
            .args(["--wait-for-subscribers", "1", "--wait-timeout-s", "60"])
            .env(IOX_PREFIX_ENV, iox())
            .stderr(Stdio::piped()),
    );
    replay.wait_success(Duration::from_secs(120));
    rec2.wait_success(Duration::from_secs(60));
    assert_eq!(generations(&replayed), (frames, scenes));
}

/// Pids of the children of `parent` running the program `name` (by its argv[0], so a child
/// forked but not yet exec'd is not taken for it).
fn children_running(parent: u32, name: &str) -> Vec<u32> {
    let Ok(dir) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    dir.filter_map(Result::ok)
        .filter_map(|e| e.file_name().to_str()?.parse::<u32>().ok())
        .filter(|pid| {
            let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
            // pid (comm) state ppid ...
            let ppid = stat
                .rsplit_once(") ")
                .and_then(|(_, rest)| rest.split_whitespace().nth(1)?.parse().ok());
            let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
            let argv0 = cmdline.split(|b| *b == 0).next().unwrap_or_default();
            ppid == Some(parent)
                && Path::new(std::str::from_utf8(argv0).unwrap_or("")).ends_with(name)
        })
        .collect()
}

/// `splatphys run --duration-s <duration_s> --out <out>` on the built-in scene, stderr piped.
fn run_job(out: &Path, duration_s: &str) -> Proc {
    Proc::spawn(
        Command::new(bin("splatphys"))
            .args(["run", "--duration-s", duration_s, "--out"])
            .arg(out)
            .env(IOX_PREFIX_ENV, iox())
            .stdout(Stdio::null())
            .stderr(Stdio::piped()),
    )
}

#[test]
fn a_run_whose_recording_lost_frames_fails_and_says_so() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("run");
    let run = run_job(&out, "8");
    let mut recorder = Vec::new();
    wait_until(
        "the run starts its recorder",
        Duration::from_secs(60),
        || {
            recorder = children_running(run.id(), "splatphys-record");
            !recorder.is_empty()
        },
    );
    let pid = recorder[0].to_string();
    std::thread::sleep(Duration::from_secs(2));
    // Held still for longer than the server's 2 s lossless limit: the server drops frames.
    let signal = |s: &str| {
        let ok = Command::new("kill").args([s, &pid]).status().expect("kill");
        assert!(ok.success(), "kill {s} {pid}");
    };
    signal("-STOP");
    std::thread::sleep(Duration::from_secs(4));
    signal("-CONT");
    let e = run.wait_exit(Duration::from_secs(300));
    assert_ne!(
        e.code,
        Some(0),
        "a run that lost frames must fail: {}",
        e.err
    );
    assert!(e.err.contains("the recording lost"), "{}", e.err);
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("summary.json")).expect("summary.json"),
    )
    .expect("json");
    let lost = summary["frames_lost_by_recorder"].as_u64().expect("lost");
    let recorded = summary["frames_recorded"].as_u64().expect("recorded");
    assert!(lost > 0, "{summary}");
    // The counts come from the file: the steps it holds, and the rest of 0..=last.
    let steps: BTreeSet<u64> = frame_headers(
        read_all(&out.join("run.mcap"), true)
            .expect("read")
            .into_iter()
            .map(Ok),
        &out,
    )
    .expect("frames")
    .iter()
    .map(|h| h.step)
    .collect();
    assert_eq!(steps.len() as u64, recorded);
}

#[test]
fn an_interrupted_run_stops_its_processes_and_keeps_what_it_did() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("run");
    let run = run_job(&out, "60");
    wait_until(
        "the run starts its recorder",
        Duration::from_secs(60),
        || !children_running(run.id(), "splatphys-record").is_empty(),
    );
    std::thread::sleep(Duration::from_secs(3));
    run.signal("TERM");
    let e = run.wait_exit(Duration::from_secs(60));
    assert_ne!(
        e.code,
        Some(0),
        "an interrupted run is not a success: {}",
        e.err
    );
    assert!(e.err.contains("interrupted at step"), "{}", e.err);
    // The server stopped on SIGTERM, the recorder finished a whole file, the summary was written
    // and counts what the file holds (nothing lost).
    verify(&out.join("run.mcap")).expect("a whole recording");
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("summary.json")).expect("summary.json"),
    )
    .expect("json");
    assert_eq!(summary["frames_lost_by_recorder"], 0, "{summary}");
    assert!(summary["frames_recorded"].as_u64().expect("recorded") > 0);
    assert!(out.join("objects.csv").exists());
}
