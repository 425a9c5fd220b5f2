//! Multi-process fault tests: `splatphys serve --fake` and `splatphys-probe` clients as real
//! processes, killed with SIGKILL. Each test uses its own iceoryx2 file prefix
//! (`SPLATPHYS_IOX2_PREFIX`) and checks that nothing of it is left in /dev/shm or
//! /tmp/iceoryx2 afterwards (except iceoryx2's persistent 16-byte `*.global_mgmt` node counter).

mod common;

use std::process::Command;
use std::time::{Duration, Instant};

use common::{iox_prefix, json_field, leftovers, probe, server, wait_exit, wait_line};

#[test]
fn killed_server_makes_clients_exit_with_a_clear_message() {
    let iox = iox_prefix("ksrv");
    let mut srv = server(&iox, "t/ksrv", 100);
    let mut p = probe(&iox, "t/ksrv", &[]);
    wait_line(&mut p, "first_frame", Duration::from_secs(10));
    let killed = Instant::now();
    srv.0.kill().expect("kill -9 server");
    let _ = srv.0.wait();
    // The deadline only catches a hang: a loaded CI machine may take well over the 1 s
    // heartbeat timeout to schedule the client (wall-clock speed is not asserted in tests).
    let (code, _out, err, _) = wait_exit(p, Duration::from_secs(30));
    let after_kill = killed.elapsed();
    assert_eq!(code, Some(2), "stderr: {err}");
    assert!(err.contains("is gone: no heartbeat"), "stderr: {err}");
    // Never declared dead before the heartbeat timeout minus one status period (0.1 s):
    // load can only delay the detection, never bring it forward.
    assert!(
        after_kill >= Duration::from_millis(900),
        "declared dead after only {after_kill:?}"
    );
    drop(srv);
    // The client cleaned up the dead server's resources on its way out.
    assert_eq!(leftovers(&iox), Vec::<String>::new());
}

#[test]
fn killed_lossless_client_costs_no_step_and_a_new_client_attaches() {
    let iox = iox_prefix("kcli");
    let srv = server(&iox, "t/kcli", 100);
    let mut a = probe(&iox, "t/kcli", &["--lossless", "--delay-ms", "1"]);
    wait_line(&mut a, "first_frame", Duration::from_secs(10));
    a.0.kill().expect("kill -9 client");
    let _ = a.0.wait();
    drop(a);
    // A new lossless client attaches and receives 500 consecutive frames without a gap.
    let b = probe(&iox, "t/kcli", &["--lossless", "--frames", "500"]);
    let (code, out, err, _) = wait_exit(b, Duration::from_secs(60));
    assert_eq!(code, Some(0), "stderr: {err}");
    assert_eq!(json_field(&out, "frames"), 500, "{out}");
    assert_eq!(json_field(&out, "gaps"), 0, "{out}");
    // Clean shutdown on SIGTERM.
    let pid = srv.0.id().to_string();
    Command::new("kill")
        .args(["-TERM", &pid])
        .status()
        .expect("kill -TERM");
    let (code, _, err, _) = wait_exit(srv, Duration::from_secs(30));
    assert_eq!(code, Some(0), "server stderr: {err}");
    assert!(err.contains("stopped (Signal)"), "server stderr: {err}");
    assert_eq!(leftovers(&iox), Vec::<String>::new());
}

#[test]
fn two_prefixes_never_cross_talk() {
    let iox = iox_prefix("xtalk");
    let s1 = server(&iox, "t/one", 10);
    let s2 = server(&iox, "t/two", 30);
    let p1 = probe(&iox, "t/one", &["--frames", "50"]);
    let p2 = probe(&iox, "t/two", &["--frames", "50"]);
    let (c1, o1, e1, _) = wait_exit(p1, Duration::from_secs(60));
    let (c2, o2, e2, _) = wait_exit(p2, Duration::from_secs(60));
    assert_eq!((c1, c2), (Some(0), Some(0)), "{e1} {e2}");
    // Two objects per fake scene: 20 and 60 Gaussians.
    assert_eq!(json_field(&o1, "scene_gaussians"), 20, "{o1}");
    assert_eq!(json_field(&o2, "scene_gaussians"), 60, "{o2}");
    for s in [s1, s2] {
        Command::new("kill")
            .args(["-TERM", &s.0.id().to_string()])
            .status()
            .expect("kill");
        let (code, _, err, _) = wait_exit(s, Duration::from_secs(30));
        assert_eq!(code, Some(0), "{err}");
    }
    assert_eq!(leftovers(&iox), Vec::<String>::new());
}
