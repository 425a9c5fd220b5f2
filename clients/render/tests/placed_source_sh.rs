//! A source placed with `rotation_deg` keeps its view-dependent colour: its SH coefficients are
//! rotated with it (`splatphys_core::gaussians::sh_rotation`), checked here against the
//! renderer's own SH evaluation and through the whole path scene file -> placed cloud -> image.

mod common;

use std::path::Path;

use common::SplitMix;
use glam::{Mat3, Quat, Vec3};
use splatphys_core::formats::ply::write_ply;
use splatphys_core::gaussians::GaussianCloud;
use splatphys_core::gaussians::sh_rotation::rotate_cloud_sh;
use splatphys_core::scene::load_scene_str;
use splatphys_core::scene::transform::euler_xyz_deg;
use splatphys_render::sh::eval_sh;
use splatphys_render::{Camera, ImageF32, RenderSettings, Splats, render};

/// `n` random Gaussians in a cube of half-size `half_m`, with `rest_len` random `f_rest_*`
/// values each (9, 24 or 45: SH degree 1, 2 or 3), σ 8-40 mm, opacities 0.3-0.95.
fn random_cloud(seed: u64, n: usize, half_m: f32, rest_len: usize) -> GaussianCloud {
    let mut rng = SplitMix(seed);
    let mut cloud = GaussianCloud::with_capacity(n, rest_len);
    for _ in 0..n {
        cloud.positions.push([
            rng.range(-half_m, half_m),
            rng.range(-half_m, half_m),
            rng.range(-half_m, half_m),
        ]);
        cloud.sh_dc.push([
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        ]);
        cloud
            .sh_rest
            .extend((0..rest_len).map(|_| rng.range(-0.5, 0.5)));
        let o = rng.range(0.3, 0.95);
        cloud.opacity_logit.push((o / (1.0 - o)).ln());
        cloud.log_scales.push([
            rng.range(0.008, 0.04).ln(),
            rng.range(0.008, 0.04).ln(),
            rng.range(0.008, 0.04).ln(),
        ]);
        let q = rng.unit_quat();
        cloud.rotations_wxyz.push([q.w, q.x, q.y, q.z]);
    }
    cloud
}

fn random_unit(rng: &mut SplitMix) -> Vec3 {
    loop {
        let v = Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        if (0.1..=1.0).contains(&v.length()) {
            return v.normalize();
        }
    }
}

#[test]
fn rotated_sh_evaluates_like_the_original_towards_the_rotated_direction() {
    let mut rng = SplitMix(5);
    for (degree, rest_len) in [(1u8, 9usize), (2, 24), (3, 45)] {
        let original = random_cloud(degree as u64, 40, 0.1, rest_len);
        assert_eq!(original.sh_degree, degree);
        for _ in 0..5 {
            let q = rng.unit_quat();
            let r = Mat3::from_quat(q);
            let mut rotated = original.clone();
            rotate_cloud_sh(&mut rotated, q);
            for i in 0..original.len() {
                let (before, after) = (original.sh_coefficients(i), rotated.sh_coefficients(i));
                for _ in 0..8 {
                    let d = random_unit(&mut rng);
                    let want = eval_sh(degree, &before, d);
                    let got = eval_sh(degree, &after, r * d);
                    // The renderer's f32 evaluation of ~16 terms of size <= ~2 and the rotated
                    // coefficients rounded to f32: errors of a few 1e-7.
                    for ch in 0..3 {
                        assert!(
                            (got[ch] - want[ch]).abs() < 1e-5,
                            "degree {degree}, Gaussian {i}: {got:?} vs {want:?}"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn sh_rotation_by_identity_is_a_no_op_and_the_inverse_round_trips() {
    let original = random_cloud(9, 50, 0.1, 45);
    let mut same = original.clone();
    rotate_cloud_sh(&mut same, Quat::IDENTITY);
    assert_eq!(same, original);

    let q = euler_xyz_deg([-90.0, 30.0, 125.0]);
    let mut there_and_back = original.clone();
    rotate_cloud_sh(&mut there_and_back, q);
    assert_ne!(there_and_back.sh_rest, original.sh_rest);
    rotate_cloud_sh(&mut there_and_back, q.inverse());
    // Two f32 roundings of values <= 0.5 after f64 arithmetic: a few 1e-8.
    for (a, b) in there_and_back.sh_rest.iter().zip(&original.sh_rest) {
        assert!((a - b).abs() < 1e-6, "{a} vs {b}");
    }
}

fn max_abs_diff(a: &ImageF32, b: &ImageF32) -> f32 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |ch| (p[ch] - q[ch]).abs()))
        .fold(0.0, f32::max)
}

fn mean_abs_diff(a: &ImageF32, b: &ImageF32) -> f32 {
    let sum: f32 = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| (0..3).map(|ch| (p[ch] - q[ch]).abs()).sum::<f32>())
        .sum();
    sum / (3 * a.pixels.len()) as f32
}

/// The one source's Gaussians of a scene file that places `cloud.ply` from `dir` with
/// `placement` (TOML keys of `[[source]]`); no objects, so all of it is background.
fn placed(dir: &Path, placement: &str) -> GaussianCloud {
    let text = format!("[[source]]\nname = \"capture\"\npath = \"cloud.ply\"\n{placement}\n");
    load_scene_str(&text, dir).unwrap().background
}

#[test]
fn rotated_source_renders_as_the_file_seen_from_the_rotated_camera() {
    let dir = tempfile::tempdir().unwrap();
    let file = random_cloud(21, 400, 0.3, 24);
    assert_eq!(file.sh_degree, 2);
    write_ply(dir.path().join("cloud.ply"), &file, &[]).unwrap();

    let rotation_deg = [-90.0, 25.0, 40.0];
    let translation = Vec3::new(0.3, -0.2, 0.5);
    let unrotated = placed(dir.path(), "");
    let rotated = placed(
        dir.path(),
        &format!(
            "rotation_deg = {rotation_deg:?}\ntranslation_m = {:?}",
            translation.to_array()
        ),
    );
    assert_eq!(unrotated, file, "no placement keeps the file's values");

    let settings = RenderSettings {
        background: [0.2, 0.3, 0.4],
        ..RenderSettings::default()
    };
    let camera = Camera::new(
        Vec3::new(2.0, 0.9, 0.7),
        Vec3::new(0.02, -0.03, 0.0),
        Vec3::Z,
        45.0,
        96,
        72,
    )
    .unwrap();
    let r = Mat3::from_quat(euler_xyz_deg(rotation_deg));
    let moved_camera = Camera::new(
        r * camera.position + translation,
        r * camera.look_at + translation,
        r * camera.up,
        camera.fov_y_deg,
        camera.width_px,
        camera.height_px,
    )
    .unwrap();
    let image = |cloud: &GaussianCloud, camera: &Camera| {
        render(
            &Splats::from_cloud(cloud).view().unwrap(),
            camera,
            &settings,
        )
        .unwrap()
    };
    let reference = image(&unrotated, &camera);
    let seen_rotated = image(&rotated, &moved_camera);
    // Same maths on values rotated in f32 (centres, quaternions, SH): differences come from
    // rounding (~1e-6 relative) except at pixels where a Gaussian's 3σ tile rectangle or the
    // α >= 1/255 cut flips, where one faint edge (α ~ o e^-4.5 ~ 0.01) may appear or not.
    let (max, mean) = (
        max_abs_diff(&seen_rotated, &reference),
        mean_abs_diff(&seen_rotated, &reference),
    );
    assert!(max < 0.02, "max difference {max}");
    assert!(mean < 1e-4, "mean difference {mean}");

    // With the file's SH left unrotated the view-dependent colour is wrong: the images differ
    // clearly, so the check above does test the SH rotation.
    let stale_sh = GaussianCloud {
        sh_rest: file.sh_rest.clone(),
        ..rotated
    };
    let stale = max_abs_diff(&image(&stale_sh, &moved_camera), &reference);
    assert!(stale > 0.1, "unrotated SH differ by only {stale}");
}
