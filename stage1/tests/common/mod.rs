//! Shared fixtures: procedural objects and training cameras around them.

#![allow(dead_code)]

use glam::Vec3;
use splatphys_render::{Camera, Splats};
use splatphys_stage1::TrainingView;

/// `k` spherical shells of `per_object` Gaussians (Fibonacci points on a sphere of radius
/// 0.1 m, σ = 12 mm, opacity 0.9) on a circle of radius 0.35 m in the z = 0 plane. Returns the
/// Gaussians and each one's object id.
pub fn shells(k: usize, per_object: usize) -> (Splats, Vec<usize>) {
    let mut s = Splats::default();
    let mut ids = Vec::new();
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    for obj in 0..k {
        let a = obj as f32 / k as f32 * std::f32::consts::TAU;
        let centre = Vec3::new(0.35 * a.cos(), 0.35 * a.sin(), 0.0);
        for j in 0..per_object {
            let z = 1.0 - 2.0 * (j as f32 + 0.5) / per_object as f32;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * j as f32;
            let p = centre + 0.1 * Vec3::new(r * phi.cos(), r * phi.sin(), z);
            push(&mut s, p, 0.012, 0.9, [0.0; 3]);
            ids.push(obj);
        }
    }
    (s, ids)
}

/// Appends an isotropic Gaussian (σ in m) with SH DC `dc`.
pub fn push(s: &mut Splats, p: Vec3, sigma_m: f32, opacity: f32, dc: [f32; 3]) {
    let v = sigma_m * sigma_m;
    s.positions.push(p.to_array());
    s.covariances.push([v, 0.0, 0.0, v, 0.0, v]);
    s.opacities.push(opacity);
    s.sh.push(dc);
}

/// `per_ring` cameras on each of the rings at elevations `elevations_deg`, at `radius_m` from
/// `target`, looking at it (50° vertical field of view, `w × h` pixels), named `view_NN`.
pub fn ring_cameras(
    target: Vec3,
    radius_m: f32,
    elevations_deg: &[f32],
    per_ring: usize,
    size_px: [u32; 2],
) -> Vec<(Camera, TrainingView)> {
    let mut out = Vec::new();
    for (ri, &el) in elevations_deg.iter().enumerate() {
        for j in 0..per_ring {
            let az = (j as f32 + 0.5 * ri as f32) / per_ring as f32 * std::f32::consts::TAU;
            let el = el.to_radians();
            let dir = Vec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
            let cam = Camera::new(
                target + radius_m * dir,
                target,
                Vec3::Z,
                50.0,
                size_px[0],
                size_px[1],
            )
            .expect("camera");
            let view = cam.view_params().expect("view");
            out.push((
                cam,
                TrainingView {
                    name: format!("view_{:02}", out.len()),
                    view,
                },
            ));
        }
    }
    out
}

/// One-hot rows `[N][k]` for ids.
pub fn one_hot(ids: &[usize], k: usize) -> Vec<f32> {
    let mut v = vec![0.0; ids.len() * k];
    for (i, &id) in ids.iter().enumerate() {
        v[i * k + id] = 1.0;
    }
    v
}

/// Precision and recall of `selected` against the indices whose id is `target`.
pub fn precision_recall(selected: &[usize], ids: &[usize], target: usize) -> (f64, f64) {
    let truth = ids.iter().filter(|&&i| i == target).count();
    let hits = selected.iter().filter(|&&i| ids[i] == target).count();
    (
        hits as f64 / selected.len().max(1) as f64,
        hits as f64 / truth.max(1) as f64,
    )
}

/// Hue in degrees, saturation and value of an RGB colour in [0, 1].
pub fn hsv([r, g, b]: [f32; 3]) -> (f32, f32, f32) {
    let max = r.max(g).max(b);
    let min = r.min(g).min(b);
    let c = max - min;
    let h = if c <= 0.0 {
        0.0
    } else if max == r {
        60.0 * ((g - b) / c).rem_euclid(6.0)
    } else if max == g {
        60.0 * ((b - r) / c + 2.0)
    } else {
        60.0 * ((r - g) / c + 4.0)
    };
    (h, if max > 0.0 { c / max } else { 0.0 }, max)
}

/// The donut's colour rule, `[icing, dough]`: pink (hue 290°..360° or below 12°) is icing,
/// orange-tan (12°..60°) is dough, anything dark, grey or blue (sprinkles) says nothing.
pub fn colour_rule(rgb: [f32; 3]) -> [f32; 2] {
    let (h, s, v) = hsv(rgb);
    if s < 0.2 || v < 0.15 {
        [0.0, 0.0]
    } else if !(12.0..290.0).contains(&h) {
        [1.0, 0.0]
    } else if h < 60.0 {
        [0.0, 1.0]
    } else {
        [0.0, 0.0]
    }
}

/// A transforms.json (OpenGL camera-to-world, `fl_x`/`fl_y`/`w`/`h` per frame) for `views`.
pub fn transforms_json(views: &[TrainingView]) -> serde_json::Value {
    let frames: Vec<serde_json::Value> = views
        .iter()
        .map(|v| {
            let w = v.view.rotation.transpose(); // columns: right, down, forward
            let cols = [w.x_axis, -w.y_axis, -w.z_axis, v.view.position];
            let rows: Vec<Vec<f32>> = (0..3)
                .map(|r| cols.iter().map(|c| c[r]).collect())
                .chain([vec![0.0, 0.0, 0.0, 1.0]])
                .collect();
            serde_json::json!({
                "file_path": format!("./train/{}.png", v.name),
                "transform_matrix": rows,
                "fl_x": v.view.focal_px[0],
                "fl_y": v.view.focal_px[1],
                "w": v.view.size_px[0],
                "h": v.view.size_px[1],
            })
        })
        .collect();
    serde_json::json!({ "frames": frames })
}
