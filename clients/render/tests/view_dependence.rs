//! View-dependent colour: SH degree 1 evaluated along the camera-to-Gaussian direction, rotated
//! into the Gaussian's frame by Rᵀ (3DGS `computeColorFromSH`; PhysGaussian's rotated SH), and
//! the invariance "rotating the input through F renders the same as rotating the camera by F⁻¹".

mod common;

use common::{covariance, mat_from6, push, random_scene, sym6};
use glam::{Mat3, Quat, Vec3};
use splatphys_render::sh::SH_C1;
use splatphys_render::{Camera, ImageF32, RenderSettings, Splats, render};

fn camera_at(position: Vec3) -> Camera {
    Camera::new(position, Vec3::ZERO, Vec3::Z, 40.0, 33, 33).unwrap()
}

/// One degree-1 Gaussian at the origin: DC = 0 and a red/blue gradient along x, green along y.
/// Colour = 0.5 − C1 y sh₁ + C1 z sh₂ − C1 x sh₃ for the unit direction (x, y, z) from the camera.
fn gradient_gaussian() -> Splats {
    let mut s = Splats {
        sh_degree: 1,
        ..Splats::default()
    };
    let sh = [[0.0; 3], [0.0, -0.8, 0.0], [0.0; 3], [-0.6, 0.0, 0.6]];
    push(
        &mut s,
        Vec3::ZERO,
        covariance(Quat::IDENTITY, Vec3::splat(0.05)),
        0.5,
        &sh,
    );
    s
}

fn centre(img: &ImageF32) -> [f32; 3] {
    img.get(16, 16).unwrap()
}

fn assert_rgb(got: [f32; 3], expected: [f32; 3], what: &str) {
    for ch in 0..3 {
        assert!(
            (got[ch] - expected[ch]).abs() < 1e-4,
            "{what}: {got:?} vs {expected:?}"
        );
    }
}

#[test]
fn sh_degree_1_colour_follows_view_direction() {
    let s = gradient_gaussian();
    let settings = RenderSettings::default();
    let o = 0.5; // α at the centre, black background: C = o · colour
    // From +x the direction is (−1, 0, 0): colour = 0.5 + C1 sh₃; from −x, 0.5 − C1 sh₃.
    let from_px =
        centre(&render(&s.view().unwrap(), &camera_at(3.0 * Vec3::X), &settings).unwrap());
    let c = [0.5 - 0.6 * SH_C1, 0.5, 0.5 + 0.6 * SH_C1];
    assert_rgb(from_px, c.map(|v| o * v), "from +x");
    let from_nx =
        centre(&render(&s.view().unwrap(), &camera_at(-3.0 * Vec3::X), &settings).unwrap());
    let c = [0.5 + 0.6 * SH_C1, 0.5, 0.5 - 0.6 * SH_C1];
    assert_rgb(from_nx, c.map(|v| o * v), "from -x");
    // From +y the direction is (0, −1, 0): colour = 0.5 − C1·(−1)·sh₁ = 0.5 + C1 sh₁.
    let from_py =
        centre(&render(&s.view().unwrap(), &camera_at(3.0 * Vec3::Y), &settings).unwrap());
    assert_rgb(
        from_py,
        [0.5, 0.5 - 0.8 * SH_C1, 0.5].map(|v| o * v),
        "from +y",
    );
    // Degree capped at 0: the view dependence disappears.
    let flat = RenderSettings {
        max_sh_degree: 0,
        ..settings
    };
    let c = centre(&render(&s.view().unwrap(), &camera_at(3.0 * Vec3::X), &flat).unwrap());
    assert_rgb(c, [0.25; 3], "degree capped at 0");
}

#[test]
fn sh_rotation_turns_view_direction_into_gaussian_frame() {
    // R = 180° about z: seen from +x, the Gaussian shows the side it showed to −x before.
    let mut s = gradient_gaussian();
    let q = Quat::from_rotation_z(std::f32::consts::PI);
    s.rotations = vec![[q.w, q.x, q.y, q.z]];
    let settings = RenderSettings::default();
    let rotated =
        centre(&render(&s.view().unwrap(), &camera_at(3.0 * Vec3::X), &settings).unwrap());
    let c = [0.5 + 0.6 * SH_C1, 0.5, 0.5 - 0.6 * SH_C1];
    assert_rgb(rotated, c.map(|v| 0.5 * v), "rotated, from +x");
}

/// Rotates positions, covariances (F Σ Fᵀ) and, when `with_r`, passes R = F for SH.
fn rotate_scene(s: &Splats, f: Quat, with_r: bool) -> Splats {
    let m = Mat3::from_quat(f);
    let mut out = s.clone();
    for (p, c) in out.positions.iter_mut().zip(out.covariances.iter_mut()) {
        *p = (m * Vec3::from(*p)).to_array();
        *c = sym6(m * mat_from6(*c) * m.transpose());
    }
    out.rotations = if with_r {
        vec![[f.w, f.x, f.y, f.z]; s.positions.len()]
    } else {
        Vec::new()
    };
    out
}

fn max_abs_diff(a: &ImageF32, b: &ImageF32) -> f32 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |ch| (p[ch] - q[ch]).abs()))
        .fold(0.0, f32::max)
}

#[test]
fn rotating_input_matches_rotating_camera_the_opposite_way() {
    let scene = random_scene(11, 400, 0.5, 3);
    let f = Quat::from_axis_angle(Vec3::new(0.3, -0.5, 0.8).normalize(), 0.9);
    let camera = Camera::new(
        Vec3::new(2.5, 0.8, 0.6),
        Vec3::new(0.05, -0.02, 0.0),
        Vec3::Z,
        45.0,
        96,
        72,
    )
    .unwrap();
    let settings = RenderSettings {
        background: [0.2, 0.3, 0.4],
        ..RenderSettings::default()
    };
    let moved = render(
        &rotate_scene(&scene, f, true).view().unwrap(),
        &camera,
        &settings,
    )
    .unwrap();
    let back = camera.rotated_about(Vec3::ZERO, Mat3::from_quat(f.inverse()));
    let reference = render(&scene.view().unwrap(), &back, &settings).unwrap();
    // Same maths in different float order: differences come from rounding (~1e-6 relative)
    // except at pixels where a Gaussian's 3σ tile rectangle or the α >= 1/255 cut flips, where
    // one Gaussian's faint edge (α ~ o e^-4.5 ~ 0.01) may appear or not.
    let diff = max_abs_diff(&moved, &reference);
    let mean: f32 = moved
        .pixels
        .iter()
        .zip(&reference.pixels)
        .map(|(p, q)| (0..3).map(|ch| (p[ch] - q[ch]).abs()).sum::<f32>())
        .sum::<f32>()
        / (3 * moved.pixels.len()) as f32;
    assert!(diff < 0.02, "max difference {diff}");
    assert!(mean < 1e-4, "mean difference {mean}");

    // Without R the SH are evaluated in the wrong frame: the images must differ clearly, or the
    // check above would not be testing the rotation of view directions.
    let no_r = render(
        &rotate_scene(&scene, f, false).view().unwrap(),
        &camera,
        &settings,
    )
    .unwrap();
    assert!(max_abs_diff(&no_r, &reference) > 0.1);
}
