//! `splatphys serve --fake` (the free-fall stand-in scene: cubes falling, no scene file) and
//! `splatphys-probe` (a client that counts frames and gaps) as processes under a test's iceoryx2
//! file prefix.

use std::process::{Command, Stdio};
use std::time::Duration;

use crate::{IOX_PREFIX_ENV, Proc, bin};

/// `splatphys serve --fake --prefix <prefix> <args>` under iceoryx2 file prefix `iox`; stdout
/// discarded, stderr piped (read it with [`Proc::wait_exit`]).
pub fn fake_server(iox: &str, prefix: &str, args: &[&str]) -> Proc {
    Proc::spawn(
        Command::new(bin("splatphys"))
            .args(["serve", "--fake", "--prefix", prefix])
            .args(args)
            .env(IOX_PREFIX_ENV, iox)
            .stdout(Stdio::null())
            .stderr(Stdio::piped()),
    )
}

/// [`fake_server`] stepping 1 ms of simulated time per frame as fast as it can, with `gaussians`
/// per object (2 objects) and `extra` arguments.
pub fn stepping_server(iox: &str, prefix: &str, gaussians: usize, extra: &[&str]) -> Proc {
    let gaussians = gaussians.to_string();
    let mut args = vec!["--fake-dt", "0.001", "--fake-gaussians", &gaussians];
    args.extend_from_slice(extra);
    fake_server(iox, prefix, &args)
}

/// `splatphys-probe <prefix> <extra>` under iceoryx2 file prefix `iox`, stdout and stderr piped.
/// It prints one JSON line when it stops (see [`crate::json_field`]).
pub fn probe(iox: &str, prefix: &str, extra: &[&str]) -> Proc {
    Proc::spawn(
        Command::new(bin("splatphys-probe"))
            .arg(prefix)
            .args(extra)
            .env(IOX_PREFIX_ENV, iox)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped()),
    )
}

/// SIGTERM the server and check it stops cleanly (exit 0, "stopped (Signal)"); returns its
/// stderr.
///
/// # Panics
/// When it does not stop within 30 s or not cleanly.
pub fn stop_server(srv: Proc) -> String {
    let e = srv.terminate(Duration::from_secs(30));
    assert_eq!(e.code, Some(0), "server stderr: {}", e.err);
    assert!(
        e.err.contains("stopped (Signal)"),
        "server stderr: {}",
        e.err
    );
    e.err
}

/// The number in the server's final stderr line "..., N lost by recorders".
///
/// # Panics
/// When there is no such line.
pub fn lost_by_recorders(server_stderr: &str) -> u64 {
    let line = server_stderr
        .lines()
        .rfind(|l| l.contains("lost by recorders"))
        .unwrap_or_else(|| panic!("no summary line in server stderr: {server_stderr}"));
    let before = line.trim_end_matches(" lost by recorders");
    before
        .rsplit(' ')
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("cannot read the lost count in {line:?}"))
}
