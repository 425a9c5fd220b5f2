//! The `splatphys` command line itself: its help shows an example of every subcommand, and bad
//! arguments are refused naming them. The end-to-end tests of its subcommands are in the
//! workspace's tests/ package; this package keeps a test of its own so that `cargo test` builds
//! the binary they run.

use std::process::{Command, Output};

fn splatphys(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_splatphys"))
        .args(args)
        .output()
        .expect("run splatphys")
}

#[test]
fn help_shows_an_example_of_every_subcommand() {
    let out = splatphys(&["--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(help.contains("Examples:"), "{help}");
    for sub in [
        "run", "serve", "select", "align", "inspect", "uplift", "bench",
    ] {
        let example = |l: &str| l.split_whitespace().take(2).eq(["splatphys", sub]);
        assert!(
            help.lines().any(example),
            "no example of `splatphys {sub}`:\n{help}"
        );
    }
}

#[test]
fn uplift_help_shows_its_examples_and_formats() {
    let out = splatphys(&["uplift", "--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(help.contains("splatphys uplift --ply "), "{help}");
    assert!(
        help.contains("Feature maps: FEATURES/<image stem>.npy"),
        "{help}"
    );
}

#[test]
fn bad_arguments_are_refused_naming_them() {
    // A value that is not a number: a usage error (exit 2) naming the flag and the value.
    let out = splatphys(&["serve", "--frames", "many"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("--frames") && err.contains("'many'"), "{err}");
    // A missing required flag is named too.
    let out = splatphys(&["uplift", "--ply", "scene.ply"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("--cameras"), "{err}");
    // An unknown subcommand.
    let out = splatphys(&["simulate"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("'simulate'"), "{err}");
}
