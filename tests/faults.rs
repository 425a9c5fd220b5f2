//! Multi-process fault tests: `splatphys serve --fake` and `splatphys-probe` clients as real
//! processes, killed with SIGKILL. Each test uses its own iceoryx2 file prefix
//! (`SPLATPHYS_IOX2_PREFIX`) and checks that nothing of it is left in /dev/shm or
//! /tmp/iceoryx2 afterwards (except iceoryx2's persistent 16-byte `*.global_mgmt` node counter).

use std::time::{Duration, Instant};

use splatphys_tests::{
    Exit, iox_prefix, json_field, leftovers, probe, service_prefix, stepping_server, stop_server,
};

#[test]
fn killed_server_makes_clients_exit_with_a_clear_message() {
    let iox = iox_prefix("ksrv");
    let prefix = service_prefix("ksrv");
    let mut srv = stepping_server(&iox, &prefix, 100, &[]);
    let mut p = probe(&iox, &prefix, &[]);
    p.wait_line("first_frame", Duration::from_secs(10));
    let killed = Instant::now();
    srv.kill9();
    // The deadline only catches a hang: a loaded CI machine may take well over the 1 s
    // heartbeat timeout to schedule the client (wall-clock speed is not asserted in tests).
    let Exit { code, err, .. } = p.wait_exit(Duration::from_secs(30));
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
    let prefix = service_prefix("kcli");
    let srv = stepping_server(&iox, &prefix, 100, &[]);
    let mut a = probe(&iox, &prefix, &["--lossless", "--delay-ms", "1"]);
    a.wait_line("first_frame", Duration::from_secs(10));
    a.kill9();
    drop(a);
    // A new lossless client attaches and receives 500 consecutive frames without a gap.
    let b = probe(&iox, &prefix, &["--lossless", "--frames", "500"]);
    let Exit { code, out, err } = b.wait_exit(Duration::from_secs(60));
    assert_eq!(code, Some(0), "stderr: {err}");
    assert_eq!(json_field(&out, "frames"), 500, "{out}");
    assert_eq!(json_field(&out, "gaps"), 0, "{out}");
    // Clean shutdown on SIGTERM (exit 0, "stopped (Signal)").
    stop_server(srv);
    assert_eq!(leftovers(&iox), Vec::<String>::new());
}

#[test]
fn two_prefixes_never_cross_talk() {
    let iox = iox_prefix("xtalk");
    let (one, two) = (service_prefix("one"), service_prefix("two"));
    let s1 = stepping_server(&iox, &one, 10, &[]);
    let s2 = stepping_server(&iox, &two, 30, &[]);
    let p1 = probe(&iox, &one, &["--frames", "50"]);
    let p2 = probe(&iox, &two, &["--frames", "50"]);
    let Exit {
        code: c1,
        out: o1,
        err: e1,
    } = p1.wait_exit(Duration::from_secs(60));
    let Exit {
        code: c2,
        out: o2,
        err: e2,
    } = p2.wait_exit(Duration::from_secs(60));
    assert_eq!((c1, c2), (Some(0), Some(0)), "{e1} {e2}");
    // Two objects per fake scene: 20 and 60 Gaussians.
    assert_eq!(json_field(&o1, "scene_gaussians"), 20, "{o1}");
    assert_eq!(json_field(&o2, "scene_gaussians"), 60, "{o2}");
    for s in [s1, s2] {
        let Exit { code, err, .. } = s.terminate(Duration::from_secs(30));
        assert_eq!(code, Some(0), "{err}");
    }
    assert_eq!(leftovers(&iox), Vec::<String>::new());
}
