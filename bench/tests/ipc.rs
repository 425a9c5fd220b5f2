//! `splatphys-bench ipc` end to end on a small size: every transport's peer process runs, the
//! JSON line carries each transport's figures, and `ipc.csv` has one row with every column.

use std::process::Command;

#[test]
fn ipc_measures_iceoryx2_the_socket_and_zenoh() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_splatphys-bench"))
        .args([
            "ipc",
            "--sizes",
            "1000",
            "--samples",
            "5",
            "--warmup",
            "1",
            "--command-flood-hz",
            "0",
            "--out-dir",
        ])
        .arg(dir.path())
        .output()
        .expect("run splatphys-bench");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let line: serde_json::Value =
        serde_json::from_str(stdout.lines().next().expect("a JSON line")).unwrap();
    assert_eq!(line["gaussians"], 1000);
    assert_eq!(line["bytes"], 52_000);
    for key in [
        "iox_median_latency_us",
        "socket_median_latency_us",
        "zenoh_median_latency_us",
        "zenoh_p99_latency_us",
        "zenoh_frames_per_s",
    ] {
        let v = line[key].as_f64().unwrap_or(f64::NAN);
        assert!(v.is_finite() && v > 0.0, "{key} = {v}");
    }
    let mut csv = csv::Reader::from_path(dir.path().join("ipc.csv")).unwrap();
    let headers = csv.headers().unwrap().clone();
    assert_eq!(headers.len(), 16);
    assert_eq!(&headers[15], "zenoh_frames_per_s");
    assert_eq!(csv.records().count(), 1);
}
