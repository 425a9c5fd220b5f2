//! `splatphys-bench --help`: every benchmark listed, with examples (and so that `cargo test`
//! builds this package's binary for the workspace's end-to-end tests).

use std::process::Command;

#[test]
fn help_lists_every_benchmark_with_examples() {
    let out = Command::new(env!("CARGO_BIN_EXE_splatphys-bench"))
        .arg("--help")
        .output()
        .expect("run splatphys-bench");
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{help}");
    assert!(help.contains("Examples:"), "{help}");
    for bench in [
        "mpm",
        "ipc",
        "compare",
        "stability",
        "subsets",
        "realtime",
        "sag",
        "contact",
        "soak",
    ] {
        assert!(
            help.lines()
                .any(|l| l.split_whitespace().next() == Some(bench)),
            "`{bench}` missing from:\n{help}"
        );
    }
}

#[test]
fn an_unknown_benchmark_is_a_clear_error() {
    let out = Command::new(env!("CARGO_BIN_EXE_splatphys-bench"))
        .arg("nonsense")
        .output()
        .expect("run splatphys-bench");
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("nonsense"), "{err}");
}
