//! `splatphys-render live` against a server as a separate process: `splatphys serve --fake`
//! (the free-fall stand-in) when that binary was built next to ours (`cargo test --workspace`
//! builds it; `SPLATPHYS_BIN` names another), otherwise the same stand-in served from a thread of
//! this test. Every test uses its own service prefix under one iceoryx2 file prefix per test
//! binary (`SPLATPHYS_IOX2_PREFIX`), and every wait is bounded.

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

/// `splatphys` built next to the renderer, or named by `SPLATPHYS_BIN`.
fn server_binary() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("SPLATPHYS_BIN") {
        return Some(PathBuf::from(p));
    }
    let p = PathBuf::from(RENDER).with_file_name("splatphys");
    p.is_file().then_some(p)
}

/// A running stand-in server: a child process or a thread of this test.
enum Server {
    Process(Proc),
    Thread(std::thread::JoinHandle<u64>),
}

impl Server {
    fn start(prefix: &str, extra: &[&str]) -> Self {
        let iox = iox_prefix();
        if let Some(bin) = server_binary() {
            eprintln!("server: {} serve --fake", bin.display());
            let child = Command::new(bin)
                .args(["serve", "--fake", "--prefix", prefix, "--fake-dt", "0.005"])
                .args(["--fake-gaussians", "500", "--wait-for-subscribers", "1"])
                .args(extra)
                .env("SPLATPHYS_IOX2_PREFIX", &iox)
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .expect("spawn splatphys serve");
            return Server::Process(Proc(child));
        }
        eprintln!("server: no splatphys binary built; serving the stand-in from a thread");
        let cfg = ServerConfig {
            prefix: Some(prefix.to_owned()),
            max_frames: Some(FRAMES),
            wait_for_subscribers: 1,
            ..ServerConfig::default()
        };
        Server::Thread(std::thread::spawn(move || {
            let mut sim = FreeFall::new("fake", 2, 500, 0.005, None);
            serve(&mut sim, &cfg).expect("server").frames_published
        }))
    }

    fn is_process(&self) -> bool {
        matches!(self, Server::Process(_))
    }

    fn join(self, timeout: Duration) {
        match self {
            Server::Process(p) => {
                let e = wait_exit(p, timeout);
                assert_eq!(e.code, Some(0), "server failed:\n{}", e.stderr);
            }
            Server::Thread(h) => {
                let start = Instant::now();
                while !h.is_finished() {
                    assert!(start.elapsed() < timeout, "server thread did not stop");
                    std::thread::sleep(Duration::from_millis(10));
                }
                assert_eq!(h.join().expect("server thread"), FRAMES + 1);
            }
        }
    }
}

fn render_live(prefix: &str, out: &std::path::Path, extra: &[&str]) -> Proc {
    Proc(
        Command::new(RENDER)
            .args(["--threads", "2", "live", "--prefix", prefix, "--out-dir"])
            .arg(out)
            .args(["--width", "160", "--height", "120", "--timeout-s", "20"])
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
    let renderer = render_live(prefix, dir.path(), &[]);
    let server = Server::start(prefix, &["--frames", &FRAMES.to_string()]);
    let e = wait_exit(renderer, Duration::from_secs(60));
    server.join(Duration::from_secs(30));
    assert_eq!(e.code, Some(0), "renderer failed:\n{}", e.stderr);

    let s = summary(&e.stdout);
    let rendered = s["frames_rendered"].as_u64().expect("frames_rendered");
    assert!(rendered > 0, "{s}");
    assert!(s["frames_dropped"].as_u64().is_some(), "{s}");
    assert!(s["seconds"].as_f64().is_some_and(|t| t > 0.0), "{s}");
    // After draining, the final frame of the run is rendered.
    assert_eq!(s["last_step"].as_u64(), Some(FRAMES), "{s}\n{}", e.stderr);
    let files = pngs(dir.path());
    assert_eq!(files.len() as u64, rendered, "{files:?}");
    assert!(
        dir.path()
            .join(format!("frame_{FRAMES:05}.png"))
            .is_file()
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
    let renderer = render_live(prefix, dir.path(), &[]);
    let server = Server::start(prefix, &["--realtime"]);
    if !server.is_process() {
        eprintln!("skipped: needs the splatphys binary to kill the server");
        drop(renderer);
        // The thread serves FRAMES frames and stops on its own.
        server.join(Duration::from_secs(30));
        return;
    }
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
