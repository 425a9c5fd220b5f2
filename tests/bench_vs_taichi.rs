//! `splatphys bench mpm --vs-taichi` without Taichi: a missing script fails before the run, a
//! missing interpreter or a Python without `taichi` is a clean skip after our own result, a
//! failing or silent child is an error with its stderr tail, and a child's JSON line is parsed
//! into the comparison. Stand-in interpreters are small shell scripts, so none of this needs
//! Taichi; where Taichi is installed one more test runs the real reference on a tiny cube.

use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;
use splatphys_tests::{bin, workspace};

const TINY: [&str; 6] = [
    "--particles-per-axis",
    "4",
    "--steps",
    "2",
    "--threads",
    "1",
];

fn bench_mpm(extra: &[&str]) -> Output {
    Command::new(bin("splatphys"))
        .args(["bench", "mpm"])
        .args(TINY)
        .arg("--vs-taichi")
        .args(extra)
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("run splatphys")
}

fn json_lines(out: &Output) -> Vec<Value> {
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("not JSON: {l:?}: {e}")))
        .collect()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// An executable shell script standing in for `python3`.
fn fake_python(dir: &Path, body: &str) -> PathBuf {
    let path = dir.join("python");
    std::fs::write(&path, format!("#!/bin/sh\n{body}\n")).expect("write fake python");
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).expect("chmod");
    path
}

fn repo_script() -> String {
    let script = workspace().join("bench/taichi/mpm_cube.py");
    script.to_str().expect("UTF-8 path").to_owned()
}

#[test]
fn missing_script_fails_before_the_run() {
    let out = bench_mpm(&["--taichi-script", "/nonexistent.py"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("/nonexistent.py"), "{}", stderr(&out));
    assert!(out.stdout.is_empty(), "ran anyway");
}

#[test]
fn missing_interpreter_skips_after_our_result() {
    // No --taichi-script: the default lookup must find bench/taichi/mpm_cube.py.
    let out = bench_mpm(&["--python", "/nonexistent/python3"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let lines = json_lines(&out);
    assert_eq!(lines.len(), 1);
    assert_eq!(lines[0]["impl"], "splatphys");
    assert_eq!(lines[0]["particles"], 64);
    assert!(lines[0]["com_z_m"].as_f64().is_some());
    assert!(
        stderr(&out).contains("taichi is not installed: pip install taichi"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn python_without_taichi_skips_cleanly() {
    let dir = tempfile::tempdir().expect("tempdir");
    let py = fake_python(
        dir.path(),
        "echo \"ModuleNotFoundError: No module named 'taichi'\" >&2; exit 1",
    );
    let out = bench_mpm(&["--python", py.to_str().expect("utf-8 path")]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(json_lines(&out).len(), 1);
    let err = stderr(&out);
    assert!(
        err.contains("taichi is not installed: pip install taichi"),
        "{err}"
    );
    assert!(err.contains("No module named 'taichi'"), "{err}");
}

#[test]
fn failing_child_reports_its_stderr() {
    let dir = tempfile::tempdir().expect("tempdir");
    let py = fake_python(
        dir.path(),
        "[ \"$1\" = -c ] && exit 0\necho 'Traceback: kernel exploded' >&2; exit 3",
    );
    let out = bench_mpm(&["--python", py.to_str().expect("utf-8 path")]);
    assert!(!out.status.success());
    assert_eq!(json_lines(&out).len(), 1, "our own result comes first");
    assert!(stderr(&out).contains("kernel exploded"), "{}", stderr(&out));
}

#[test]
fn child_without_json_is_an_error() {
    let dir = tempfile::tempdir().expect("tempdir");
    let py = fake_python(
        dir.path(),
        "[ \"$1\" = -c ] && exit 0\necho 'not json'; echo 'compiled 3 kernels' >&2; exit 0",
    );
    let out = bench_mpm(&["--python", py.to_str().expect("utf-8 path")]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(
        err.contains("no JSON result") && err.contains("compiled 3 kernels"),
        "{err}"
    );
}

#[test]
fn child_json_is_compared_and_its_arguments_are_ours() {
    let dir = tempfile::tempdir().expect("tempdir");
    // Echoes its arguments into the result so the test sees what it was given.
    let py = fake_python(
        dir.path(),
        "[ \"$1\" = -c ] && exit 0\nshift\necho '[Taichi] version 0.0.0'\n\
         printf '{\"impl\":\"taichi\",\"particles\":64,\"particle_substeps_per_s\":1000.0,\
         \"com_z_m\":0.449,\"momentum_z_kg_m_s\":-27.0,\"taichi_version\":\"0.0.0\",\"args\":\"%s\"}\\n' \"$*\"",
    );
    let out = bench_mpm(&["--python", py.to_str().expect("utf-8 path")]);
    assert!(out.status.success(), "{}", stderr(&out));
    let lines = json_lines(&out);
    assert_eq!(lines.len(), 3, "ours, Taichi's, the comparison");
    assert_eq!(
        lines[1]["args"],
        "--particles-per-axis 4 --grid 64 --steps 2 --threads 1 --warmup 5 --domain-scale 1 --arch cpu"
    );
    let cmp = &lines[2];
    assert_eq!(cmp["bench"], "mpm-vs-taichi");
    let ours = lines[0]["particle_substeps_per_s"].as_f64().expect("rate");
    assert_eq!(cmp["splatphys_per_s"].as_f64(), Some(ours));
    assert_eq!(cmp["taichi_per_s"].as_f64(), Some(1000.0));
    assert!((cmp["ratio"].as_f64().expect("ratio") - ours / 1000.0).abs() <= 1e-9 * ours);
    let diff = lines[0]["com_z_m"].as_f64().expect("com") - 0.449;
    assert!((cmp["com_z_diff_m"].as_f64().expect("diff") - diff).abs() < 1e-12);
}

/// Only where `python3` has Taichi (CI need not): the real reference agrees with ours.
#[test]
fn real_taichi_agrees_when_installed() {
    let has_taichi = Command::new("python3")
        .args(["-c", "import taichi"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !has_taichi {
        eprintln!("taichi is not installed: skipping");
        return;
    }
    let script = repo_script();
    let out = bench_mpm(&["--taichi-script", &script]);
    assert!(out.status.success(), "{}", stderr(&out));
    let lines = json_lines(&out);
    assert_eq!(lines.len(), 3);
    assert_eq!(lines[1]["impl"], "taichi");
    assert_eq!(lines[1]["particles"], 64);
    let cmp = &lines[2];
    assert!(
        cmp["com_z_diff_m"].as_f64().expect("diff").abs() < 1e-5,
        "{cmp}"
    );
    assert!(
        cmp["momentum_z_diff_kg_m_s"].as_f64().expect("diff").abs() < 1e-3,
        "{cmp}"
    );
}
