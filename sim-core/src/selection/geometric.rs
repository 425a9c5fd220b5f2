//! Geometric selection: axis-aligned boxes, spheres and an opacity threshold (drops the
//! low-opacity "floaters" 3DGS leaves around captured objects).

use glam::Vec3;

use crate::gaussians::GaussianCloud;

/// Indices (ascending) of `indices` whose centre lies in the box `[min, max]` (m, inclusive).
pub fn in_box(
    cloud: &GaussianCloud,
    indices: &[usize],
    min: [f32; 3],
    max: [f32; 3],
) -> Vec<usize> {
    let (lo, hi) = (Vec3::from(min), Vec3::from(max));
    indices
        .iter()
        .copied()
        .filter(|&i| {
            let p = cloud.position(i);
            p.cmpge(lo).all() && p.cmple(hi).all()
        })
        .collect()
}

/// Indices of `indices` whose centre lies within `radius` (m) of `center`.
pub fn in_sphere(
    cloud: &GaussianCloud,
    indices: &[usize],
    center: [f32; 3],
    radius: f32,
) -> Vec<usize> {
    let c = Vec3::from(center);
    indices
        .iter()
        .copied()
        .filter(|&i| cloud.position(i).distance_squared(c) <= radius * radius)
        .collect()
}

/// Indices of `indices` with opacity (after the sigmoid) at least `min_opacity` (in [0, 1]).
pub fn opacity_at_least(cloud: &GaussianCloud, indices: &[usize], min_opacity: f32) -> Vec<usize> {
    indices
        .iter()
        .copied()
        .filter(|&i| cloud.opacity(i) >= min_opacity)
        .collect()
}
