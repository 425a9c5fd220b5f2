//! The browser viewer end to end: a real server (two jelly spheres), the `splatphys-web` bridge,
//! and the page in headless Chromium (Debian's `chromium`, driven by playwright-core from
//! `clients/web/tests/node_modules`; `.ci/run` installs both; software GL).
//!
//! - the step counter advances while the server runs;
//! - a paused frame drawn by the page matches `splatphys-render`'s image of the same frame and
//!   camera (PSNR >= 30 dB), rendered here from the same published state;
//! - clicking an object selects it, dragging from it sends an impulse the server accepts, and
//!   the object's velocity changes by about the Δv the drag asked for;
//! - a refused material edit shows the server's reason in the page.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use splatphys_ipc::client::{ClientOptions, Connection};
use splatphys_ipc::wire::FrameGaussian;
use splatphys_render::{Camera, RenderSettings, SplatView, render_rgb8};
use splatphys_tests::{
    IOX_PREFIX_ENV, Proc, bin, iox_prefix, service_prefix, wait_until, workspace,
};

const WIDTH: u32 = 320;
const HEIGHT: u32 = 240;
/// The scene file's camera (scenes/validation_two_spheres.toml), at the test's image size.
const CAMERA_POS: [f32; 3] = [0.0, -1.2, 0.2];
const LOOK_AT: [f32; 3] = [0.0, 0.0, 0.0];
const FOV_DEG: f32 = 50.0;

fn web_tests_dir() -> PathBuf {
    workspace().join("clients/web/tests")
}

/// Fails with what to install when the browser tools are missing.
fn require_browser() {
    let chromium = std::env::var("CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into());
    assert!(
        Path::new(&chromium).exists(),
        "the viewer tests need Chromium at {chromium} (apt-get install chromium; .ci/run does)"
    );
    assert!(
        web_tests_dir()
            .join("node_modules/playwright-core")
            .exists(),
        "the viewer tests need playwright-core: (cd clients/web/tests && npm install)"
    );
}

/// Runs `node viewer_e2e.mjs <args>` and parses its JSON line.
fn node(args: &[&str]) -> serde_json::Value {
    let out = Command::new("node")
        .arg("viewer_e2e.mjs")
        .args(args)
        .current_dir(web_tests_dir())
        .stderr(Stdio::inherit())
        .output()
        .expect("run node");
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text.lines().rfind(|l| l.starts_with('{')).unwrap_or("{}");
    let v: serde_json::Value = serde_json::from_str(line).expect("json from viewer_e2e.mjs");
    assert_eq!(v["ok"], true, "viewer_e2e.mjs {args:?}: {v}");
    v
}

fn csv(v: [f32; 3]) -> String {
    format!("{},{},{}", v[0], v[1], v[2])
}

/// The published scene and the newest frame, kept by a client thread of the test's own (a
/// paused server publishes nothing new, so the frame must be taken while it runs).
#[derive(Default)]
struct Published {
    opacities: Vec<f32>,
    sh: Vec<[f32; 3]>,
    degree: u8,
    step: Option<u64>,
    frame: Vec<FrameGaussian>,
}

fn follow(prefix: String, stop: Arc<AtomicBool>, out: Arc<Mutex<Published>>) {
    let mut opts = ClientOptions::new(&prefix);
    opts.commands = false;
    opts.connect_timeout = Duration::from_secs(30);
    let mut conn = Connection::connect(&opts).expect("connect");
    while !stop.load(Ordering::Acquire) {
        if let Some(s) = conn.recv_scene().expect("scene") {
            let degree = s.user_header().sh_degree.min(3) as u8;
            let k = (usize::from(degree) + 1).pow(2);
            let mut p = out.lock().expect("lock");
            p.degree = degree;
            p.sh = s
                .payload()
                .iter()
                .flat_map(|g| g.sh.chunks_exact(3).take(k).map(|c| [c[0], c[1], c[2]]))
                .collect();
            p.opacities = s.payload().iter().map(|g| g.opacity).collect();
        }
        if let Some(f) = conn.latest_frame().expect("frame") {
            let mut p = out.lock().expect("lock");
            p.step = Some(f.user_header().step);
            p.frame = f.payload().to_vec();
        }
        std::thread::sleep(Duration::from_millis(1));
    }
}

/// `splatphys-render`'s image of the published frame of `step`.
fn cpu_image(published: &Mutex<Published>, step: u64) -> Vec<u8> {
    wait_until(
        "the test's client has the paused frame",
        Duration::from_secs(30),
        || published.lock().expect("lock").step == Some(step),
    );
    let p = published.lock().expect("lock");
    let positions: Vec<[f32; 3]> = p.frame.iter().map(|g| g.position_m).collect();
    let covariances: Vec<[f32; 6]> = p.frame.iter().map(|g| g.covariance_m2).collect();
    let rotations: Vec<[f32; 4]> = p.frame.iter().map(|g| g.rotation_wxyz).collect();
    let view = SplatView::new(
        &positions,
        &covariances,
        &p.opacities,
        &p.sh,
        p.degree,
        &rotations,
    )
    .expect("splats");
    let camera = Camera::new(
        CAMERA_POS.into(),
        LOOK_AT.into(),
        glam::Vec3::Z,
        FOV_DEG,
        WIDTH,
        HEIGHT,
    )
    .expect("camera");
    render_rgb8(&view, &camera, &RenderSettings::default())
        .expect("render")
        .data
}

fn psnr_db(a: &[u8], b: &[u8]) -> f64 {
    assert_eq!(a.len(), b.len());
    let mse = a
        .iter()
        .zip(b)
        .map(|(x, y)| (f64::from(*x) - f64::from(*y)).powi(2))
        .sum::<f64>()
        / a.len() as f64;
    10.0 * (255.0f64 * 255.0 / mse.max(1e-12)).log10()
}

#[test]
fn the_browser_viewer_shows_the_simulation_and_pushes_it() {
    require_browser();
    let iox = iox_prefix("web");
    // SAFETY: the only test of this binary, set before any iceoryx2 node exists.
    unsafe { std::env::set_var(IOX_PREFIX_ENV, &iox) };
    let prefix = service_prefix("web");
    let server = Proc::spawn(
        Command::new(bin("splatphys"))
            .arg("serve")
            .arg(workspace().join("scenes/validation_two_spheres.toml"))
            .args(["--prefix", &prefix, "--duration-s", "600"])
            .env(IOX_PREFIX_ENV, &iox)
            .stdout(Stdio::null())
            .stderr(Stdio::piped()),
    );
    let mut web = Proc::spawn(
        Command::new(bin("splatphys-web"))
            .args(["--prefix", &prefix, "--port", "0"])
            .args(["--camera-pos", &csv(CAMERA_POS), "--look-at", &csv(LOOK_AT)])
            .args(["--fov-deg", &FOV_DEG.to_string()])
            .args([
                "--width",
                &WIDTH.to_string(),
                "--height",
                &HEIGHT.to_string(),
            ])
            .env(IOX_PREFIX_ENV, &iox)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped()),
    );
    let url = web
        .wait_line("http://", Duration::from_secs(30))
        .trim()
        .to_owned();
    let published = Arc::new(Mutex::new(Published::default()));
    let stop = Arc::new(AtomicBool::new(false));
    let follower = {
        let (prefix, stop, published) = (prefix.clone(), stop.clone(), published.clone());
        std::thread::spawn(move || follow(prefix, stop, published))
    };
    let (w, h) = (WIDTH.to_string(), HEIGHT.to_string());

    // 1. Live, then paused: the page's image of the paused frame against the CPU renderer's.
    let dir = tempfile::tempdir().expect("tempdir");
    let rgb = dir.path().join("page.rgb");
    let rgb_s = rgb.display().to_string();
    let cap = node(&["capture", &url, &w, &h, &rgb_s]);
    assert!(
        cap["step1"].as_u64() > cap["step0"].as_u64(),
        "the step counter advances: {cap}"
    );
    let paused = cap["pausedStep"].as_u64().expect("paused step");
    assert_eq!(
        cap["stepAfter"].as_u64(),
        Some(paused),
        "still paused: {cap}"
    );
    let page = std::fs::read(&rgb).expect("page pixels");
    let cpu = cpu_image(&published, paused);
    stop.store(true, Ordering::Release);
    follower.join().expect("follower");
    let psnr = psnr_db(&page, &cpu);
    eprintln!("web_viewer: paused step {paused}, page vs splatphys-render: PSNR {psnr:.1} dB");
    if psnr < 30.0 {
        let save = |name: &str, data: &[u8]| {
            let p = std::env::temp_dir().join(name);
            image::RgbImage::from_raw(WIDTH, HEIGHT, data.to_vec())
                .expect("image")
                .save(&p)
                .expect("save");
            p
        };
        panic!(
            "PSNR {psnr:.1} dB < 30 dB: page {} vs cpu {}",
            save("web_viewer_page.png", &page).display(),
            save("web_viewer_cpu.png", &cpu).display()
        );
    }

    // 2. Click an object, drag from it (an impulse), step once; a refused material edit.
    let it = node(&["interact", &url, &w, &h]);
    assert_eq!(it["selectedText"], "left", "{it}");
    assert_eq!(it["impulseReply"]["accepted"], true, "{it}");
    let v = |k: &str| -> Vec<f64> {
        it[k]
            .as_array()
            .expect("velocity")
            .iter()
            .map(|x| x.as_f64().expect("number"))
            .collect()
    };
    let (before, after) = (v("velocityBefore"), v("velocityAfter"));
    // 100 px of drag is 1 m/s along the view direction; the camera looks along +y (and a bit
    // down).
    let dv: Vec<f64> = after.iter().zip(&before).map(|(a, b)| a - b).collect();
    assert!(
        dv[1] > 0.5 && dv[1] < 1.5,
        "Δv {dv:?} (before {before:?}, after {after:?})"
    );
    assert_eq!(it["materialReply"]["accepted"], false, "{it}");
    let text = it["replyText"].as_str().unwrap_or_default();
    assert!(
        text.contains("youngs_modulus_pa") && text.contains("1e13"),
        "the refusal's reason is shown: {text:?}"
    );

    // 3. The server stops: the page keeps the last frame and says so.
    let json = dir.path().join("stopped.json");
    let json_s = json.display().to_string();
    let mut watcher = Proc::spawn(
        Command::new("node")
            .args(["viewer_e2e.mjs", "stopped", &url, &w, &h, &json_s])
            .current_dir(web_tests_dir())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped()),
    );
    watcher.wait_line("READY", Duration::from_secs(60));
    let srv = server.terminate(Duration::from_secs(30));
    assert_eq!(srv.code, Some(0), "server: {}", srv.err);
    let e = watcher.wait_exit(Duration::from_secs(120));
    let stopped: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap_or_default())
            .unwrap_or_else(|_| panic!("no report from the stopped phase: {}", e.err));
    assert_eq!(stopped["ok"], true, "{stopped}");
    assert!(
        stopped["statusText"]
            .as_str()
            .is_some_and(|t| t.contains("stopped")),
        "{stopped}"
    );
    assert!(
        stopped["litPixels"].as_u64() > Some(100),
        "the last frame is still drawn: {stopped}"
    );
    let bridge = web.terminate(Duration::from_secs(30));
    assert!(bridge.err.contains("frames sent"), "{}", bridge.err);
}
