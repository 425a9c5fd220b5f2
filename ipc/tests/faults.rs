//! Multi-process fault tests: `splatphys serve --fake` and `splatphys-probe` clients as real
//! processes, killed with SIGKILL. Each test uses its own iceoryx2 file prefix
//! (`SPLATPHYS_IOX2_PREFIX`) and checks that nothing of it is left in /dev/shm or
//! /tmp/iceoryx2 afterwards (except iceoryx2's persistent 16-byte `*.global_mgmt` node counter).

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const SERVER: &str = env!("CARGO_BIN_EXE_splatphys");
const PROBE: &str = env!("CARGO_BIN_EXE_splatphys-probe");

struct Proc(Child);
impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn iox_prefix(test: &str) -> String {
    format!("spxt_{test}_{}_", std::process::id())
}

fn server(iox: &str, prefix: &str, gaussians: usize) -> Proc {
    Proc(
        Command::new(SERVER)
            .args(["serve", "--fake", "--prefix", prefix, "--fake-dt", "0.001"])
            .args(["--fake-gaussians", &gaussians.to_string()])
            .env("SPLATPHYS_IOX2_PREFIX", iox)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn server"),
    )
}

fn probe(iox: &str, prefix: &str, extra: &[&str]) -> Proc {
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
fn wait_line(p: &mut Proc, needle: &str, timeout: Duration) -> String {
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

/// Waits for exit within `timeout`; returns (status code, stdout, stderr, elapsed).
fn wait_exit(mut p: Proc, timeout: Duration) -> (Option<i32>, String, String, Duration) {
    let t0 = Instant::now();
    loop {
        if let Some(st) = p.0.try_wait().expect("try_wait") {
            let mut out = String::new();
            let mut err = String::new();
            use std::io::Read;
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

fn leftovers(iox: &str) -> Vec<String> {
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

fn json_field(line: &str, key: &str) -> i64 {
    let v: serde_json::Value = serde_json::from_str(line.lines().last().unwrap_or("{}")).unwrap();
    v[key].as_i64().unwrap_or(i64::MIN)
}

#[test]
fn killed_server_makes_clients_exit_with_a_clear_message() {
    let iox = iox_prefix("ksrv");
    let mut srv = server(&iox, "t/ksrv", 100);
    let mut p = probe(&iox, "t/ksrv", &[]);
    wait_line(&mut p, "first_frame", Duration::from_secs(10));
    let killed = Instant::now();
    srv.0.kill().expect("kill -9 server");
    let _ = srv.0.wait();
    // The deadline only catches a hang: a loaded CI machine may take well over the 1 s
    // heartbeat timeout to schedule the client (wall-clock speed is not asserted in tests).
    let (code, _out, err, _) = wait_exit(p, Duration::from_secs(30));
    let after_kill = killed.elapsed();
    assert_eq!(code, Some(2), "stderr: {err}");
    assert!(err.contains("is gone: no heartbeat"), "stderr: {err}");
    // Never declared dead before the heartbeat timeout minus one status period (0.1 s):
    // load can only delay the detection, never bring it forward.
    assert!(
        after_kill >= Duration::from_millis(900),
        "declared dead after only {after_kill:?}"
    );
    drop(srv);
    // The client cleaned up the dead server's resources on its way out.
    assert_eq!(leftovers(&iox), Vec::<String>::new());
}

#[test]
fn killed_lossless_client_costs_no_step_and_a_new_client_attaches() {
    let iox = iox_prefix("kcli");
    let srv = server(&iox, "t/kcli", 100);
    let mut a = probe(&iox, "t/kcli", &["--lossless", "--delay-ms", "1"]);
    wait_line(&mut a, "first_frame", Duration::from_secs(10));
    a.0.kill().expect("kill -9 client");
    let _ = a.0.wait();
    drop(a);
    // A new lossless client attaches and receives 500 consecutive frames without a gap.
    let b = probe(&iox, "t/kcli", &["--lossless", "--frames", "500"]);
    let (code, out, err, _) = wait_exit(b, Duration::from_secs(60));
    assert_eq!(code, Some(0), "stderr: {err}");
    assert_eq!(json_field(&out, "frames"), 500, "{out}");
    assert_eq!(json_field(&out, "gaps"), 0, "{out}");
    // Clean shutdown on SIGTERM.
    let pid = srv.0.id().to_string();
    Command::new("kill")
        .args(["-TERM", &pid])
        .status()
        .expect("kill -TERM");
    let (code, _, err, _) = wait_exit(srv, Duration::from_secs(30));
    assert_eq!(code, Some(0), "server stderr: {err}");
    assert!(err.contains("stopped (Signal)"), "server stderr: {err}");
    assert_eq!(leftovers(&iox), Vec::<String>::new());
}

#[test]
fn two_prefixes_never_cross_talk() {
    let iox = iox_prefix("xtalk");
    let s1 = server(&iox, "t/one", 10);
    let s2 = server(&iox, "t/two", 30);
    let p1 = probe(&iox, "t/one", &["--frames", "50"]);
    let p2 = probe(&iox, "t/two", &["--frames", "50"]);
    let (c1, o1, e1, _) = wait_exit(p1, Duration::from_secs(60));
    let (c2, o2, e2, _) = wait_exit(p2, Duration::from_secs(60));
    assert_eq!((c1, c2), (Some(0), Some(0)), "{e1} {e2}");
    // Two objects per fake scene: 20 and 60 Gaussians.
    assert_eq!(json_field(&o1, "scene_gaussians"), 20, "{o1}");
    assert_eq!(json_field(&o2, "scene_gaussians"), 60, "{o2}");
    for s in [s1, s2] {
        Command::new("kill")
            .args(["-TERM", &s.0.id().to_string()])
            .status()
            .expect("kill");
        let (code, _, err, _) = wait_exit(s, Duration::from_secs(30));
        assert_eq!(code, Some(0), "{err}");
    }
    assert_eq!(leftovers(&iox), Vec::<String>::new());
}
