//! `splatphys-control` as a process against `splatphys serve --fake` processes: one-shot
//! commands and their exit status, a timeline, the closed-loop follower, and a dead server.
//! Each test uses its own iceoryx2 file prefix (`SPLATPHYS_IOX2_PREFIX`), so tests never see
//! each other's services.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use splatphys_ipc::client::{ClientOptions, Connection};
use splatphys_tests::{
    Exit, IOX_PREFIX_ENV, Proc, bin, fake_server, iox_prefix, json_objects, leftovers,
    service_prefix,
};

/// `splatphys-control --prefix <prefix> <args>` under iceoryx2 file prefix `iox`, output piped.
fn control_process(iox: &str, prefix: &str, args: &[&str]) -> Proc {
    Proc::spawn(
        Command::new(bin("splatphys-control"))
            .args(["--prefix", prefix])
            .args(args)
            .env(IOX_PREFIX_ENV, iox)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped()),
    )
}

/// Runs `splatphys-control --prefix P ARGS` to completion within `timeout`: exit code, stdout,
/// stderr.
fn control(
    iox: &str,
    prefix: &str,
    args: &[&str],
    timeout: Duration,
) -> (Option<i32>, String, String) {
    let Exit { code, out, err } = control_process(iox, prefix, args).wait_exit(timeout);
    (code, out, err)
}

/// An in-test client subscribed to `objects` (frames keep no history: subscribe first).
fn objects_client(iox: &str, prefix: &str) -> Connection {
    // SAFETY: iceoryx2 reads the prefix when a node is created; only this test of this binary
    // creates in-process nodes, and child processes get theirs through `Command::env`.
    unsafe { std::env::set_var(IOX_PREFIX_ENV, iox) };
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
    let p = &service_prefix("oneshot");
    let srv = fake_server(&iox, p, &["--paused", "--fake-dt", "0.01"]);
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
    assert_eq!(json_objects(&out)[0]["effective_step"], 1, "{out}");
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
    let Exit { code, err, .. } = srv.wait_exit(Duration::from_secs(30));
    assert!(code == Some(0) && err.contains("ShutdownCommand"), "{err}");
}

#[test]
fn no_server_exits_with_status_2_and_says_so() {
    let iox = iox_prefix("none");
    let p = &service_prefix("none");
    let (code, _, err) = control(
        &iox,
        p,
        &["--connect-timeout-ms", "300", "pause"],
        Duration::from_secs(5),
    );
    assert_eq!(code, Some(2));
    assert!(
        err.contains(&format!("no splatphys server under prefix `{p}`")),
        "{err}"
    );
}

#[test]
fn timeline_sends_each_event_once_simulated_time_reaches_it() {
    let iox = iox_prefix("tl");
    let p = &service_prefix("tl");
    // Real-time pacing at 60 Hz: 0.4 s of simulated time take 0.4 s.
    let srv = fake_server(&iox, p, &["--paused", "--realtime"]);
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
    let lines = json_objects(&out);
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
    srv.terminate(Duration::from_secs(30)); // clean shutdown: services removed
    assert_eq!(leftovers(&iox), Vec::<String>::new());
}

#[test]
fn follow_pushes_an_object_to_the_target_and_reports_loop_latency() {
    let iox = iox_prefix("follow");
    let p = &service_prefix("follow");
    let srv = fake_server(&iox, p, &["--realtime"]);
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
    let r = &json_objects(&out)[0];
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
    srv.terminate(Duration::from_secs(30)); // clean shutdown: services removed
    assert_eq!(leftovers(&iox), Vec::<String>::new());
}

#[test]
fn killed_server_makes_follow_exit_within_a_second_with_status_2() {
    let iox = iox_prefix("kill");
    let p = &service_prefix("kill");
    let mut srv = fake_server(&iox, p, &["--realtime"]);
    let follower = control_process(
        &iox,
        p,
        &[
            "follow",
            "--object",
            "0",
            "--target",
            "0,0,10",
            "--duration-s",
            "30",
        ],
    );
    std::thread::sleep(Duration::from_millis(700));
    srv.kill9();
    let killed = Instant::now();
    // The deadline only catches a hang; wall-clock speed is not asserted in tests.
    let Exit { code, err, .. } = follower.wait_exit(Duration::from_secs(30));
    assert_eq!(code, Some(2), "{err}");
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
