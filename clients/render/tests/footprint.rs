//! A single Gaussian renders to its analytic screen-space footprint (EWA projection, 3DGS eq. 5
//! plus the 0.3 px² low-pass), and two overlapping Gaussians compose front to back.

mod common;

use common::{dc_for, push};
use glam::Vec3;
use splatphys_render::{Camera, RenderSettings, Splats, render};

const W: u32 = 65;
const H: u32 = 49;
const FOV_Y_DEG: f32 = 40.0;
const DIST_M: f32 = 2.0;

/// Camera on +x looking at the origin, z up: image x runs along world +y, image y along −z, and
/// the origin lands exactly on pixel (32, 24) (pixel centres at integers).
fn camera() -> Camera {
    Camera::new(
        Vec3::new(DIST_M, 0.0, 0.0),
        Vec3::ZERO,
        Vec3::Z,
        FOV_Y_DEG,
        W,
        H,
    )
    .unwrap()
}

fn focal_px() -> f32 {
    H as f32 / (2.0 * (FOV_Y_DEG.to_radians() * 0.5).tan())
}

#[test]
fn single_gaussian_matches_analytic_footprint() {
    let f = focal_px();
    // World σ chosen for 4 px along image x and 2.5 px along image y before the low-pass, plus
    // a y-z correlation so the ellipse is tilted.
    let sy = 4.0 * DIST_M / f;
    let sz = 2.5 * DIST_M / f;
    let rho = 0.4;
    let cov = [1e-6, 0.0, 0.0, sy * sy, -rho * sy * sz, sz * sz];
    let opacity = 0.8;
    let colour = [0.9, 0.6, 0.3];
    let mut s = Splats::default();
    push(&mut s, Vec3::ZERO, cov, opacity, &[dc_for(colour)]);
    let img = render(&s.view().unwrap(), &camera(), &RenderSettings::default()).unwrap();

    // Expected image-space covariance: world (y, z) -> image (u, v) = (y, -z), scaled by f/d,
    // plus the low-pass. Depth stays exactly d for the thin (1 mm) x extent: J is evaluated at the
    // centre, so the x variance does not enter on the optical axis.
    let k = f / DIST_M;
    let suu = k * k * sy * sy + 0.3;
    let svv = k * k * sz * sz + 0.3;
    let suv = k * k * rho * sy * sz; // cov(y, -z) = +ρ σy σz
    let det = suu * svv - suv * suv;
    let (cx, cy) = (32.0f32, 24.0f32);

    // Peak: α = o at the centre, T = 1, black background -> C = o · colour.
    let peak = img.get(32, 24).unwrap();
    for ch in 0..3 {
        let expected = opacity * colour[ch];
        assert!(
            (peak[ch] - expected).abs() <= 0.01 * expected,
            "peak channel {ch}: {} vs {expected}",
            peak[ch]
        );
    }

    // Every pixel where α >= 1/255 matches o · colour · exp(-½ dᵀ Σ⁻¹ d) within 1 % of the peak.
    let mut compared = 0;
    for y in 0..H {
        for x in 0..W {
            let (du, dv) = (x as f32 - cx, y as f32 - cy);
            let power = -0.5 * (svv * du * du - 2.0 * suv * du * dv + suu * dv * dv) / det;
            let alpha = opacity * power.exp();
            let got = img.get(x, y).unwrap()[0];
            if alpha >= 1.0 / 255.0 * 1.01 {
                compared += 1;
                let expected = alpha * colour[0];
                assert!(
                    (got - expected).abs() <= 0.01 * opacity * colour[0],
                    "pixel ({x}, {y}): {got} vs {expected}"
                );
            } else if alpha < 1.0 / 255.0 * 0.99 {
                assert_eq!(got, 0.0, "pixel ({x}, {y}) is outside the 1/255 footprint");
            }
        }
    }
    assert!(
        compared > 100,
        "only {compared} pixels inside the footprint"
    );

    // σ in pixels from the profiles through the centre along each image axis. Along u at v = 0
    // the fall-off is exp(-½ u² (Σ⁻¹)_uu), i.e. a Gaussian of variance det / Σ_vv (and likewise
    // along v); fitting σ from the value ratio at 2, 3 and 4 px must give it within 1 %.
    let sigma_u_cond = (det / svv).sqrt();
    let sigma_v_cond = (det / suu).sqrt();
    for (axis, sigma) in [(0, sigma_u_cond), (1, sigma_v_cond)] {
        for step in [2u32, 3, 4] {
            let (x, y) = if axis == 0 {
                (32 + step, 24)
            } else {
                (32, 24 + step)
            };
            let ratio = img.get(x, y).unwrap()[0] / peak[0];
            let fitted = step as f32 / (2.0 * (1.0 / ratio).ln()).sqrt();
            assert!(
                (fitted - sigma).abs() <= 0.01 * sigma,
                "axis {axis} step {step}: fitted σ {fitted} px vs analytic {sigma} px"
            );
        }
    }
}

/// Two Gaussians on the optical axis, red in front, blue behind.
fn red_blue(red_first: bool) -> Splats {
    let cov = common::covariance(glam::Quat::IDENTITY, Vec3::splat(0.05));
    let red = (Vec3::new(0.5, 0.0, 0.0), dc_for([1.0, 0.0, 0.0]));
    let blue = (Vec3::new(-0.5, 0.0, 0.0), dc_for([0.0, 0.0, 1.0]));
    let order = if red_first { [red, blue] } else { [blue, red] };
    let mut s = Splats::default();
    for (p, dc) in order {
        push(&mut s, p, cov, 0.95, &[dc]);
    }
    s
}

#[test]
fn front_gaussian_dominates_regardless_of_input_order() {
    let settings = RenderSettings::default();
    let a = render(&red_blue(true).view().unwrap(), &camera(), &settings).unwrap();
    let b = render(&red_blue(false).view().unwrap(), &camera(), &settings).unwrap();
    assert_eq!(a, b, "input order changed the image");
    // Front-to-back: C = α_r c_r + (1 − α_r) α_b c_b with α = 0.95 at the centre.
    let c = a.get(32, 24).unwrap();
    assert!((c[0] - 0.95).abs() < 1e-3, "red {}", c[0]);
    assert!((c[2] - 0.05 * 0.95).abs() < 1e-3, "blue {}", c[2]);

    // Seen from the other side, blue is in front.
    let behind = Camera::new(
        Vec3::new(-DIST_M, 0.0, 0.0),
        Vec3::ZERO,
        Vec3::Z,
        FOV_Y_DEG,
        W,
        H,
    )
    .unwrap();
    let c = render(&red_blue(true).view().unwrap(), &behind, &settings)
        .unwrap()
        .get(32, 24)
        .unwrap();
    assert!(
        (c[2] - 0.95).abs() < 1e-3 && (c[0] - 0.05 * 0.95).abs() < 1e-3,
        "{c:?}"
    );
}

#[test]
fn pixel_stops_before_transmittance_drops_below_1e4() {
    // Ten white layers with α = 0.95 at the centre: T goes 1 -> 0.05 -> 2.5e-3 -> 1.25e-4; the
    // fourth would take it to 6.25e-6 < 1e-4, so the pixel stops without blending it, and the
    // grey background is weighted by the T left: C = 0.95 (1 + 0.05 + 0.0025) + 1.25e-4 · 0.5.
    let cov = common::covariance(glam::Quat::IDENTITY, Vec3::splat(0.3));
    let mut s = Splats::default();
    for i in 0..10 {
        let p = Vec3::new(0.5 - 0.1 * i as f32, 0.0, 0.0);
        push(&mut s, p, cov, 0.95, &[dc_for([1.0; 3])]);
    }
    let settings = RenderSettings {
        background: [0.5; 3],
        ..RenderSettings::default()
    };
    let c = render(&s.view().unwrap(), &camera(), &settings)
        .unwrap()
        .get(32, 24)
        .unwrap();
    let expected = 0.95 * (1.0 + 0.05 + 0.0025) + 1.25e-4 * 0.5;
    assert!((c[0] - expected).abs() < 1e-5, "{} vs {expected}", c[0]);
}

#[test]
fn portable_exp_matches_libm_over_the_blending_range() {
    // The blending only needs e^x for x in [ln(1/255) - 1e-3, 0] (α >= 1/255); check a wider
    // range. 5e-7 relative is a few f32 ulps, far below the 1/255 quantisation of the output.
    let mut worst = 0.0f64;
    for i in 0..=200_000 {
        let x = -20.0 * i as f32 / 200_000.0;
        let got = f64::from(splatphys_render::raster::exp_neg(x));
        let want = f64::from(x).exp();
        worst = worst.max((got - want).abs() / want);
    }
    assert!(worst < 5e-7, "worst relative error {worst}");
    assert_eq!(splatphys_render::raster::exp_neg(0.0), 1.0);
    assert_eq!(
        splatphys_render::raster::exp_neg(3.0),
        1.0,
        "positive input clamps to 0"
    );
    assert!(splatphys_render::raster::exp_neg(-200.0) < 1e-37);
}
