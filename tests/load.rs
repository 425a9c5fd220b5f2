//! Load and fault tests, each with real processes (`splatphys serve --fake` and
//! `splatphys-probe`) under its own iceoryx2 file prefix, ending with a check that nothing of
//! that prefix is left in /dev/shm or /tmp/iceoryx2:
//! - a lossless recorder with random 50 ms stalls loses no frame over 2,000 frames;
//! - a recorder stopped with SIGSTOP does not freeze the server;
//! - kill -9 of a renderer, a recorder and a controller mid-run costs the server no step (a
//!   lossless watcher sees every frame), and new clients of each kind attach and receive.
//!
//! CI runs these on a loaded 2-core machine: deadlines (30-60 s) only catch hangs, and the
//! asserts are on counts, gaps, exit codes and messages, never on wall-clock speed.

use std::time::Duration;

use splatphys_tests::{
    Exit, iox_prefix, json_field, last_line, leftovers, lost_by_recorders, probe, service_prefix,
    stepping_server, stop_server, wait_for,
};

/// Longest wait on a full lossless subscriber given to servers whose lossless clients must lose
/// nothing: the server's default, 2 s, written out so the tests do not depend on it.
const PATIENT_LIMIT_MS: &str = "2000";

#[test]
fn lossless_recorder_with_random_50ms_stalls_loses_no_frame_in_2000() {
    let iox = iox_prefix("stall");
    let prefix = service_prefix("stall");
    let srv = stepping_server(
        &iox,
        &prefix,
        100,
        &["--lossless-limit-ms", PATIENT_LIMIT_MS],
    );
    // About 2 % of frames are followed by a 50 ms stall (seeded: the same stalls every run).
    let rec = probe(
        &iox,
        &prefix,
        &[
            "--lossless",
            "--frames",
            "2000",
            "--stall-ms",
            "50",
            "--stall-probability",
            "0.02",
            "--seed",
            "5",
        ],
    );
    let Exit { code, out, err } = rec.wait_exit(Duration::from_secs(120));
    assert_eq!(code, Some(0), "stderr: {err}");
    assert_eq!(json_field(&out, "frames"), 2000, "{out}");
    assert_eq!(json_field(&out, "gaps"), 0, "{out}");
    assert!(json_field(&out, "stalls") >= 10, "too few stalls: {out}");
    let err = stop_server(srv);
    assert_eq!(lost_by_recorders(&err), 0, "server stderr: {err}");
    assert_eq!(leftovers(&iox), Vec::<String>::new());
}

#[test]
fn sigstopped_recorder_does_not_freeze_the_server() {
    let iox = iox_prefix("sigstop");
    let prefix = service_prefix("sigstop");
    // The default lossless limit (2 s): the server must give up on the stopped recorder.
    let srv = stepping_server(&iox, &prefix, 100, &[]);
    let mut rec = probe(&iox, &prefix, &["--lossless"]);
    let rec_lines = rec.stdout_lines();
    wait_for(&rec_lines, "first_frame", Duration::from_secs(30));
    rec.signal("STOP");

    // While the recorder is stopped, a renderer sees 300 frames: the server keeps stepping.
    let viewer = probe(&iox, &prefix, &["--frames", "300"]);
    let Exit { code, out, err } = viewer.wait_exit(Duration::from_secs(60));
    assert_eq!(code, Some(0), "stderr: {err}");
    assert_eq!(json_field(&out, "frames"), 300, "{out}");
    let span = json_field(&out, "last") - json_field(&out, "first");
    assert!(span >= 299, "the server advanced only {span} frames: {out}");

    // The recorder continues after SIGCONT, and then dies.
    rec.signal("CONT");
    std::thread::sleep(Duration::from_millis(200));
    rec.kill9();
    drop(rec);

    // A new recorder attaches and gets 200 consecutive frames.
    let rec2 = probe(&iox, &prefix, &["--lossless", "--frames", "200"]);
    let Exit { code, out, err } = rec2.wait_exit(Duration::from_secs(60));
    assert_eq!(code, Some(0), "stderr: {err}");
    assert_eq!(json_field(&out, "gaps"), 0, "{out}");

    let err = stop_server(srv);
    // The server dropped frames for the stopped recorder rather than wait, and said so.
    assert!(lost_by_recorders(&err) > 0, "server stderr: {err}");
    assert_eq!(leftovers(&iox), Vec::<String>::new());
}

#[test]
fn killed_renderer_recorder_and_controller_cost_no_step() {
    let iox = iox_prefix("kill3");
    let prefix = service_prefix("kill3");
    let srv = stepping_server(
        &iox,
        &prefix,
        100,
        &["--lossless-limit-ms", PATIENT_LIMIT_MS],
    );
    // A lossless watcher for the whole run: every frame the server publishes, without a gap.
    let mut watcher = probe(&iox, &prefix, &["--lossless"]);
    let watched = watcher.stdout_lines();
    wait_for(&watched, "first_frame", Duration::from_secs(30));

    for (kind, args) in [
        ("renderer", &[][..]),
        ("recorder", &["--lossless", "--delay-ms", "1"][..]),
        ("controller", &["--commands-hz", "500", "--object", "1"][..]),
    ] {
        let mut p = probe(&iox, &prefix, args);
        let lines = p.stdout_lines();
        wait_for(&lines, "first_frame", Duration::from_secs(30));
        std::thread::sleep(Duration::from_millis(300)); // mid-run: frames and commands flowing
        p.kill9();
        eprintln!("killed the {kind}");
    }

    // New clients of each kind attach and receive.
    let renderer = probe(&iox, &prefix, &["--frames", "100"]);
    let recorder = probe(&iox, &prefix, &["--lossless", "--frames", "300"]);
    let controller = probe(
        &iox,
        &prefix,
        &["--commands-hz", "200", "--object", "1", "--replies", "20"],
    );
    let Exit { code, out, err } = renderer.wait_exit(Duration::from_secs(60));
    assert_eq!(code, Some(0), "new renderer: {err}");
    assert_eq!(json_field(&out, "frames"), 100, "new renderer: {out}");
    let Exit { code, out, err } = recorder.wait_exit(Duration::from_secs(60));
    assert_eq!(code, Some(0), "new recorder: {err}");
    assert_eq!(json_field(&out, "frames"), 300, "new recorder: {out}");
    assert_eq!(json_field(&out, "gaps"), 0, "new recorder: {out}");
    let Exit { code, out, err } = controller.wait_exit(Duration::from_secs(60));
    assert_eq!(code, Some(0), "new controller: {err}");
    assert!(
        json_field(&out, "commands_accepted") >= 20,
        "new controller: {out}"
    );
    assert_eq!(
        json_field(&out, "commands_rejected"),
        0,
        "new controller: {out}"
    );

    stop_server(srv);
    // The watcher saw the server shut down and every frame up to then.
    let Exit { code, err, .. } = watcher.wait_exit(Duration::from_secs(30));
    let summary = last_line(&watched, Duration::from_secs(10));
    assert_eq!(code, Some(0), "watcher: {err}");
    assert!(summary.contains("\"reason\":\"shutdown\""), "{summary}");
    assert_eq!(json_field(&summary, "gaps"), 0, "{summary}");
    // It was connected all along the new recorder's 300 frames.
    assert!(json_field(&summary, "frames") >= 300, "{summary}");
    assert_eq!(leftovers(&iox), Vec::<String>::new());
}
