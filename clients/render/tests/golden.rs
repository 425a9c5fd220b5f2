//! Golden image of a small procedural scene: a chequered floor of flat Gaussians and three
//! blobs (one with degree-1 SH), rendered at 96×72. `UPDATE_GOLDEN=1 cargo test -p
//! splatphys-render --test golden` rewrites `tests/golden/procedural_96x72.png`.

mod common;

use std::path::PathBuf;

use common::{SplitMix, covariance, dc_for, push};
use glam::{Quat, Vec3};
use splatphys_render::{Camera, ImageRgb8, RenderSettings, Splats, render_rgb8, write_png};

fn scene() -> Splats {
    let mut s = Splats {
        sh_degree: 1,
        ..Splats::default()
    };
    let zero = [0.0; 3];
    // Floor: 20 × 20 flat discs (σ 3 cm in plane, 2 mm thick), 5 cm apart, chequered.
    for i in 0..20 {
        for j in 0..20 {
            let p = Vec3::new(-0.5 + 0.05 * i as f32, -0.5 + 0.05 * j as f32, 0.0);
            let c = if (i / 4 + j / 4) % 2 == 0 {
                [0.85, 0.85, 0.8]
            } else {
                [0.25, 0.3, 0.35]
            };
            let cov = covariance(Quat::IDENTITY, Vec3::new(0.03, 0.03, 0.002));
            push(&mut s, p, cov, 0.9, &[dc_for(c), zero, zero, zero]);
        }
    }
    // Three blobs of 150 random Gaussians each.
    let mut rng = SplitMix(2024);
    let blobs = [
        (Vec3::new(-0.2, -0.15, 0.12), [0.9, 0.2, 0.15], 0.0),
        (Vec3::new(0.15, -0.1, 0.1), [0.2, 0.8, 0.3], 0.0),
        (Vec3::new(0.0, 0.25, 0.15), [0.5, 0.5, 0.5], 0.7),
    ];
    for (centre, colour, view_dep) in blobs {
        for _ in 0..150 {
            let offset = Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            )
            .clamp_length_max(1.0)
                * 0.1;
            let scales = Vec3::new(
                rng.range(0.01, 0.03),
                rng.range(0.01, 0.03),
                rng.range(0.01, 0.03),
            );
            let cov = covariance(rng.unit_quat(), scales);
            // Degree-1 term along x for the third blob: bluish from +x, reddish from -x.
            let sh3 = [view_dep, 0.0, -view_dep];
            push(
                &mut s,
                centre + offset,
                cov,
                rng.range(0.5, 1.0),
                &[dc_for(colour), zero, zero, sh3],
            );
        }
    }
    s
}

fn golden_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden/procedural_96x72.png")
}

#[test]
fn procedural_scene_matches_golden_image() {
    let camera = Camera::new(
        Vec3::new(1.1, -0.9, 0.7),
        Vec3::new(0.0, 0.0, 0.08),
        Vec3::Z,
        45.0,
        96,
        72,
    )
    .unwrap();
    let settings = RenderSettings {
        background: [0.05, 0.05, 0.1],
        ..RenderSettings::default()
    };
    let img = render_rgb8(&scene().view().unwrap(), &camera, &settings).unwrap();
    let path = golden_path();
    if std::env::var_os("UPDATE_GOLDEN").is_some_and(|v| v == "1") {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        write_png(&path, &img).unwrap();
        eprintln!("rewrote {}", path.display());
        return;
    }
    let golden = image::open(&path)
        .unwrap_or_else(|e| {
            panic!(
                "{}: {e}; run with UPDATE_GOLDEN=1 to create it",
                path.display()
            )
        })
        .to_rgb8();
    let golden = ImageRgb8 {
        width: golden.width(),
        height: golden.height(),
        data: golden.into_raw(),
    };
    assert_eq!((img.width, img.height), (golden.width, golden.height));
    // Tolerance: the maths is deterministic, but another CPU, libm or compiler may round exp()
    // or sums differently; that moves a channel by at most one level except where a faint
    // Gaussian edge crosses the α = 1/255 cut. Allow ±1 everywhere, a few values up to ±8.
    let diffs: Vec<i32> = img
        .data
        .iter()
        .zip(&golden.data)
        .map(|(&a, &b)| (i32::from(a) - i32::from(b)).abs())
        .collect();
    let over_1 = diffs.iter().filter(|&&d| d > 1).count();
    let max = diffs.iter().copied().max().unwrap_or(0);
    assert!(max <= 8, "max channel difference {max}");
    assert!(
        over_1 <= diffs.len() / 500,
        "{over_1} channel values differ by more than 1"
    );
    // The scene is not blank: the floor, the blobs and the background are all there.
    let distinct: std::collections::BTreeSet<[u8; 3]> = img
        .data
        .chunks_exact(3)
        .map(|p| [p[0] / 32, p[1] / 32, p[2] / 32])
        .collect();
    assert!(
        distinct.len() >= 8,
        "only {} colour classes",
        distinct.len()
    );
}
