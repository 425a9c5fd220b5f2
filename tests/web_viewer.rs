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
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Duration;

use splatphys_core::formats::ply::write_ply;
use splatphys_core::gaussians::GaussianCloud;
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

/// `splatphys-render`'s image of the published frame of `step`, seen from `camera` (position,
/// look-at), with SH up to `max_sh_degree`.
fn cpu_image(
    published: &Mutex<Published>,
    step: u64,
    camera: (&[f32; 3], &[f32; 3]),
    max_sh_degree: u8,
) -> Vec<u8> {
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
        (*camera.0).into(),
        (*camera.1).into(),
        glam::Vec3::Z,
        FOV_DEG,
        WIDTH,
        HEIGHT,
    )
    .expect("camera");
    let settings = RenderSettings {
        max_sh_degree,
        ..RenderSettings::default()
    };
    render_rgb8(&view, &camera, &settings).expect("render").data
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

/// One iceoryx2 file prefix for this binary (the test's own client reads it from the
/// environment).
fn iox() -> String {
    static IOX: OnceLock<String> = OnceLock::new();
    IOX.get_or_init(|| {
        let iox = iox_prefix("web");
        // SAFETY: set once, before any iceoryx2 node of this process exists, to one value.
        unsafe { std::env::set_var(IOX_PREFIX_ENV, &iox) };
        iox
    })
    .clone()
}

/// `splatphys-web` for `prefix` with the test's camera; returns it and its URL.
fn bridge(iox: &str, prefix: &str, camera: (&[f32; 3], &[f32; 3])) -> (Proc, String) {
    let mut web = Proc::spawn(
        Command::new(bin("splatphys-web"))
            .args(["--prefix", prefix, "--port", "0"])
            .args([
                "--camera-pos",
                &csv(*camera.0),
                "--look-at",
                &csv(*camera.1),
            ])
            .args(["--fov-deg", &FOV_DEG.to_string()])
            .args([
                "--width",
                &WIDTH.to_string(),
                "--height",
                &HEIGHT.to_string(),
            ])
            .env(IOX_PREFIX_ENV, iox)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped()),
    );
    let url = web
        .wait_line("http://", Duration::from_secs(30))
        .trim()
        .to_owned();
    (web, url)
}

/// A client thread of the test's own following `prefix` (see [`Published`]).
fn follower(
    prefix: &str,
) -> (
    Arc<Mutex<Published>>,
    Arc<AtomicBool>,
    std::thread::JoinHandle<()>,
) {
    let published = Arc::new(Mutex::new(Published::default()));
    let stop = Arc::new(AtomicBool::new(false));
    let handle = {
        let (prefix, stop, published) = (prefix.to_owned(), stop.clone(), published.clone());
        std::thread::spawn(move || follow(prefix, stop, published))
    };
    (published, stop, handle)
}

#[test]
fn the_browser_viewer_shows_the_simulation_and_pushes_it() {
    require_browser();
    let iox = iox();
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
    let (web, url) = bridge(&iox, &prefix, (&CAMERA_POS, &LOOK_AT));
    let (published, stop, follower) = follower(&prefix);
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
    let cpu = cpu_image(&published, paused, (&CAMERA_POS, &LOOK_AT), 3);
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

/// `n` Gaussians with random SH of degree 2 (24 `f_rest_*` each) in a 0.3 m cube.
fn sh2_cloud(n: usize) -> GaussianCloud {
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut r = move |lo: f32, hi: f32| {
        // SplitMix64, reproducible.
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        lo + (hi - lo) * ((z >> 40) as f32 / (1u64 << 24) as f32)
    };
    let mut cloud = GaussianCloud::with_capacity(n, 24);
    for _ in 0..n {
        cloud
            .positions
            .push([r(-0.15, 0.15), r(-0.15, 0.15), r(-0.15, 0.15)]);
        cloud.sh_dc.push([r(-1.0, 1.0), r(-1.0, 1.0), r(-1.0, 1.0)]);
        cloud.sh_rest.extend((0..24).map(|_| r(-0.6, 0.6)));
        let o = r(0.3, 0.95);
        cloud.opacity_logit.push((o / (1.0 - o)).ln());
        cloud.log_scales.push([
            r(0.006, 0.02).ln(),
            r(0.006, 0.02).ln(),
            r(0.006, 0.02).ln(),
        ]);
        let q = glam::Quat::from_euler(
            glam::EulerRot::XYZ,
            r(-3.0, 3.0),
            r(-3.0, 3.0),
            r(-3.0, 3.0),
        );
        cloud.rotations_wxyz.push([q.w, q.x, q.y, q.z]);
    }
    cloud
}

#[test]
fn a_rotated_sh2_source_looks_the_same_in_the_browser() {
    require_browser();
    let iox = iox();
    let dir = tempfile::tempdir().expect("tempdir");
    let cloud = sh2_cloud(3_000);
    assert_eq!(cloud.sh_degree, 2);
    let ply = dir.path().join("cloud.ply");
    write_ply(&ply, &cloud, &[]).expect("write ply");
    // The source is placed rotated: the scene message carries its SH rotated into the world
    // frame, and the page must evaluate it as the CPU renderer does.
    let scene = dir.path().join("sh2.toml");
    let camera = ([0.9_f32, -0.7, 0.5], [0.0_f32, 0.0, 0.3]);
    let toml = format!(
        r#"[simulation]
duration_s = 100.0
gravity_m_s2 = [0.0, 0.0, 0.0]
background_collision = false

[[source]]
name = "cloud"
path = {path:?}
rotation_deg = [-90.0, 25.0, 40.0]
translation_m = [0.0, 0.0, 0.3]

[[object]]
name = "cloud"
select = {{ source = "cloud" }}
kind = "rigid"
material = {{ model = "jelly", youngs_modulus_pa = 1e5, poisson_ratio = 0.3, density_kg_m3 = 500.0 }}
"#,
        path = ply.display().to_string()
    );
    std::fs::write(&scene, toml).expect("write scene");
    let prefix = service_prefix("web-sh");
    // Paused, and the initial frame published again once the bridge and the test's client
    // have subscribed.
    let server = Proc::spawn(
        Command::new(bin("splatphys"))
            .arg("serve")
            .arg(&scene)
            .args([
                "--prefix",
                &prefix,
                "--paused",
                "--wait-for-subscribers",
                "2",
            ])
            .env(IOX_PREFIX_ENV, &iox)
            .stdout(Stdio::null())
            .stderr(Stdio::piped()),
    );
    let (web, url) = bridge(&iox, &prefix, (&camera.0, &camera.1));
    let (published, stop, follower) = follower(&prefix);
    let rgb = dir.path().join("page.rgb");
    let still = node(&[
        "still",
        &url,
        &WIDTH.to_string(),
        &HEIGHT.to_string(),
        &rgb.display().to_string(),
    ]);
    let step = still["step"].as_u64().expect("step");
    let page = std::fs::read(&rgb).expect("page pixels");
    let cpu = cpu_image(&published, step, (&camera.0, &camera.1), 3);
    let dc_only = cpu_image(&published, step, (&camera.0, &camera.1), 0);
    stop.store(true, Ordering::Release);
    follower.join().expect("follower");
    let (full, without) = (psnr_db(&page, &cpu), psnr_db(&page, &dc_only));
    eprintln!(
        "web_viewer: rotated SH-2 source: PSNR {full:.1} dB against splatphys-render, {without:.1} dB against its image without the view-dependent terms"
    );
    assert!(full >= 30.0, "PSNR {full:.1} dB < 30 dB");
    assert!(
        without < full - 10.0,
        "the view-dependent colour must show: {without:.1} dB without it, {full:.1} dB with it"
    );
    drop(web);
    drop(server);
}

#[test]
fn serve_view_holds_the_last_frame_for_a_page_opened_after_the_end() {
    require_browser();
    let iox = iox();
    let prefix = service_prefix("web-end");
    // `splatphys serve --view` as a user types it (the viewer on any free port), its stderr
    // read as lines: the viewer's URL, then the end of the scene.
    let mut server = Proc::spawn(
        Command::new("sh")
            .args(["-c", "exec \"$0\" \"$@\" 2>&1"])
            .arg(bin("splatphys"))
            .arg("serve")
            .arg(workspace().join("scenes/validation_two_spheres.toml"))
            .args(["--duration-s=0.5", "--view", "--view-port=0", "--prefix"])
            .arg(&prefix)
            .env(IOX_PREFIX_ENV, &iox)
            .stdout(Stdio::piped())
            .stderr(Stdio::null()),
    );
    let lines = server.stdout_lines();
    let url = splatphys_tests::wait_for(&lines, "watch it live at", Duration::from_secs(60));
    let url = url.rsplit(' ').next().expect("a URL").to_owned();
    let end = splatphys_tests::wait_for(&lines, "finished at step", Duration::from_secs(120));
    std::thread::spawn(move || lines.iter().for_each(drop));
    let final_step: u64 = end
        .split("finished at step ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no step in {end:?}"));
    // The page is opened 5 s after the end.
    std::thread::sleep(Duration::from_secs(5));
    let (w, h) = (WIDTH.to_string(), HEIGHT.to_string());
    let page = node(&["finished", &url, &w, &h]);
    assert_eq!(
        page["finalStep"].as_u64(),
        Some(final_step),
        "the last frame: {page}"
    );
    assert!(page["litPixels"].as_u64() > Some(500), "drawn: {page}");
    let status = page["statusText"].as_str().unwrap_or_default();
    assert!(status.contains("finished"), "{page}");
    assert_eq!(page["stepAfterReset"].as_u64(), Some(0), "{page}");
    assert!(page["stepAfterResume"].as_u64() > Some(2), "{page}");
    // SIGTERM still ends it (and its viewer) within 2 s.
    let t0 = std::time::Instant::now();
    let e = server.terminate(Duration::from_secs(30));
    let took = t0.elapsed();
    assert_eq!(e.code, Some(0));
    assert!(took < Duration::from_secs(2), "SIGTERM took {took:?}");
}
