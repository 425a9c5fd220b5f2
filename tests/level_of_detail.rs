//! `splatphys run --budget-fps` and `--spacing-from`: the calibration's record in summary.json,
//! a recorded level of detail reproduced exactly by a later run (in either mode, on another
//! thread count), and clear errors for files that hold none. No timing is asserted: which
//! candidate meets a budget depends on the machine, so the budgets here are either unreachable
//! or trivially met.

use std::collections::HashMap;
use std::path::Path;
use std::process::{Command, Output};

use splatphys_tests::{Row, bin, iox_prefix, leftovers, read_csv};

/// A 5 cm jelly sphere dropping onto a floor, on a 10 mm grid: its thinnest extent (9.5 cm
/// between the outer Gaussians) keeps 3 cells across up to a 30 mm grid.
const SCENE: &str = r#"
[simulation]
duration_s = 0.12
frame_rate_hz = 100.0
grid_dx_m = 0.01
domain_m = [[-0.3, -0.3, -0.05], [0.3, 0.3, 0.4]]

[[object]]
name = "ball"
shape = { sphere = { center_m = [0.0, 0.0, 0.08], radius_m = 0.05 } }
spacing_m = 0.005
material = { model = "jelly", youngs_modulus_pa = 2e5, poisson_ratio = 0.3, density_kg_m3 = 1000.0 }

[[collider]]
name = "floor"
plane = { point_m = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0] }
surface = "separate"

[[camera]]
name = "main"
position_m = [0.6, -0.6, 0.4]
look_at_m = [0.0, 0.0, 0.05]
"#;

fn splatphys(test: &str, args: &[&str], out: &Path) -> Output {
    let iox = iox_prefix(test);
    let o = Command::new(bin("splatphys"))
        .arg("run")
        .args(args)
        .arg("--out")
        .arg(out)
        .env("SPLATPHYS_IOX2_PREFIX", &iox)
        .output()
        .expect("splatphys runs");
    assert!(leftovers(&iox).is_empty(), "{:?}", leftovers(&iox));
    o
}

/// Runs `splatphys run` and returns its summary; fails the test unless it exits 0.
fn run(test: &str, args: &[&str], out: &Path) -> serde_json::Value {
    let o = splatphys(test, args, out);
    assert!(
        o.status.success(),
        "splatphys run {args:?}:\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let text = std::fs::read_to_string(out.join("summary.json")).expect("summary.json");
    serde_json::from_str(&text).expect("summary.json is JSON")
}

/// Writes [`SCENE`] into `dir`; returns its path.
fn ball_scene(dir: &Path) -> String {
    let path = dir.join("ball.toml");
    std::fs::write(&path, SCENE).unwrap();
    path.to_str().unwrap().to_owned()
}

fn rows_by_key(path: &Path) -> HashMap<(String, String), Row> {
    read_csv(path)
        .into_iter()
        .map(|r| ((r["step"].clone(), r["object"].clone()), r))
        .collect()
}

#[test]
fn a_calibrated_level_of_detail_is_recorded_and_reproduced_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let scene = ball_scene(dir.path());
    let (a, b, c) = (
        dir.path().join("a"),
        dir.path().join("b"),
        dir.path().join("c"),
    );

    // An unreachable budget: every candidate is measured, the fastest is taken, flagged.
    let sa = run(
        "lod_calibrate",
        &[
            &scene,
            "--in-process",
            "--threads",
            "2",
            "--budget-fps",
            "1e9",
            "--calibrate-s",
            "0.1",
            "--calibrate-errors",
        ],
        &a,
    );
    let lod = &sa["level_of_detail"];
    assert_eq!(lod["source"], "calibrated");
    let cal = &lod["calibration"];
    assert_eq!(cal["budget_met"], false);
    assert_eq!(cal["errors"], true);
    assert_eq!(cal["window_s"], 0.1);
    assert_eq!(cal["threads"], 2);
    let candidates = cal["candidates"].as_array().unwrap();
    let dxs: Vec<f64> = candidates
        .iter()
        .map(|k| k["grid_dx_m"].as_f64().unwrap())
        .collect();
    let want = [0.01, 0.015, 0.02, 0.03];
    assert_eq!(dxs.len(), want.len(), "{dxs:?}");
    for (d, w) in dxs.iter().zip(want) {
        assert!((d - w).abs() < 1e-9, "{dxs:?}");
    }
    // The first candidate is the scene as written: its own reference, so no error.
    assert_eq!(candidates[0]["com_error_m"], 0.0);
    assert!(candidates[0]["objects"][0]["physics_spacing_m"].is_null());
    for k in &candidates[1..] {
        let (dx, h, cell) = (
            k["grid_dx_m"].as_f64().unwrap(),
            k["objects"][0]["physics_spacing_m"].as_f64().unwrap(),
            k["cells_m"][0].as_f64().unwrap(),
        );
        assert!((h - dx / 2.0).abs() < 1e-6, "spacing {h} at dx {dx}");
        // The ball gets a grid of its own; the scene's grid stays as written.
        assert_eq!(cell, dx);
        assert_eq!(k["objects"][0]["grid_dx_m"].as_f64(), Some(dx));
        // The ball reaches the floor at 0.078 s, within the window: coarser grids deform it
        // differently.
        assert!(k["com_error_m"].as_f64().unwrap() > 0.0, "{k}");
    }
    let chosen: Vec<&serde_json::Value> =
        candidates.iter().filter(|k| k["chosen"] == true).collect();
    assert_eq!(chosen.len(), 1, "{candidates:?}");
    let best = candidates
        .iter()
        .map(|k| k["frames_per_wall_s"].as_f64().unwrap())
        .fold(0.0, f64::max);
    assert_eq!(chosen[0]["frames_per_wall_s"].as_f64().unwrap(), best);
    assert_eq!(lod["chosen"]["objects"], chosen[0]["objects"]);
    assert_eq!(
        lod["chosen"]["grid_dx_m"], 0.01,
        "the scene's grid as written"
    );
    assert_eq!(
        lod["chosen"]["collision_dx_m"], 0.01,
        "collision surfaces keep their cell"
    );
    // The expected error is the chosen candidate's, over the calibration window.
    let expected = &cal["expected_error"];
    assert_eq!(expected["window_s"], 0.1);
    assert_eq!(expected["com_error_m"], chosen[0]["com_error_m"]);

    // The recorded level, on one thread: the same run, row for row.
    let sb = run(
        "lod_from_summary",
        &[
            &scene,
            "--in-process",
            "--threads",
            "1",
            "--spacing-from",
            a.join("summary.json").to_str().unwrap(),
        ],
        &b,
    );
    assert_eq!(sb["level_of_detail"]["chosen"], lod["chosen"]);
    assert!(sb["level_of_detail"]["calibration"].is_null());
    assert!(
        sb["level_of_detail"]["source"]
            .as_str()
            .unwrap()
            .starts_with("from "),
        "{}",
        sb["level_of_detail"]
    );
    assert_eq!(sa["particles"], sb["particles"]);
    assert_eq!(
        std::fs::read_to_string(a.join("objects.csv")).unwrap(),
        std::fs::read_to_string(b.join("objects.csv")).unwrap(),
        "--spacing-from reproduces the calibrated run"
    );

    // Across processes: the server is given the level chosen by the parent.
    let sc = run(
        "lod_multi_process",
        &[
            &scene,
            "--threads",
            "2",
            "--spacing-from",
            a.join("summary.json").to_str().unwrap(),
        ],
        &c,
    );
    assert_eq!(sc["level_of_detail"]["chosen"], lod["chosen"]);
    assert_eq!(sa["particles"], sc["particles"]);
    let written: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(c.join("level_of_detail.json")).unwrap())
            .unwrap();
    assert_eq!(written, lod["chosen"]);
    let (ra, rc) = (
        rows_by_key(&a.join("objects.csv")),
        rows_by_key(&c.join("objects.csv")),
    );
    assert!(!rc.is_empty());
    for (key, row) in &rc {
        assert_eq!(
            Some(row),
            ra.get(key),
            "row {key:?} differs between the modes"
        );
    }
}

#[test]
fn a_budget_the_scene_already_meets_keeps_it_as_written() {
    let dir = tempfile::tempdir().unwrap();
    let scene = ball_scene(dir.path());
    let out = dir.path().join("out");
    let s = run(
        "lod_met",
        &[
            &scene,
            "--in-process",
            "--threads",
            "2",
            "--budget-fps",
            "1e-3",
            "--calibrate-s",
            "0.03",
        ],
        &out,
    );
    let lod = &s["level_of_detail"];
    assert_eq!(lod["calibration"]["budget_met"], true);
    assert_eq!(
        lod["calibration"]["candidates"].as_array().unwrap().len(),
        1
    );
    assert_eq!(lod["chosen"]["grid_dx_m"], 0.01);
    assert!(lod["chosen"]["objects"][0]["physics_spacing_m"].is_null());
    // Without --calibrate-errors no candidate's error is measured; the scene as written costs
    // none.
    assert!(lod["calibration"]["candidates"][0]["com_error_m"].is_null());
    assert_eq!(lod["calibration"]["expected_error"]["com_error_m"], 0.0);
}

#[test]
fn an_unreachable_budget_stops_every_calibration_run_early_and_takes_the_fastest() {
    let dir = tempfile::tempdir().unwrap();
    let scene = ball_scene(dir.path());
    let out = dir.path().join("out");
    let s = run(
        "lod_unreachable",
        &[
            &scene,
            "--in-process",
            "--threads",
            "2",
            "--budget-fps",
            "1e9",
        ],
        &out,
    );
    let cal = &s["level_of_detail"]["calibration"];
    assert_eq!(cal["budget_met"], false);
    assert_eq!(cal["errors"], false);
    // The whole scene is the default window.
    assert_eq!(cal["window_s"], 0.12);
    let candidates = cal["candidates"].as_array().unwrap();
    assert_eq!(candidates.len(), 4, "{candidates:?}");
    let fps: Vec<f64> = candidates
        .iter()
        .map(|k| k["frames_per_wall_s"].as_f64().unwrap())
        .collect();
    assert!(fps.iter().all(|f| f.is_finite() && *f > 0.0), "{fps:?}");
    let best = fps.iter().copied().fold(0.0, f64::max);
    let chosen: Vec<&serde_json::Value> =
        candidates.iter().filter(|k| k["chosen"] == true).collect();
    assert_eq!(chosen.len(), 1);
    assert_eq!(chosen[0]["frames_per_wall_s"].as_f64().unwrap(), best);
    // The chosen level's error, over the default 0.2 s (clamped to the scene's 0.12 s).
    let expected = &cal["expected_error"];
    assert_eq!(expected["window_s"], 0.12);
    let com = expected["com_error_m"].as_f64().unwrap();
    if chosen[0]["grid_dx_m"] == 0.01 {
        assert_eq!(com, 0.0);
    } else {
        // Measured, and less than the ball's diameter (the coarse run did not blow up).
        assert!(com > 0.0 && com < 0.1, "{expected}");
    }
    // The run itself still covers the whole scene.
    assert_eq!(s["frames"], 12);
}

#[test]
fn spacing_from_a_file_without_a_fitting_level_of_detail_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let scene = ball_scene(dir.path());
    let cases = [
        (
            "none.json",
            r#"{"level_of_detail": null}"#,
            "records no level of detail",
        ),
        ("text.json", "not json", "is not JSON"),
        (
            "other.json",
            r#"{"grid_dx_m": 0.02, "collision_dx_m": 0.01, "objects": [{"name": "cube", "physics_spacing_m": 0.01}]}"#,
            "the scene has no object \"cube\"",
        ),
        (
            "zero.json",
            r#"{"grid_dx_m": 0.0, "collision_dx_m": 0.01, "objects": [{"name": "ball", "physics_spacing_m": null}]}"#,
            "grid_dx_m = 0 must be a positive number",
        ),
    ];
    for (file, text, want) in cases {
        let path = dir.path().join(file);
        std::fs::write(&path, text).unwrap();
        let out = dir.path().join(file.replace(".json", ""));
        let o = splatphys(
            "lod_bad",
            &[
                &scene,
                "--in-process",
                "--spacing-from",
                path.to_str().unwrap(),
            ],
            &out,
        );
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{file}: accepted");
        assert!(err.contains(want), "{file}: {err}");
        assert!(
            err.contains(file),
            "{file}: the error names the file: {err}"
        );
    }
}

/// Two jelly balls (radius 5 cm and 3 cm) on a 10 mm grid: the big one's ladder is 10, 15, 20 and
/// 30 mm, the small one's (5.5 cm between its outer Gaussians) stops at 15 mm.
const TWO_BALLS: &str = r#"
[simulation]
duration_s = 0.06
frame_rate_hz = 100.0
grid_dx_m = 0.01
domain_m = [[-0.3, -0.3, -0.05], [0.3, 0.3, 0.4]]

[[object]]
name = "big"
shape = { sphere = { center_m = [-0.1, 0.0, 0.08], radius_m = 0.05 } }
spacing_m = 0.005
material = { model = "jelly", youngs_modulus_pa = 2e5, poisson_ratio = 0.3, density_kg_m3 = 1000.0 }

[[object]]
name = "small"
shape = { sphere = { center_m = [0.1, 0.0, 0.08], radius_m = 0.03 } }
spacing_m = 0.005
material = { model = "jelly", youngs_modulus_pa = 2e5, poisson_ratio = 0.3, density_kg_m3 = 1000.0 }

[[collider]]
name = "floor"
plane = { point_m = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0] }
surface = "separate"
"#;

#[test]
fn each_deformable_object_has_its_own_ladder_and_its_own_time_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("two.toml");
    std::fs::write(&scene, TWO_BALLS).unwrap();
    let out = dir.path().join("out");
    let s = run(
        "lod_two",
        &[
            scene.to_str().unwrap(),
            "--in-process",
            "--threads",
            "2",
            "--budget-fps",
            "1e9",
            "--error-window-s",
            "0",
        ],
        &out,
    );
    let lod = &s["level_of_detail"];
    let candidates = lod["calibration"]["candidates"].as_array().unwrap();
    let cells: Vec<Vec<f64>> = candidates
        .iter()
        .map(|k| {
            k["cells_m"]
                .as_array()
                .unwrap()
                .iter()
                .map(|c| (c.as_f64().unwrap() * 1e4).round() / 10.0)
                .collect()
        })
        .collect();
    // Uniform steps only (the budget is unreachable): the small ball stays at the bottom of
    // its ladder while the big one goes on.
    assert_eq!(
        cells,
        [[10.0, 10.0], [15.0, 15.0], [20.0, 15.0], [30.0, 15.0]],
        "{candidates:?}"
    );
    // Each object gets its own grid in the chosen level; the scene's grid stays as written.
    assert_eq!(lod["chosen"]["grid_dx_m"], 0.01);
    let chosen = lod["chosen"]["objects"].as_array().unwrap();
    assert_eq!(chosen.len(), 2);
    assert!(chosen.iter().all(|o| o["grid_dx_m"].as_f64().is_some()));

    // A budget the scene meets: its one calibration run goes to the end, and each object's
    // own MPM time per frame is recorded (none when a run stops within its first frame).
    let out = dir.path().join("met");
    let s = run(
        "lod_two_met",
        &[
            scene.to_str().unwrap(),
            "--in-process",
            "--budget-fps",
            "1e-3",
            "--error-window-s",
            "0",
        ],
        &out,
    );
    let candidates = s["level_of_detail"]["calibration"]["candidates"]
        .as_array()
        .unwrap();
    assert_eq!(candidates.len(), 1);
    let times = candidates[0]["object_wall_s_per_frame"].as_array().unwrap();
    assert_eq!(times.len(), 2, "{}", candidates[0]);
    assert!(
        times.iter().all(|t| t.as_f64().unwrap() > 0.0),
        "each object's own MPM time is measured: {}",
        candidates[0]
    );
}
