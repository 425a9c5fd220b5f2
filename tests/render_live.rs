//! `splatphys-render live` against `splatphys serve --fake` (the free-fall stand-in) as separate
//! processes: a clean run renders until the server shuts down, no server is a clear error, and a
//! killed server leaves what was rendered. Every test uses its own iceoryx2 file prefix and
//! service prefix, and every wait is bounded.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use splatphys_tests::{
    IOX_PREFIX_ENV, Proc, bin, fake_server, iox_prefix, lit_pixels, pngs, service_prefix, summary,
    wait_until,
};

/// Frames the server publishes after the initial one.
const FRAMES: u64 = 60;

/// The stand-in server: 2 cubes of 500 Gaussians, 2 ms per frame, publishing once one client
/// subscribed; `frames` frames after the initial one (or until killed), paced to simulated time
/// with `realtime`.
fn server(iox: &str, prefix: &str, frames: Option<u64>, realtime: bool) -> Proc {
    let frames = frames.map(|f| f.to_string());
    let mut args = vec![
        "--fake-dt",
        "0.002",
        "--fake-gaussians",
        "500",
        "--wait-for-subscribers",
        "1",
    ];
    if let Some(f) = &frames {
        args.extend(["--frames", f]);
    }
    if realtime {
        args.push("--realtime");
    }
    fake_server(iox, prefix, &args)
}

fn render_live(iox: &str, prefix: &str, out: &Path, extra: &[&str]) -> Proc {
    Proc::spawn(
        Command::new(bin("splatphys-render"))
            .args(["--threads", "2", "live", "--prefix", prefix, "--out-dir"])
            .arg(out)
            .args(["--width", "160", "--height", "120"])
            .args(extra)
            .env(IOX_PREFIX_ENV, iox)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped()),
    )
}

#[test]
fn live_renders_until_clean_shutdown() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (iox, prefix) = (iox_prefix("rlive"), service_prefix("render_live"));
    // Renderer first: it waits for the server to appear.
    let renderer = render_live(&iox, &prefix, dir.path(), &["--timeout-s", "20"]);
    let server = server(&iox, &prefix, Some(FRAMES), true);
    let e = renderer.wait_exit(Duration::from_secs(60));
    server.wait_success(Duration::from_secs(30));
    assert_eq!(e.code, Some(0), "renderer failed:\n{}", e.err);

    let s = summary(&e.out);
    let rendered = s["frames_rendered"].as_u64().expect("frames_rendered");
    assert!(rendered > 0, "{s}");
    assert!(s["frames_dropped"].as_u64().is_some(), "{s}");
    assert!(s["seconds"].as_f64().is_some_and(|t| t > 0.0), "{s}");
    // The final frame is rendered when it reached the renderer (a best-effort subscriber
    // misses it when its buffer is full at that moment). `--frames` counts the frames after the
    // initial one, which is published once, after the renderer subscribed.
    let last = s["last_step"].as_u64().expect("last_step");
    assert!((1..=FRAMES).contains(&last), "{s}\n{}", e.err);
    assert!(dir.path().join(format!("frame_{last:05}.png")).is_file());
    let files = pngs(dir.path());
    // Every step is published once, so every frame rendered is a file of its own.
    let n = files.len() as u64;
    assert_eq!(n, rendered, "{files:?}");
    for f in &files {
        assert!(lit_pixels(f) > 0, "{} is blank", f.display());
    }
    assert!(dir.path().join("animation.gif").is_file());
}

#[test]
fn live_fails_clearly_without_a_server() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (iox, prefix) = (iox_prefix("rnobody"), service_prefix("render_nobody"));
    let start = Instant::now();
    let p = render_live(&iox, &prefix, dir.path(), &["--timeout-s", "0.3"]);
    let e = p.wait_exit(Duration::from_secs(20));
    assert_ne!(e.code, Some(0));
    assert!(e.err.contains("no splatphys server"), "{}", e.err);
    assert!(start.elapsed() < Duration::from_secs(10));
}

#[test]
fn live_writes_what_it_has_when_the_server_dies() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (iox, prefix) = (iox_prefix("rkilled"), service_prefix("render_killed"));
    let renderer = render_live(&iox, &prefix, dir.path(), &["--timeout-s", "20"]);
    let server = server(&iox, &prefix, None, true);
    // Let a few frames be rendered, then kill -9 the server.
    wait_until("two frames rendered", Duration::from_secs(30), || {
        pngs(dir.path()).len() >= 2
    });
    drop(server);
    let e = renderer.wait_exit(Duration::from_secs(30));
    assert_ne!(e.code, Some(0), "{}", e.err);
    assert!(e.err.contains("gone"), "{}", e.err);
    assert!(dir.path().join("animation.gif").is_file(), "{}", e.err);
    let s = summary(&e.out);
    assert!(s["frames_rendered"].as_u64().is_some_and(|n| n >= 2), "{s}");
}
