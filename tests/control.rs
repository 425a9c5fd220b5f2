//! `splatphys-control` as a process against `splatphys serve --fake` processes: one-shot
//! commands and their exit status, a timeline, the closed-loop follower, and a dead server.
//! Each test uses its own iceoryx2 file prefix (`SPLATPHYS_IOX2_PREFIX`), so tests never see
//! each other's services.

use std::path::PathBuf;
use std::process::{Child, Command, Output, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use splatphys_ipc::client::{ClientOptions, Connection};

const CONTROL: &str = env!("CARGO_BIN_EXE_splatphys-control");

/// `splatphys` lives in another package: take it from the same target directory, building it
/// once if this test run did not (e.g. `cargo test -p splatphys-control` on a fresh tree).
fn server_bin() -> &'static PathBuf {
    static BIN: OnceLock<PathBuf> = OnceLock::new();
    BIN.get_or_init(|| {
        let dir = PathBuf::from(CONTROL)
            .parent()
            .expect("target dir")
            .to_path_buf();
        let bin = dir.join("splatphys");
        if !bin.exists() {
            let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
            let st = Command::new(cargo)
                .args(["build", "-p", "splatphys-ipc", "--bin", "splatphys"])
                .status()
                .expect("run cargo build for the splatphys binary");
            assert!(st.success(), "building splatphys failed");
        }
        assert!(bin.exists(), "{} missing", bin.display());
        bin
    })
}

/// A child process, stopped with SIGTERM (clean server shutdown, services removed) when
/// dropped, and with SIGKILL if that takes more than 3 s.
struct Proc(Child);
impl Drop for Proc {
    fn drop(&mut self) {
        if let Ok(None) = self.0.try_wait() {
            let _ = Command::new("kill")
                .args(["-TERM", &self.0.id().to_string()])
                .status();
            let t0 = Instant::now();
            while matches!(self.0.try_wait(), Ok(None)) && t0.elapsed() < Duration::from_secs(3) {
                std::thread::sleep(Duration::from_millis(5));
            }
        }
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Files of iceoryx2 prefix `iox` left in /dev/shm or /tmp/iceoryx2 (iceoryx2 keeps one
/// 16-byte `*.global_mgmt` node counter per prefix on purpose).
fn leftovers(iox: &str) -> Vec<String> {
    let mut found = Vec::new();
    for dir in ["/dev/shm", "/tmp/iceoryx2/services", "/tmp/iceoryx2/nodes"] {
        for e in std::fs::read_dir(dir).into_iter().flatten().flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if name.starts_with(iox) && !name.ends_with(".global_mgmt") {
                found.push(format!("{dir}/{name}"));
            }
        }
    }
    found
}

fn iox_prefix(test: &str) -> String {
    format!("spxc_{test}_{}_", std::process::id())
}

fn server(iox: &str, prefix: &str, extra: &[&str]) -> Proc {
    Proc(
        Command::new(server_bin())
            .args(["serve", "--fake", "--prefix", prefix])
            .args(extra)
            .env("SPLATPHYS_IOX2_PREFIX", iox)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn server"),
    )
}

/// Runs `splatphys-control --prefix P ARGS` to completion within `timeout`.
fn control(
    iox: &str,
    prefix: &str,
    args: &[&str],
    timeout: Duration,
) -> (Option<i32>, String, String) {
    let mut child = Command::new(CONTROL)
        .args(["--prefix", prefix])
        .args(args)
        .env("SPLATPHYS_IOX2_PREFIX", iox)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn splatphys-control");
    let o = wait_output(&mut child, timeout);
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// Waits for `child` within `timeout` (killing it and failing the test otherwise) and
/// collects its output.
fn wait_output(child: &mut Child, timeout: Duration) -> Output {
    use std::io::Read;
    let t0 = Instant::now();
    let status = loop {
        if let Some(st) = child.try_wait().expect("try_wait") {
            break st;
        }
        if t0.elapsed() > timeout {
            let _ = child.kill();
            panic!("process did not exit within {timeout:?}");
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let (mut stdout, mut stderr) = (Vec::new(), Vec::new());
    if let Some(mut o) = child.stdout.take() {
        let _ = o.read_to_end(&mut stdout);
    }
    if let Some(mut e) = child.stderr.take() {
        let _ = e.read_to_end(&mut stderr);
    }
    Output {
        status,
        stdout,
        stderr,
    }
}

fn json_lines(out: &str) -> Vec<serde_json::Value> {
    out.lines()
        .filter(|l| l.starts_with('{'))
        .map(|l| serde_json::from_str(l).expect("json line"))
        .collect()
}

/// An in-test client subscribed to `objects` (frames keep no history: subscribe first).
fn objects_client(iox: &str, prefix: &str) -> Connection {
    // SAFETY: iceoryx2 reads the prefix when a node is created; only this test of this binary
    // creates in-process nodes, and child processes get theirs through `Command::env`.
    unsafe { std::env::set_var("SPLATPHYS_IOX2_PREFIX", iox) };
    let mut opts = ClientOptions::new(prefix);
    opts.frames = false;
    opts.commands = false;
    Connection::connect(&opts).expect("connect")
}

/// The objects of the first frame at or after `step`.
fn objects_at(conn: &mut Connection, step: u64) -> Vec<splatphys_ipc::wire::ObjectState> {
    let t0 = Instant::now();
    loop {
        assert!(t0.elapsed() < Duration::from_secs(30), "no objects frame");
        if let Some(s) = conn.recv_objects().expect("objects")
            && s.user_header().step >= step
        {
            return s.payload().to_vec();
        }
        std::thread::sleep(Duration::from_millis(1));
    }
}

#[test]
fn one_shot_commands_print_the_reply_and_exit_non_zero_on_rejection() {
    let iox = iox_prefix("oneshot");
    let p = "t/oneshot";
    let mut srv = server(&iox, p, &["--paused", "--fake-dt", "0.01"]);
    let t = Duration::from_secs(10);

    // By name, accepted; the impulse really moves the object once the server steps.
    let (code, out, err) = control(
        &iox,
        p,
        &["impulse", "--object", "cube1", "--vector", "0,0,2"],
        t,
    );
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(
        out.contains("impulse #1: accepted, takes effect at step 1"),
        "{out}"
    );
    let mut watcher = objects_client(&iox, p);
    let (code, out, _) = control(&iox, p, &["--json", "step", "1"], t);
    assert_eq!(code, Some(0), "{out}");
    assert_eq!(json_lines(&out)[0]["effective_step"], 1, "{out}");
    let objs = objects_at(&mut watcher, 1);
    drop(watcher);
    // 1 kg: Δv = J / m = 2 m/s, then one 0.01 s step of gravity: v = 2 - 9.81 * 0.01 m/s
    // (f32 on the wire, hence 1e-5).
    assert!(
        (objs[1].velocity_m_s[2] - (2.0 - 0.0981)).abs() < 1e-5,
        "{:?}",
        objs[1]
    );
    assert_eq!(
        objs[0].velocity_m_s[2], -0.0981_f32,
        "cube0 untouched: {:?}",
        objs[0]
    );

    // Rejected by the server: exit 1 with the reason.
    let (code, out, _) = control(
        &iox,
        p,
        &["edit-material", "--object", "0", "--nu", "0.7"],
        t,
    );
    assert_eq!(code, Some(1), "{out}");
    assert!(
        out.contains("rejected (OutOfRange): nu = 0.7 outside (-1, 0.5)"),
        "{out}"
    );
    let (code, out, _) = control(
        &iox,
        p,
        &["impulse", "--object", "#9", "--vector", "1,0,0"],
        t,
    );
    assert_eq!(code, Some(1), "{out}");
    assert!(out.contains("UnknownObject"), "{out}");
    let (code, out, _) = control(
        &iox,
        p,
        &["impulse", "--object", "cube0", "--vector=nan,0,0"],
        t,
    );
    assert_eq!(code, Some(1), "{out}");
    assert!(out.contains("NotFinite"), "{out}");

    // Refused locally: unknown name (lists the scene's names), bad vector, bad kind.
    let (code, _, err) = control(
        &iox,
        p,
        &["impulse", "--object", "teapot", "--vector", "0,0,1"],
        t,
    );
    assert_eq!(code, Some(1));
    assert!(
        err.contains("no object named `teapot`") && err.contains("cube0, cube1"),
        "{err}"
    );
    let (code, _, err) = control(
        &iox,
        p,
        &["impulse", "--object", "cube0", "--vector", "0,1"],
        t,
    );
    assert_eq!(code, Some(2), "clap usage error: {err}");
    let (code, _, err) = control(
        &iox,
        p,
        &["set-kind", "--object", "cube0", "--kind", "gas"],
        t,
    );
    assert_eq!(code, Some(1));
    assert!(err.contains("unknown object kind `gas`"), "{err}");

    // Accepted: set-kind by number, set-velocity with a negative vector, material edit, resume.
    for args in [
        &["set-kind", "--object", "1", "--kind", "rigid"][..],
        &["set-velocity", "--object", "cube0", "--vector", "-1,0,0"],
        &[
            "edit-material",
            "--object",
            "cube0",
            "--model",
            "snow",
            "--youngs-modulus-pa",
            "1e5",
        ],
        &["pause"],
        &["resume"],
    ] {
        let (code, out, err) = control(&iox, p, args, t);
        assert_eq!(code, Some(0), "{args:?}: {out}{err}");
        assert!(out.contains("accepted"), "{args:?}: {out}");
    }

    // Shutdown: accepted, and the server exits cleanly.
    let (code, out, _) = control(&iox, p, &["shutdown"], t);
    assert_eq!(code, Some(0), "{out}");
    let o = wait_output(&mut srv.0, Duration::from_secs(30));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success() && err.contains("ShutdownCommand"),
        "{err}"
    );
}

#[test]
fn no_server_exits_with_status_2_and_says_so() {
    let iox = iox_prefix("none");
    let (code, _, err) = control(
        &iox,
        "t/none",
        &["--connect-timeout-ms", "300", "pause"],
        Duration::from_secs(5),
    );
    assert_eq!(code, Some(2));
    assert!(
        err.contains("no splatphys server under prefix `t/none`"),
        "{err}"
    );
}

#[test]
fn timeline_sends_each_event_once_simulated_time_reaches_it() {
    let iox = iox_prefix("tl");
    let p = "t/tl";
    // Real-time pacing at 60 Hz: 0.4 s of simulated time take 0.4 s.
    let srv = server(&iox, p, &["--paused", "--realtime"]);
    let dir = tempfile::tempdir().expect("tempdir");
    let file = dir.path().join("tl.toml");
    std::fs::write(
        &file,
        r#"
        [[event]]            # the server starts paused at t = 0: resume at once
        at_s = 0.0
        command = "resume"
        [[event]]
        at_s = 0.4
        command = "edit-material"
        object = "cube0"
        poisson_ratio = 0.9  # rejected
        [[event]]
        at_s = 0.2
        command = "impulse"
        object = "cube1"
        impulse_n_s = [0, 0, 1]
        "#,
    )
    .expect("write timeline");
    let t0 = Instant::now();
    let (code, out, err) = control(
        &iox,
        p,
        &["--json", "timeline", file.to_str().expect("utf8")],
        Duration::from_secs(10),
    );
    assert_eq!(code, Some(1), "one event is rejected: {out}{err}");
    let lines = json_lines(&out);
    assert_eq!(lines.len(), 3, "{out}");
    // Replies arrive in sending order, which is time order.
    let at: Vec<f64> = lines.iter().map(|l| l["at_s"].as_f64().unwrap()).collect();
    assert_eq!(at, [0.0, 0.2, 0.4], "{out}");
    assert_eq!(lines[0]["accepted"], true);
    assert_eq!(lines[1]["accepted"], true);
    assert_eq!(lines[1]["object"], 1);
    assert_eq!(lines[2]["reject_code"], "OutOfRange");
    for l in &lines {
        let (at, sent) = (
            l["at_s"].as_f64().unwrap(),
            l["sent_at_s"].as_f64().unwrap(),
        );
        // Sent at the first frame at or after its time: within two 1/60 s frames (plus the
        // 0.1 s status period when only the heartbeat had the time).
        assert!(sent >= at && sent <= at + 0.15, "{l}");
    }
    assert!(
        t0.elapsed() >= Duration::from_millis(350),
        "paced by simulated time"
    );
    drop(srv);
    assert_eq!(leftovers(&iox), Vec::<String>::new());
}

#[test]
fn follow_pushes_an_object_to_the_target_and_reports_loop_latency() {
    let iox = iox_prefix("follow");
    let p = "t/follow";
    let srv = server(&iox, p, &["--realtime"]);
    let (code, out, err) = control(
        &iox,
        p,
        &[
            "--json",
            "follow",
            "--object",
            "cube1",
            "--target",
            "1.2,0,10.3",
            "--duration-s",
            "6",
            "--tolerance-m",
            "0.002",
        ],
        Duration::from_secs(15),
    );
    assert_eq!(code, Some(0), "{out}{err}");
    let r = &json_lines(&out)[0];
    assert_eq!(r["stop"], "Settled", "{r}");
    assert_eq!(r["object"], "cube1");
    assert!(r["final_error_m"].as_f64().unwrap() <= 0.002, "{r}");
    assert_eq!(r["rejected"], 0, "{r}");
    let lat = &r["latency"];
    let (n, p50, p99) = (
        lat["count"].as_u64().unwrap(),
        lat["p50_us"].as_f64().unwrap(),
        lat["p99_us"].as_f64().unwrap(),
    );
    // One impulse per 1/60 s frame for over a second of settling, nearly all measured.
    assert!(n >= 60, "{r}");
    // A command takes effect at the next step, published one 16.7 ms frame later in real time.
    assert!(p50 > 0.0 && p50 < 40_000.0 && p99 < 200_000.0, "{r}");
    drop(srv);
    assert_eq!(leftovers(&iox), Vec::<String>::new());
}

#[test]
fn killed_server_makes_follow_exit_within_a_second_with_status_2() {
    let iox = iox_prefix("kill");
    let p = "t/kill";
    let mut srv = server(&iox, p, &["--realtime"]);
    let mut child = Command::new(CONTROL)
        .args([
            "--prefix",
            p,
            "follow",
            "--object",
            "0",
            "--target",
            "0,0,10",
            "--duration-s",
            "30",
        ])
        .env("SPLATPHYS_IOX2_PREFIX", &iox)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    std::thread::sleep(Duration::from_millis(700));
    srv.0.kill().expect("kill -9 server");
    let killed = Instant::now();
    // The deadline only catches a hang; wall-clock speed is not asserted in tests.
    let o = wait_output(&mut child, Duration::from_secs(30));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("is gone: no heartbeat"), "{err}");
    // Load can only delay the detection: never before the 1 s timeout minus one status period.
    assert!(
        killed.elapsed() >= Duration::from_millis(900),
        "declared dead after only {:?}",
        killed.elapsed()
    );
    // The controller removed what the dead server left behind on its way out.
    drop(srv);
    assert_eq!(leftovers(&iox), Vec::<String>::new());
}
