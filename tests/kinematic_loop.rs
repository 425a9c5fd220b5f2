//! `clients/python/examples/push_to_target.py` against `splatphys serve
//! scenes/donut_push_finger.toml`: a Python client steers a kinematic finger that pushes the
//! captured donut (rigid in this scene, to stay fast) along a table to a target point, in
//! lockstep with the paused server, and must end within 1 cm of it. The example prints its loop
//! latency and the final error (run with `--nocapture` to see them).
//!
//! Needs `python3` with the `iceoryx2` and `numpy` packages (`clients/python/run_tests.sh`
//! installs them): missing, the test fails under CI (`CI` set) and is skipped elsewhere.

use std::process::{Command, Stdio};
use std::time::Duration;

use splatphys_tests::{
    IOX_PREFIX_ENV, Proc, bin, iox_prefix, leftovers, service_prefix, workspace,
};

fn python_client_available() -> bool {
    Command::new("python3")
        .args(["-c", "import iceoryx2, numpy"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

#[test]
fn a_python_loop_pushes_the_donut_to_a_target_with_a_kinematic_finger() {
    if !python_client_available() {
        assert!(
            std::env::var_os("CI").is_none(),
            "python3 with iceoryx2 and numpy is missing, and CI must run this test"
        );
        eprintln!("skipped: python3 with iceoryx2 and numpy is missing");
        return;
    }
    let iox = iox_prefix("kinloop");
    let prefix = service_prefix("kinloop");
    let root = workspace();
    let server = Proc::spawn(
        Command::new(bin("splatphys"))
            .current_dir(root)
            .args([
                "serve",
                "scenes/donut_push_finger.toml",
                "--paused",
                "--prefix",
            ])
            .arg(&prefix)
            .env(IOX_PREFIX_ENV, &iox)
            .stdout(Stdio::null())
            .stderr(Stdio::piped()),
    );
    let run = Proc::spawn(
        Command::new("python3")
            .current_dir(root)
            .args([
                "clients/python/examples/push_to_target.py",
                "--lockstep",
                "--target",
                "0.25,0.10",
                "--prefix",
            ])
            .arg(&prefix)
            .env(IOX_PREFIX_ENV, &iox)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped()),
    )
    .wait_exit(Duration::from_secs(240));
    println!("{}{}", run.out, run.err);
    let stopped = server.terminate(Duration::from_secs(30));
    assert_eq!(
        run.code,
        Some(0),
        "the loop missed the target: {}{}",
        run.out,
        run.err
    );
    let line = run
        .out
        .lines()
        .find(|l| l.starts_with("final error"))
        .expect("a final error line");
    let mm: f64 = line
        .split_whitespace()
        .nth(2)
        .and_then(|v| v.parse().ok())
        .expect("final error in mm");
    assert!(mm <= 10.0, "{line}");
    assert!(run.out.contains("loop latency"), "{}", run.out);
    assert_eq!(stopped.code, Some(0), "server: {}", stopped.err);
    assert!(leftovers(&iox).is_empty(), "{:?}", leftovers(&iox));
}
