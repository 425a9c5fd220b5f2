//! `splatphys align` on a real capture: the PlayCanvas playbot stands on a patch of captured
//! ground in a y-down frame; the scene that drops it (scenes/playbot_drop.toml) was levelled by
//! hand with `rotation_deg = [-90, 0, 0]`. The command must find the same from the ground alone.

use std::process::Command;

#[test]
fn the_playbot_ground_is_levelled_as_the_hand_made_scene_does() {
    let file = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../shared/data/playcanvas_playbot.ply"
    );
    let out = Command::new(env!("CARGO_BIN_EXE_splatphys"))
        .args(["align", file])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let toml = String::from_utf8(out.stdout).unwrap();
    let line = toml
        .lines()
        .find(|l| l.starts_with("rotation_deg"))
        .unwrap();
    let angles: Vec<f32> = line
        .trim_start_matches("rotation_deg = [")
        .trim_end_matches(']')
        .split(',')
        .map(|v| v.trim().parse().unwrap())
        .collect();
    for (got, want) in angles.iter().zip([-90.0, 0.0, 0.0]) {
        assert!((got - want).abs() < 1.0, "{line}");
    }
    // What it prints is a [[source]] table a scene file takes as it is.
    let table: toml::Value = toml::from_str(&toml).unwrap();
    assert!(table["source"][0]["translation_m"].as_array().is_some());
}
