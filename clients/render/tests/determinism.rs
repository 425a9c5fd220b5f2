//! Images are bit-identical for any thread count (per-Gaussian and per-tile work only, fixed
//! combination order), and bad input is refused or skipped without a panic.

mod common;

use common::{push, random_scene};
use glam::Vec3;
use splatphys_render::{
    Camera, CameraError, InputError, RenderError, RenderSettings, SplatView, render,
};

fn camera(w: u32, h: u32) -> Camera {
    Camera::new(Vec3::new(2.2, -1.0, 0.8), Vec3::ZERO, Vec3::Z, 50.0, w, h).unwrap()
}

#[test]
fn image_is_bit_identical_for_1_2_and_5_threads() {
    let scene = random_scene(5, 20_000, 0.6, 2);
    let view = scene.view().unwrap();
    let cam = camera(203, 157); // not a multiple of 16: partial edge tiles
    let settings = RenderSettings::default();
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| render(&view, &cam, &settings).unwrap())
    };
    let one = run(1);
    assert!(one.pixels.iter().any(|p| p[0] > 0.1), "blank image");
    for threads in [2, 5] {
        let many = run(threads);
        let same = one
            .pixels
            .iter()
            .zip(&many.pixels)
            .all(|(a, b)| a.map(f32::to_bits) == b.map(f32::to_bits));
        assert!(same, "{threads} threads differ from 1");
    }
}

#[test]
fn zero_size_image_is_refused() {
    let scene = random_scene(1, 10, 0.5, 0);
    let mut cam = camera(64, 48);
    cam.width_px = 0;
    let err = render(&scene.view().unwrap(), &cam, &RenderSettings::default()).unwrap_err();
    assert_eq!(
        err,
        RenderError::Camera(CameraError::ZeroSizeImage {
            width_px: 0,
            height_px: 48
        })
    );
    assert!(matches!(
        Camera::new(Vec3::X, Vec3::ZERO, Vec3::Z, 50.0, 64, 0),
        Err(CameraError::ZeroSizeImage { .. })
    ));
}

#[test]
fn degenerate_cameras_and_settings_are_refused() {
    // Up parallel to the view direction, look-at at the position, bad field of view.
    assert!(Camera::new(Vec3::Z, Vec3::ZERO, Vec3::Z, 50.0, 8, 8).is_err());
    assert!(Camera::new(Vec3::X, Vec3::X, Vec3::Z, 50.0, 8, 8).is_err());
    assert!(Camera::new(Vec3::X, Vec3::ZERO, Vec3::Z, 180.0, 8, 8).is_err());
    assert!(Camera::new(Vec3::X, Vec3::ZERO, Vec3::Z, f32::NAN, 8, 8).is_err());
    let scene = random_scene(1, 10, 0.5, 0);
    let settings = RenderSettings {
        near_m: -1.0,
        ..RenderSettings::default()
    };
    assert!(matches!(
        render(&scene.view().unwrap(), &camera(8, 8), &settings),
        Err(RenderError::NearPlane { .. })
    ));
}

#[test]
fn mismatched_arrays_are_refused() {
    let scene = random_scene(1, 10, 0.5, 1);
    let err = SplatView::new(
        &scene.positions,
        &scene.covariances[..9],
        &scene.opacities,
        &scene.sh,
        1,
        &[],
    )
    .unwrap_err();
    assert!(matches!(
        err,
        InputError::LengthMismatch {
            field: "covariances",
            expected: 10,
            found: 9,
            ..
        }
    ));
    // SH for degree 1 given but degree 2 claimed.
    let err = SplatView::new(
        &scene.positions,
        &scene.covariances,
        &scene.opacities,
        &scene.sh,
        2,
        &[],
    )
    .unwrap_err();
    assert!(matches!(
        err,
        InputError::LengthMismatch { field: "sh", .. }
    ));
    assert!(matches!(
        SplatView::new(&[], &[], &[], &[], 4, &[]),
        Err(InputError::ShDegree { degree: 4 })
    ));
}

#[test]
fn non_finite_and_degenerate_gaussians_are_skipped() {
    let scene = random_scene(9, 300, 0.5, 0);
    let cam = camera(80, 60);
    let settings = RenderSettings::default();
    let clean = render(&scene.view().unwrap(), &cam, &settings).unwrap();

    let mut dirty = scene.clone();
    let cov = common::covariance(glam::Quat::IDENTITY, Vec3::splat(0.05));
    let dc = [[1.0; 3]];
    push(&mut dirty, Vec3::new(f32::NAN, 0.0, 0.0), cov, 0.9, &dc);
    push(&mut dirty, Vec3::ZERO, [f32::INFINITY; 6], 0.9, &dc);
    push(&mut dirty, Vec3::ZERO, cov, f32::NAN, &dc);
    push(&mut dirty, Vec3::ZERO, cov, 0.9, &[[f32::NAN; 3]]);
    // Negative-definite and all-zero covariances: not a Gaussian; the low-pass keeps the zero one
    // as a 0.3 px² dot, the negative one has det <= 0 and is dropped.
    push(
        &mut dirty,
        Vec3::splat(5.0),
        [-1.0, 0.0, 0.0, -1.0, 0.0, -1.0],
        0.9,
        &dc,
    );
    // Behind the camera and exactly at it.
    push(&mut dirty, Vec3::new(10.0, -5.0, 4.0), cov, 0.9, &dc);
    push(&mut dirty, cam.position, cov, 0.9, &dc);
    let img = render(&dirty.view().unwrap(), &cam, &settings).unwrap();
    assert_eq!(img, clean);
}

#[test]
fn empty_scene_renders_background() {
    let settings = RenderSettings {
        background: [0.25, 0.5, 1.0],
        ..RenderSettings::default()
    };
    let view = SplatView::new(&[], &[], &[], &[], 0, &[]).unwrap();
    let img = render(&view, &camera(17, 5), &settings).unwrap();
    assert_eq!(img.pixels.len(), 17 * 5);
    assert!(img.pixels.iter().all(|p| *p == [0.25, 0.5, 1.0]));
    assert_eq!(&img.to_rgb8().data[..3], &[64, 128, 255]);
}
