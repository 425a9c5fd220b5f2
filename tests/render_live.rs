//! `splatphys-render live` against a server as a separate process: `splatphys serve --fake`
//! (the free-fall stand-in) when that binary was built next to ours (`cargo test --workspace`
//! builds it; `SPLATPHYS_BIN` names another) and knows the flags used here; otherwise this test
//! binary re-runs itself as the server (the ignored test `fake_server_process`, which serves the
//! same stand-in through the ipc library). Every test uses its own service prefix under one
//! iceoryx2 file prefix per test binary (`SPLATPHYS_IOX2_PREFIX`), and every wait is bounded.

#[path = "common/procs.rs"]
mod procs;

use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::sync::Once;
use std::time::{Duration, Instant};

use procs::{Proc, RENDER, lit_pixels, pngs, summary, wait_exit};
use splatphys_ipc::fake::FreeFall;
use splatphys_ipc::server::{ServerConfig, serve};

/// Frames the server publishes after the initial one.
const FRAMES: u64 = 60;

fn iox_prefix() -> String {
    static SET: Once = Once::new();
    let prefix = format!("spxrl_{}_", std::process::id());
    SET.call_once(|| {
        // SAFETY: runs once, before any iceoryx2 node of this process reads the variable; every
        // test of this binary goes through here first.
        unsafe { std::env::set_var("SPLATPHYS_IOX2_PREFIX", &prefix) };
    });
    prefix
}

/// `splatphys` built next to the renderer, or named by `SPLATPHYS_BIN`, if its `serve` knows
/// the flags used here (a stale build may not).
fn server_binary() -> Option<PathBuf> {
    let p = match std::env::var_os("SPLATPHYS_BIN") {
        Some(p) => PathBuf::from(p),
        None => PathBuf::from(RENDER).with_file_name("splatphys"),
    };
    let help = Command::new(&p).args(["serve", "--help"]).output().ok()?;
    let help = String::from_utf8_lossy(&help.stdout);
    (help.contains("--wait-for-subscribers") && help.contains("--realtime")).then_some(p)
}

/// Environment variables that turn this test binary into a server (see
/// [`fake_server_process`]).
const SERVE_PREFIX_ENV: &str = "SPLATPHYS_RENDER_TEST_SERVE";
const SERVE_FRAMES_ENV: &str = "SPLATPHYS_RENDER_TEST_FRAMES";
const SERVE_REALTIME_ENV: &str = "SPLATPHYS_RENDER_TEST_REALTIME";

/// Not a test: the stand-in server when this binary is re-run as one.
#[test]
#[ignore = "run by the other tests as a server process"]
fn fake_server_process() {
    let Some(prefix) = std::env::var_os(SERVE_PREFIX_ENV) else {
        return;
    };
    let cfg = ServerConfig {
        prefix: Some(prefix.to_string_lossy().into_owned()),
        max_frames: std::env::var(SERVE_FRAMES_ENV)
            .ok()
            .and_then(|f| f.parse().ok()),
        realtime: std::env::var_os(SERVE_REALTIME_ENV).is_some(),
        wait_for_subscribers: 1,
        ..ServerConfig::default()
    };
    let mut sim = FreeFall::new("fake", 2, 500, 0.002, None);
    serve(&mut sim, &cfg).expect("server");
}

/// A running stand-in server process.
struct Server(Proc);

impl Server {
    /// Serves `frames` frames after the initial one (or until killed), paced to simulated time
    /// with `realtime`.
    fn start(prefix: &str, frames: Option<u64>, realtime: bool) -> Self {
        let iox = iox_prefix();
        let mut cmd = match server_binary() {
            Some(bin) => {
                eprintln!("server: {} serve --fake", bin.display());
                let mut c = Command::new(bin);
                c.args(["serve", "--fake", "--prefix", prefix, "--fake-dt", "0.002"])
                    .args(["--fake-gaussians", "500", "--wait-for-subscribers", "1"]);
                if let Some(f) = frames {
                    c.args(["--frames", &f.to_string()]);
                }
                if realtime {
                    c.arg("--realtime");
                }
                c
            }
            None => {
                eprintln!("server: no usable splatphys binary; this test binary serves instead");
                let mut c = Command::new(std::env::current_exe().expect("test binary"));
                c.args(["--ignored", "--exact", "fake_server_process", "--nocapture"])
                    .env(SERVE_PREFIX_ENV, prefix);
                if let Some(f) = frames {
                    c.env(SERVE_FRAMES_ENV, f.to_string());
                }
                if realtime {
                    c.env(SERVE_REALTIME_ENV, "1");
                }
                c
            }
        };
        let child = cmd
            .env("SPLATPHYS_IOX2_PREFIX", &iox)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn the server");
        Server(Proc(child))
    }

    fn join(self, timeout: Duration) {
        let e = wait_exit(self.0, timeout);
        assert_eq!(e.code, Some(0), "server failed:\n{}", e.stderr);
    }
}

fn render_live(prefix: &str, out: &std::path::Path, extra: &[&str]) -> Proc {
    Proc(
        Command::new(RENDER)
            .args(["--threads", "2", "live", "--prefix", prefix, "--out-dir"])
            .arg(out)
            .args(["--width", "160", "--height", "120"])
            .args(extra)
            .env("SPLATPHYS_IOX2_PREFIX", iox_prefix())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn splatphys-render"),
    )
}

#[test]
fn live_renders_until_clean_shutdown() {
    let dir = tempfile::tempdir().expect("tempdir");
    let prefix = "t/render_live";
    // Renderer first: it waits for the server to appear.
    let renderer = render_live(prefix, dir.path(), &["--timeout-s", "20"]);
    let server = Server::start(prefix, Some(FRAMES), true);
    let e = wait_exit(renderer, Duration::from_secs(60));
    server.join(Duration::from_secs(30));
    assert_eq!(e.code, Some(0), "renderer failed:\n{}", e.stderr);

    let s = summary(&e.stdout);
    let rendered = s["frames_rendered"].as_u64().expect("frames_rendered");
    assert!(rendered > 0, "{s}");
    assert!(s["frames_dropped"].as_u64().is_some(), "{s}");
    assert!(s["seconds"].as_f64().is_some_and(|t| t > 0.0), "{s}");
    // The final frame is rendered when it reached the renderer (a best-effort subscriber
    // misses it when its buffer is full at that moment). The server counts the initial frame,
    // published twice with `--wait-for-subscribers`, in `--frames`: the last step is FRAMES - 1.
    let last = s["last_step"].as_u64().expect("last_step");
    assert!((1..=FRAMES).contains(&last), "{s}\n{}", e.stderr);
    assert!(dir.path().join(format!("frame_{last:05}.png")).is_file());
    let files = pngs(dir.path());
    // Step 0 may be rendered twice (published before and after the renderer subscribed).
    let n = files.len() as u64;
    assert!(
        n == rendered || n + 1 == rendered,
        "{rendered} rendered, {files:?}"
    );
    for f in &files {
        assert!(lit_pixels(f) > 0, "{} is blank", f.display());
    }
    assert!(dir.path().join("animation.gif").is_file());
}

#[test]
fn live_fails_clearly_without_a_server() {
    let dir = tempfile::tempdir().expect("tempdir");
    let start = Instant::now();
    let p = render_live("t/render_nobody", dir.path(), &["--timeout-s", "0.3"]);
    let e = wait_exit(p, Duration::from_secs(20));
    assert_ne!(e.code, Some(0));
    assert!(e.stderr.contains("no splatphys server"), "{}", e.stderr);
    assert!(start.elapsed() < Duration::from_secs(10));
}

#[test]
fn live_writes_what_it_has_when_the_server_dies() {
    let dir = tempfile::tempdir().expect("tempdir");
    let prefix = "t/render_killed";
    let renderer = render_live(prefix, dir.path(), &["--timeout-s", "20"]);
    let server = Server::start(prefix, None, true);
    // Let a few frames be rendered, then kill -9 the server.
    let start = Instant::now();
    while pngs(dir.path()).len() < 2 {
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "no frame rendered"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    drop(server);
    let e = wait_exit(renderer, Duration::from_secs(30));
    assert_ne!(e.code, Some(0), "{}", e.stderr);
    assert!(e.stderr.contains("gone"), "{}", e.stderr);
    assert!(dir.path().join("animation.gif").is_file(), "{}", e.stderr);
    let s = summary(&e.stdout);
    assert!(s["frames_rendered"].as_u64().is_some_and(|n| n >= 2), "{s}");
}
