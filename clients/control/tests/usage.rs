//! The `splatphys-control` command line: its help shows an example of every command and the exit
//! statuses, and bad arguments are refused naming them. Commands against servers are end-to-end
//! tests in the workspace's tests/ package; this package keeps a test of its own so that
//! `cargo test` builds the binary they run.

use std::process::{Command, Output};

fn control(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_splatphys-control"))
        .args(args)
        .output()
        .expect("run splatphys-control")
}

#[test]
fn help_shows_an_example_of_every_command_and_the_exit_statuses() {
    let out = control(&["--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for command in [
        "impulse",
        "set-velocity",
        "edit-material",
        "set-kind",
        "pause",
        "step",
        "timeline",
        "follow",
    ] {
        let example = |l: &str| {
            let words: Vec<&str> = l.split_whitespace().collect();
            words.starts_with(&["splatphys-control", "--prefix"]) && words.get(3) == Some(&command)
        };
        assert!(
            help.lines().any(example),
            "no example of {command}:\n{help}"
        );
    }
    assert!(help.contains("Exit status: 0 accepted"), "{help}");
}

#[test]
fn bad_arguments_are_refused_naming_them() {
    // Usage errors exit 2 before any connection is tried.
    let out = control(&["--connect-timeout-ms", "soon", "pause"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--connect-timeout-ms") && err.contains("'soon'"),
        "{err}"
    );
    let out = control(&["impulse", "--vector", "0,0,1"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--object"),
        "the missing object is named: {err}"
    );
}
