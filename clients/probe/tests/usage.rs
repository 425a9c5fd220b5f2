//! The `splatphys-probe` command line: its help lists the load options, and bad arguments are
//! refused naming them. The probe's runs against servers are end-to-end tests in the workspace's
//! tests/ package; this package keeps a test of its own so that `cargo test` builds the binary
//! they run.

use std::process::{Command, Output};

fn probe(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_splatphys-probe"))
        .args(args)
        .output()
        .expect("run splatphys-probe")
}

#[test]
fn help_lists_the_prefix_and_the_load_options() {
    let out = probe(&["--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for option in [
        "<PREFIX>",
        "--lossless",
        "--frames",
        "--stall-ms",
        "--stall-probability",
        "--commands-hz",
        "--replies",
    ] {
        assert!(help.contains(option), "{option} missing from:\n{help}");
    }
}

#[test]
fn bad_arguments_are_refused_naming_them() {
    // Usage errors exit 2 before any connection is tried.
    let out = probe(&["t/usage", "--stall-probability", "often"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--stall-probability") && err.contains("'often'"),
        "{err}"
    );
    let out = probe(&["--lossless"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("<PREFIX>"),
        "the missing prefix is named: {err}"
    );
}
