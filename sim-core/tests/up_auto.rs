//! `up = "auto"`: a capture is levelled on its ground. The PlayCanvas playbot stands on a patch
//! of captured ground in a y-down frame (scenes/playbot_drop.toml levels it by hand with
//! `rotation_deg = [-90, 0, 0]`); turned by a known rotation first, it must still come out
//! ground-down within 2°, and a cloud without a ground is refused naming the key.

use std::path::Path;

use glam::{Quat, Vec3};
use splatphys_core::formats::read_gaussians;
use splatphys_core::scene::transform::{apply_similarity, euler_xyz_deg};
use splatphys_core::scene::up::{choose_up, planes_of};
use splatphys_core::scene::{SceneError, load_scene_str};

fn playbot() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/playcanvas_playbot.ply")
}

#[test]
fn the_playbot_comes_out_ground_down_however_it_is_turned() {
    let original = read_gaussians(playbot()).unwrap();
    // The ground's normal in the file is −y (the hand-made levelling).
    for turn in [
        Quat::IDENTITY,
        Quat::from_euler(glam::EulerRot::XYZ, 0.4, -1.2, 2.5),
        Quat::from_rotation_x(std::f32::consts::PI),
        Quat::from_euler(glam::EulerRot::ZYX, -0.9, 0.2, 1.6),
    ] {
        let mut cloud = original.clone();
        apply_similarity(&mut cloud, 1.0, turn, Vec3::ZERO);
        let (planes, _) = planes_of(&cloud.positions, |i| cloud.opacity(i), 0.5).unwrap();
        let l = choose_up(&planes, None, 1.0).unwrap();
        let up = euler_xyz_deg(l.rotation_deg) * (turn * Vec3::NEG_Y);
        let angle = up.angle_between(Vec3::Z).to_degrees();
        assert!(
            angle < 2.0,
            "turn {turn}: ground normal {angle:.2}° from +z"
        );
    }
}

#[test]
fn a_scene_levels_its_source_with_up_auto() {
    let text = format!(
        "[[source]]\nname = \"playbot\"\npath = {:?}\nup = \"auto\"\ntranslation_m = [0.0, 0.0, 0.01]\n",
        playbot().display().to_string()
    );
    let scene = load_scene_str(&text, Path::new(".")).unwrap();
    // Everything is background: its ground lies at z = 0.01, the robot above it.
    let mut z: Vec<f32> = scene.background.positions.iter().map(|p| p[2]).collect();
    z.sort_by(f32::total_cmp);
    let median = z[z.len() / 2];
    assert!((median - 0.01).abs() < 0.02, "median height {median}");
    assert!(
        z[z.len() * 99 / 100] > 0.3,
        "the robot stands above the ground"
    );

    let both = text.replace(
        "up = \"auto\"",
        "up = \"auto\"\nrotation_deg = [-90.0, 0.0, 0.0]",
    );
    let err = load_scene_str(&both, Path::new(".")).unwrap_err();
    assert!(err.to_string().contains("source[0].up"), "{err}");
}

#[test]
fn a_source_without_a_ground_is_refused_naming_the_key() {
    // A ball of random centres (written here as a PLY) holds no plane.
    use rand::{Rng, SeedableRng};
    let dir = tempfile::tempdir().unwrap();
    let mut cloud = splatphys_core::gaussians::GaussianCloud::default();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    while cloud.len() < 5000 {
        let mut h = || rng.random_range(-1.0f32..1.0);
        let p = Vec3::new(h(), h(), h());
        if p.length() <= 1.0 {
            cloud.positions.push(p.to_array());
            cloud.sh_dc.push([0.0; 3]);
            cloud.opacity_logit.push(3.0);
            cloud.log_scales.push([-4.0; 3]);
            cloud.rotations_wxyz.push([1.0, 0.0, 0.0, 0.0]);
        }
    }
    let file = dir.path().join("blob.ply");
    splatphys_core::formats::ply::write_ply(&file, &cloud, &[]).unwrap();
    let text = "[[source]]\nname = \"blob\"\npath = \"blob.ply\"\nup = \"auto\"\n";
    match load_scene_str(text, dir.path()) {
        Err(e @ SceneError::Invalid { .. }) => {
            let m = e.to_string();
            assert!(
                m.contains("source[0].up") && m.contains("no dominant plane"),
                "{m}"
            );
        }
        Err(e) => panic!("expected a refusal naming source[0].up, got {e}"),
        Ok(_) => panic!("a ball of centres was levelled: expected a refusal"),
    }
}
