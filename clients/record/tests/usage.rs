//! The `splatphys-record` command line: its help lists the subcommands, and bad arguments are
//! refused naming them. Recording and replaying against servers are end-to-end tests in the
//! workspace's tests/ package; this package keeps a test of its own so that `cargo test` builds
//! the binary they run.

use std::process::{Command, Output};

fn record(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_splatphys-record"))
        .args(args)
        .output()
        .expect("run splatphys-record")
}

#[test]
fn help_lists_record_replay_and_export() {
    let out = record(&["--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for sub in ["record", "replay", "export-objects"] {
        assert!(
            help.lines().any(|l| l.trim_start().starts_with(sub)),
            "{sub} missing from:\n{help}"
        );
    }
}

#[test]
fn bad_arguments_are_refused_naming_them() {
    // Usage errors exit 2 before any file or server is touched.
    let out = record(&["record", "--prefix", "t/usage"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("--out"), "the missing output is named: {err}");
    let out = record(&["replay", "run.mcap", "--lossless-limit-ms", "soon"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--lossless-limit-ms") && err.contains("'soon'"),
        "{err}"
    );
}

#[test]
fn export_of_a_missing_file_fails_naming_it() {
    let dir = std::env::temp_dir().join(format!("splatphys-record-usage-{}", std::process::id()));
    let missing = dir.join("nope.mcap");
    let out = record(&["export-objects", missing.to_str().expect("UTF-8 path")]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("nope.mcap"), "{err}");
}
