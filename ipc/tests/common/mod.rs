//! Helpers of the multi-process tests: `splatphys serve --fake` and `splatphys-probe` as real
//! processes under a per-test iceoryx2 file prefix (`SPLATPHYS_IOX2_PREFIX`), their output,
//! signals, and the check that nothing of a prefix is left in /dev/shm or /tmp/iceoryx2.
//!
//! Deadlines here only catch hangs; no test asserts wall-clock speed (CI runs on a loaded
//! 2-core machine).

#![allow(dead_code)] // each test binary uses its own subset

pub mod table;

use std::io::{BufRead, BufReader, Read};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

/// The `splatphys` binary.
pub const SERVER: &str = env!("CARGO_BIN_EXE_splatphys");
/// The `splatphys-probe` binary.
pub const PROBE: &str = env!("CARGO_BIN_EXE_splatphys-probe");

/// A child process, killed (SIGKILL) when dropped.
pub struct Proc(pub Child);

impl Drop for Proc {
    fn drop(&mut self) {
        // A SIGSTOPped child dies of SIGKILL too.
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

impl Proc {
    /// Sends `signal` (e.g. "TERM", "STOP", "CONT", "KILL") with kill(1).
    pub fn signal(&self, signal: &str) {
        let st = Command::new("kill")
            .args([&format!("-{signal}"), &self.0.id().to_string()])
            .status()
            .expect("run kill");
        assert!(st.success(), "kill -{signal} failed");
    }

    /// SIGKILL and reap.
    pub fn kill9(&mut self) {
        self.0.kill().expect("kill -9");
        let _ = self.0.wait();
    }

    /// Forwards every stdout line to the returned channel (from a reader thread).
    pub fn stdout_lines(&mut self) -> Receiver<String> {
        let out = self
            .0
            .stdout
            .take()
            .expect("stdout piped and not taken yet");
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        rx
    }
}

/// A per-test iceoryx2 file prefix.
pub fn iox_prefix(test: &str) -> String {
    format!("spxt_{test}_{}_", std::process::id())
}

/// `splatphys serve --fake` under service prefix `prefix`, stepping 1 ms of simulated time per
/// frame as fast as it can, with `gaussians` per object (2 objects) and `extra` arguments.
pub fn server_with(iox: &str, prefix: &str, gaussians: usize, extra: &[&str]) -> Proc {
    Proc(
        Command::new(SERVER)
            .args(["serve", "--fake", "--prefix", prefix, "--fake-dt", "0.001"])
            .args(["--fake-gaussians", &gaussians.to_string()])
            .args(extra)
            .env("SPLATPHYS_IOX2_PREFIX", iox)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn server"),
    )
}

/// [`server_with`] without extra arguments.
pub fn server(iox: &str, prefix: &str, gaussians: usize) -> Proc {
    server_with(iox, prefix, gaussians, &[])
}

/// `splatphys-probe prefix extra...`.
pub fn probe(iox: &str, prefix: &str, extra: &[&str]) -> Proc {
    Proc(
        Command::new(PROBE)
            .arg(prefix)
            .args(extra)
            .env("SPLATPHYS_IOX2_PREFIX", iox)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn probe"),
    )
}

/// Reads stdout lines until one contains `needle`, within `timeout`.
pub fn wait_line(p: &mut Proc, needle: &str, timeout: Duration) -> String {
    let out = p.0.stdout.take().expect("stdout");
    let (tx, rx) = std::sync::mpsc::channel();
    let needle = needle.to_owned();
    std::thread::spawn(move || {
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            if line.contains(&needle) {
                let _ = tx.send(line);
            }
        }
    });
    rx.recv_timeout(timeout).expect("expected line in time")
}

/// Waits on `lines` (from [`Proc::stdout_lines`]) for one containing `needle`.
pub fn wait_for(lines: &Receiver<String>, needle: &str, timeout: Duration) -> String {
    let t0 = Instant::now();
    loop {
        let left = timeout.saturating_sub(t0.elapsed());
        match lines.recv_timeout(left) {
            Ok(line) if line.contains(needle) => return line,
            Ok(_) => {}
            Err(RecvTimeoutError::Timeout) => panic!("no line with {needle:?} within {timeout:?}"),
            Err(RecvTimeoutError::Disconnected) => panic!("stdout closed before {needle:?}"),
        }
    }
}

/// The last line of `lines` once the writer closed its stdout (within `timeout`).
pub fn last_line(lines: &Receiver<String>, timeout: Duration) -> String {
    let t0 = Instant::now();
    let mut last = String::new();
    loop {
        match lines.recv_timeout(timeout.saturating_sub(t0.elapsed())) {
            Ok(line) => last = line,
            Err(RecvTimeoutError::Disconnected) => return last,
            Err(RecvTimeoutError::Timeout) => panic!("stdout still open after {timeout:?}"),
        }
    }
}

/// Waits for exit within `timeout`; returns (status code, stdout not taken yet, stderr, elapsed).
pub fn wait_exit(mut p: Proc, timeout: Duration) -> (Option<i32>, String, String, Duration) {
    let t0 = Instant::now();
    loop {
        if let Some(st) = p.0.try_wait().expect("try_wait") {
            let mut out = String::new();
            let mut err = String::new();
            if let Some(mut o) = p.0.stdout.take() {
                let _ = o.read_to_string(&mut out);
            }
            if let Some(mut e) = p.0.stderr.take() {
                let _ = e.read_to_string(&mut err);
            }
            return (st.code(), out, err, t0.elapsed());
        }
        assert!(
            t0.elapsed() < timeout,
            "process did not exit within {timeout:?}"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// Files of prefix `iox` left in /dev/shm or /tmp/iceoryx2 (except iceoryx2's persistent
/// 16-byte `*.global_mgmt` node counter).
pub fn leftovers(iox: &str) -> Vec<String> {
    let mut found = Vec::new();
    for dir in ["/dev/shm", "/tmp/iceoryx2/services", "/tmp/iceoryx2/nodes"] {
        if let Ok(rd) = std::fs::read_dir(dir) {
            for e in rd.flatten() {
                let name = e.file_name().to_string_lossy().into_owned();
                if name.starts_with(iox) && !name.ends_with(".global_mgmt") {
                    found.push(format!("{dir}/{name}"));
                }
            }
        }
    }
    // Node directories are named by id; look inside for our prefix.
    if let Ok(rd) = std::fs::read_dir("/tmp/iceoryx2/nodes") {
        for e in rd.flatten().filter(|e| e.path().is_dir()) {
            if let Ok(inner) = std::fs::read_dir(e.path()) {
                for f in inner.flatten() {
                    if f.file_name().to_string_lossy().starts_with(iox) {
                        found.push(f.path().display().to_string());
                    }
                }
            }
        }
    }
    found
}

/// Integer field `key` of the JSON on the last line of `text` (i64::MIN when absent).
pub fn json_field(text: &str, key: &str) -> i64 {
    let v: serde_json::Value = serde_json::from_str(text.lines().last().unwrap_or("{}")).unwrap();
    v[key].as_i64().unwrap_or(i64::MIN)
}

/// The number in the server's final stderr line "..., N lost by recorders".
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

/// SIGTERM the server and check it stops cleanly; returns its stderr.
pub fn stop_server(srv: Proc) -> String {
    srv.signal("TERM");
    let (code, _, err, _) = wait_exit(srv, Duration::from_secs(30));
    assert_eq!(code, Some(0), "server stderr: {err}");
    assert!(err.contains("stopped (Signal)"), "server stderr: {err}");
    err
}
