//! The server against the real simulation, as separate processes: the commands that used to
//! end or stall a server are refused with a reason and it keeps answering; SIGTERM ends it
//! within 2 s even in the middle of a long frame, leaving nothing in /dev/shm.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use splatphys_tests::{
    Exit, IOX_PREFIX_ENV, Proc, bin, iox_prefix, leftovers, service_prefix, stop_server, wait_until,
};

/// A scene file with one 0.52 kg jelly ball (r = 5 cm, E = 2e5 Pa), no gravity, never asleep,
/// at `frame_rate_hz`.
fn ball_scene(dir: &Path, frame_rate_hz: f64) -> std::path::PathBuf {
    let path = dir.join("ball.toml");
    std::fs::write(
        &path,
        format!(
            r#"[simulation]
method = "com"
duration_s = 10000.0
frame_rate_hz = {frame_rate_hz}
grid_dx_m = 0.01
gravity_m_s2 = [0.0, 0.0, 0.0]
sleep = false

[[object]]
name = "ball"
shape = {{ sphere = {{ center_m = [0.0, 0.0, 0.2], radius_m = 0.05 }} }}
material = {{ model = "jelly", youngs_modulus_pa = 2e5, poisson_ratio = 0.3, density_kg_m3 = 1000.0 }}
"#
        ),
    )
    .expect("write scene");
    path
}

fn serve(iox: &str, prefix: &str, scene: &Path, extra: &[&str]) -> Proc {
    Proc::spawn(
        Command::new(bin("splatphys"))
            .arg("serve")
            .arg(scene)
            .args(["--prefix", prefix])
            .args(extra)
            .env(IOX_PREFIX_ENV, iox)
            .stdout(Stdio::null())
            .stderr(Stdio::piped()),
    )
}

/// `splatphys-control --prefix <prefix> <args>`: (exit code, stdout + stderr).
fn control(iox: &str, prefix: &str, args: &[&str]) -> (Option<i32>, String) {
    let p = Proc::spawn(
        Command::new(bin("splatphys-control"))
            .args(["--prefix", prefix, "--reply-timeout-ms", "3000"])
            .args(args)
            .env(IOX_PREFIX_ENV, iox)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped()),
    );
    let Exit { code, out, err } = p.wait_exit(Duration::from_secs(60));
    (code, format!("{out}{err}"))
}

#[test]
fn commands_that_used_to_end_or_stall_the_server_are_refused_and_it_keeps_answering() {
    let iox = iox_prefix("hard");
    let prefix = service_prefix("hard");
    let dir = tempfile::tempdir().expect("tempdir");
    let srv = serve(&iox, &prefix, &ball_scene(dir.path(), 30.0), &["--paused"]);

    // E = 1e39 Pa overflows f32; it used to be accepted and end the server one frame later.
    let (code, out) = control(
        &iox,
        &prefix,
        &[
            "edit-material",
            "--object",
            "ball",
            "--youngs-modulus-pa",
            "1e39",
        ],
    );
    assert_eq!(code, Some(1), "{out}");
    assert!(out.contains("youngs_modulus_pa = 1e39"), "{out}");
    // 1000 N s at a lever arm of 1 km: the spin alone would be ~1e7 m/s at the rim; it used to
    // be accepted and leave the server stepping toward dt -> 0.
    let (code, out) = control(
        &iox,
        &prefix,
        &[
            "impulse", "--object", "ball", "--vector", "1000,0,0", "--point", "1000,0,0",
        ],
    );
    assert_eq!(code, Some(1), "{out}");
    assert!(out.contains("the limit is 100 m/s"), "{out}");
    // What a real object can take is accepted, and the server steps and answers.
    let (code, out) = control(
        &iox,
        &prefix,
        &[
            "edit-material",
            "--object",
            "ball",
            "--youngs-modulus-pa",
            "1e6",
        ],
    );
    assert_eq!(code, Some(0), "{out}");
    let (code, out) = control(
        &iox,
        &prefix,
        &["impulse", "--object", "ball", "--vector", "0.5,0,0"],
    );
    assert_eq!(code, Some(0), "{out}");
    let (code, out) = control(&iox, &prefix, &["step", "3"]);
    assert_eq!(code, Some(0), "{out}");
    let (code, out) = control(&iox, &prefix, &["pause"]);
    assert_eq!(code, Some(0), "{out}");
    let (code, out) = control(&iox, &prefix, &["--json", "reset"]);
    assert_eq!(code, Some(0), "{out}");
    assert!(
        out.contains("\"generation\":1"),
        "a reset names the new generation: {out}"
    );
    stop_server(srv);
    assert_eq!(leftovers(&iox), Vec::<String>::new());
}

#[test]
fn sigterm_ends_the_server_within_2_s_in_the_middle_of_a_long_frame() {
    let iox = iox_prefix("term");
    let prefix = service_prefix("term");
    let dir = tempfile::tempdir().expect("tempdir");
    // One frame is 100 s of simulated time: hundreds of thousands of substeps (minutes).
    let srv = serve(&iox, &prefix, &ball_scene(dir.path(), 0.01), &[]);
    // Its services exist once it published frame 0; a second later it is deep inside frame 1.
    wait_until("the server's services", Duration::from_secs(60), || {
        !leftovers(&iox).is_empty()
    });
    std::thread::sleep(Duration::from_secs(1));
    let t0 = Instant::now();
    srv.signal("TERM");
    let Exit { code, err, .. } = srv.wait_exit(Duration::from_secs(60));
    let took = t0.elapsed();
    assert_eq!(code, Some(0), "{err}");
    assert!(err.contains("stopped (Signal) at step 0,"), "{err}");
    assert!(took < Duration::from_secs(2), "SIGTERM took {took:?}");
    assert_eq!(leftovers(&iox), Vec::<String>::new());
}
