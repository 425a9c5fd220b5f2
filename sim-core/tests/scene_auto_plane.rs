//! `plane = "auto"` on a collider: the support plane automatic selection finds, here the
//! captured ground under the playbot robot (../shared/data).

use std::path::Path;

use splatphys_core::scene::{ColliderShape, SceneError, load_scene_str};

fn scene_text(plane: &str) -> Option<(String, std::path::PathBuf)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data");
    let file = dir.join("playcanvas_playbot.ply");
    if !file.exists() {
        eprintln!("skipped: {} not found", file.display());
        return None;
    }
    let text = format!(
        r#"
[[source]]
name = "playbot"
path = "{}"
rotation_deg = [-90.0, 0.0, 0.0]

[[collider]]
name = "ground"
plane = {plane}
"#,
        file.display()
    );
    Some((text, dir))
}

#[test]
fn auto_finds_the_captured_ground() {
    let Some((text, dir)) = scene_text("\"auto\"") else {
        return;
    };
    let scene = load_scene_str(&text, &dir).expect("scene");
    let ColliderShape::Plane { point_m, normal } = scene.colliders[0].shape else {
        panic!("not a plane");
    };
    println!("auto plane: point {point_m:?}, normal {normal:?}");
    // The ground patch is level (z up after the rotation) with its Gaussians between z = 0 and
    // 0.06 m (median 0.027 m); the robot stands above it.
    assert!(normal[2] > 0.99, "normal {normal:?}");
    let height = point_m[0] * normal[0] + point_m[1] * normal[1] + point_m[2] * normal[2];
    assert!((-0.01..0.06).contains(&height), "height {height}");
}

#[test]
fn an_unknown_keyword_is_refused_with_its_key() {
    let Some((text, dir)) = scene_text("\"floor\"") else {
        return;
    };
    let err = load_scene_str(&text, &dir).expect_err("refused");
    let msg = err.to_string();
    assert!(matches!(err, SceneError::Invalid { .. }), "{err:?}");
    assert!(
        msg.contains("collider[0].plane") && msg.contains("auto"),
        "{msg}"
    );
}
