//! `splatphys run` end to end: the built-in scene in both modes and the captured guitar scene,
//! checking summary.json, the PNG frames, the MCAP recording (read back with the mcap crate) and
//! objects.csv against each other.

use std::collections::HashMap;
use std::path::Path;
use std::process::Command;
use std::time::Duration;

use splatphys_tests::{Proc, bin, iox_prefix, leftovers, lit_pixels, pngs, read_csv};

/// Runs `splatphys run <extra> --out <out>` under its own iceoryx2 prefix; returns the summary.
fn run(test: &str, extra: &[&str], out: &Path) -> serde_json::Value {
    let iox = iox_prefix(test);
    let exit = Proc::spawn(
        Command::new(bin("splatphys"))
            .arg("run")
            .args(extra)
            .arg("--out")
            .arg(out)
            .args(["--threads", "2"])
            .env("SPLATPHYS_IOX2_PREFIX", &iox)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped()),
    )
    .wait_exit(Duration::from_secs(600));
    assert_eq!(exit.code, Some(0), "splatphys run {extra:?}:\n{}", exit.err);
    assert!(leftovers(&iox).is_empty(), "{:?}", leftovers(&iox));
    let text = std::fs::read_to_string(out.join("summary.json")).expect("summary.json");
    serde_json::from_str(&text).expect("summary.json is JSON")
}

/// Messages per topic in an MCAP file.
fn mcap_topics(path: &Path) -> HashMap<String, usize> {
    let bytes = std::fs::read(path).expect("run.mcap");
    let mut counts = HashMap::new();
    for m in mcap::MessageStream::new(&bytes).expect("an MCAP file") {
        let m = m.expect("a readable message");
        *counts.entry(m.channel.topic.clone()).or_insert(0) += 1;
    }
    counts
}

/// The checks every run's objects.csv passes: header, one row per object per frame, the names
/// of the objects in their id order, steps increasing, and `objects_csv_rows` in the summary.
/// `from_step_0`: the first frame is the initial one.
fn check_objects_csv(
    out: &Path,
    summary: &serde_json::Value,
    names: &[&str],
    from_step_0: bool,
) -> usize {
    let text = std::fs::read_to_string(out.join("objects.csv")).unwrap();
    assert_eq!(
        text.lines().next(),
        Some("step,time_s,object,name,x_m,y_m,z_m,vx_m_s,vy_m_s,vz_m_s,mass_kg,fx_n,fy_n,fz_n")
    );
    let rows = read_csv(&out.join("objects.csv"));
    assert!(!rows.is_empty(), "objects.csv has no rows");
    assert_eq!(
        rows.len() as u64,
        summary["objects_csv_rows"].as_u64().unwrap()
    );
    assert_eq!(rows.len() % names.len(), 0, "a frame with missing objects");
    for frame in rows.chunks(names.len()) {
        for (i, r) in frame.iter().enumerate() {
            assert_eq!(r["object"], i.to_string());
            assert_eq!(r["name"], names[i]);
            assert_eq!(r["step"], frame[0]["step"], "one step per frame block");
        }
    }
    let steps: Vec<u64> = rows
        .chunks(names.len())
        .map(|f| f[0]["step"].parse().unwrap())
        .collect();
    assert!(
        steps.windows(2).all(|w| w[0] < w[1]),
        "steps increase: {steps:?}"
    );
    if from_step_0 {
        assert_eq!(steps[0], 0);
    }
    rows.len() / names.len()
}

fn check_multi_process(out: &Path, s: &serde_json::Value, names: &[&str]) {
    assert_eq!(s["mode"], "multi-process");
    assert!(s["frames"].as_u64().unwrap() > 0, "no frames published");
    assert_eq!(
        s["frames_lost_by_recorder"], 0,
        "the lossless recorder lost frames"
    );
    assert_eq!(s["recorder_ok"], true);
    assert_eq!(s["renderer_ok"], true);
    assert!(std::fs::metadata(out.join("animation.gif")).unwrap().len() > 0);
    let frames = pngs(&out.join("frames"));
    assert!(!frames.is_empty(), "no PNG frames");
    assert_eq!(frames.len() as u64, s["frame_pngs"].as_u64().unwrap());
    for png in [&frames[0], &frames[frames.len() - 1]] {
        assert!(lit_pixels(png) > 100, "{}: blank frame", png.display());
    }
    let topics = mcap_topics(&out.join("run.mcap"));
    let recorded_frames = topics.get("/frame").copied().unwrap_or(0);
    assert!(recorded_frames > 0, "no frame in the recording: {topics:?}");
    assert_eq!(topics.get("/scene"), Some(&1), "{topics:?}");
    // The lossless contract: the server publishes its first frame once the recorder is ready and
    // stops once it took the last, so the recording holds every published step, each once,
    // from step 0 (objects.csv is written from it: one block of rows per objects message).
    assert_eq!(
        Some(recorded_frames as u64),
        s["frames"].as_u64(),
        "every published frame recorded once: {topics:?}"
    );
    let csv_frames = check_objects_csv(out, s, names, true);
    assert_eq!(Some(&csv_frames), topics.get("/objects"), "{topics:?}");
}

#[test]
fn builtin_scene_runs_in_both_modes_with_the_same_summary_keys() {
    let dir = tempfile::tempdir().unwrap();
    let (multi, single) = (dir.path().join("multi"), dir.path().join("single"));
    let names = ["table", "jelly", "snow"];
    let s = run("run_builtin", &["--duration-s", "0.1"], &multi);
    check_multi_process(
        &multi,
        &s,
        &names[..s["objects"].as_u64().unwrap() as usize],
    );

    let t = run(
        "run_builtin_in_process",
        &["--duration-s", "0.1", "--in-process"],
        &single,
    );
    assert_eq!(t["mode"], "in-process");
    let keys = |v: &serde_json::Value| {
        let mut k: Vec<String> = v.as_object().unwrap().keys().cloned().collect();
        k.sort();
        k
    };
    assert_eq!(keys(&s), keys(&t), "both modes write the same summary keys");
    let frames = check_objects_csv(
        &single,
        &t,
        &names[..t["objects"].as_u64().unwrap() as usize],
        true,
    );
    assert_eq!(
        frames as u64,
        t["frames"].as_u64().unwrap() + 1,
        "initial frame + one per step"
    );
    // The same scene: same particles, objects and masses in both modes.
    assert_eq!(s["particles"], t["particles"]);
    let (a, b) = (
        read_csv(&multi.join("objects.csv")),
        read_csv(&single.join("objects.csv")),
    );
    // Both modes step the same adapter and results do not depend on the thread count, so every
    // recorded row equals the in-process row of the same step and object, to the last digit.
    let by_key: HashMap<(String, String), &splatphys_tests::Row> = b
        .iter()
        .map(|r| ((r["step"].clone(), r["object"].clone()), r))
        .collect();
    for ra in &a {
        let rb = by_key[&(ra["step"].clone(), ra["object"].clone())];
        assert_eq!(ra, rb, "multi-process and in-process rows differ");
    }
    // The recording ends with the last step.
    let last = |rows: &[splatphys_tests::Row]| rows.last().map(|r| r["step"].clone());
    assert_eq!(last(&a), last(&b), "the recording holds the final state");
}

#[test]
fn captured_guitar_scene_runs_end_to_end() {
    let scene = splatphys_tests::workspace().join("scenes/guitar_topple.toml");
    let data = splatphys_tests::workspace().join("../shared/data");
    if !data.exists() {
        eprintln!("skipped: {} is not beside the checkout", data.display());
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("guitar");
    let s = run(
        "run_guitar",
        &[scene.to_str().unwrap(), "--duration-s", "0.2"],
        &out,
    );
    let names: Vec<String> = read_csv(&out.join("objects.csv"))
        .iter()
        .take(s["objects"].as_u64().unwrap() as usize)
        .map(|r| r["name"].clone())
        .collect();
    assert!(
        names.iter().all(|n| !n.is_empty()),
        "every object is named: {names:?}"
    );
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    check_multi_process(&out, &s, &names);
}

#[test]
fn scene_cameras_at_negative_zero_and_exponent_coordinates_reach_the_renderer() {
    // Regression: a camera at x = -0.7 was forwarded as `--camera-pos -0.7,...`, which the
    // renderer's parser read as an unknown flag `-0`.
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("cameras.toml");
    std::fs::write(
        &scene,
        r#"[simulation]
duration_s = 0.05
frame_rate_hz = 60.0
grid_dx_m = 0.02
gravity_m_s2 = [0.0, 0.0, -9.81]
domain_m = [[-0.5, -0.5, -0.1], [0.5, 0.5, 0.5]]

[[object]]
name = "ball"
shape = { sphere = { center_m = [0.0, 0.0, 0.1], radius_m = 0.08 } }
spacing_m = 0.01
color = [0.9, 0.2, 0.2]
material = { model = "jelly", youngs_modulus_pa = 1e5, poisson_ratio = 0.3, density_kg_m3 = 1000.0 }

[[camera]]
name = "negative"
position_m = [-0.7, -0.5, 0.35]
look_at_m = [-0.0, 1e-3, -2.5e-2]
up = [-0.0, 0.0, 1.0]
fov_y_deg = 4.5e1
width_px = 160
height_px = 120
"#,
    )
    .unwrap();
    let out = dir.path().join("out");
    let s = run(
        "run_cameras",
        &[scene.to_str().unwrap(), "--duration-s", "5e-2"],
        &out,
    );
    check_multi_process(&out, &s, &["ball"]);
    let frames = pngs(&out.join("frames"));
    let (w, h) = image::image_dimensions(&frames[0]).unwrap();
    assert_eq!((w, h), (160, 120), "the scene camera's image size");
}

#[test]
fn splatphys_bench_runs_the_benchmark_binary_with_its_arguments() {
    // The benchmarks are a binary of their own; `splatphys bench` forwards to it, `--help` and
    // exit status included.
    let _ = bin("splatphys-bench");
    let help = Command::new(bin("splatphys"))
        .args(["bench", "mpm", "--help"])
        .output()
        .expect("run splatphys bench");
    let text = String::from_utf8_lossy(&help.stdout);
    assert!(help.status.success(), "{text}");
    assert!(text.contains("--particles-per-axis"), "{text}");
    let bad = Command::new(bin("splatphys"))
        .args(["bench", "nonsense"])
        .output()
        .expect("run splatphys bench");
    assert_eq!(bad.status.code(), Some(2));
}
