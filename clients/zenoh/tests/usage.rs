//! The `splatphys-zenoh` command line: its help shows the examples, and bad arguments are
//! refused naming them. The bridge against a live server is an end-to-end test in the
//! workspace's tests/ package (`tests/zenoh_bridge.rs`); this package keeps a test of its own
//! so that `cargo test` builds the binary it runs.

use std::process::Command;

fn bridge(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_splatphys-zenoh"))
        .args(args)
        .output()
        .expect("run splatphys-zenoh")
}

#[test]
fn help_shows_examples_and_the_safety_flags() {
    let out = bridge(&["--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for needle in [
        "Examples:",
        "--allow-commands",
        "--listen",
        "--config",
        "127.0.0.1:7447",
    ] {
        assert!(help.contains(needle), "{needle} missing from:\n{help}");
    }
}

#[test]
fn bad_arguments_are_refused_naming_them() {
    let out = bridge(&["--listen", "tcp/127.0.0.1:0"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--prefix"),
        "the missing prefix is named: {err}"
    );
    let out = bridge(&["--prefix", "splatphys/x", "--connect-timeout-s=-1"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("--connect-timeout-s"), "{err}");
}
