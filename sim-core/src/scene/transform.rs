//! Placing a source in the world and slicing clouds. A similarity transform p' = s R p + t acts
//! on a Gaussian as: centre p' = s R p + t; rotation q' = R ⊗ q (raw quaternion, its length kept);
//! log scales + ln s; normals R n; SH coefficients of degrees 1 to 3 rotated band by band
//! ([`rotate_cloud_sh`]) so each Gaussian shows towards R d the colour it showed towards d.
//! Translation and scale leave SH unchanged.

use glam::{Quat, Vec3};

use crate::gaussians::GaussianCloud;
use crate::gaussians::sh_rotation::rotate_cloud_sh;

/// Rotation from Euler angles in degrees, x then y then z about the fixed world axes
/// (R = Rz · Ry · Rx).
pub fn euler_xyz_deg(rotation_deg: [f32; 3]) -> Quat {
    let [x, y, z] = rotation_deg.map(f32::to_radians);
    Quat::from_rotation_z(z) * Quat::from_rotation_y(y) * Quat::from_rotation_x(x)
}

/// Applies p' = `scale` · R · p + `translation` to every Gaussian of `cloud` in place, SH
/// coefficients included (a no-op for them when R is the identity or the cloud is degree 0).
pub fn apply_similarity(cloud: &mut GaussianCloud, scale: f32, rotation: Quat, translation: Vec3) {
    let ln_s = scale.ln();
    for p in &mut cloud.positions {
        *p = (rotation * Vec3::from(*p) * scale + translation).to_array();
    }
    for q in &mut cloud.rotations_wxyz {
        let r = rotation * Quat::from_xyzw(q[1], q[2], q[3], q[0]);
        *q = [r.w, r.x, r.y, r.z];
    }
    for s in &mut cloud.log_scales {
        *s = s.map(|v| v + ln_s);
    }
    if let Some(normals) = &mut cloud.normals {
        for n in normals {
            *n = (rotation * Vec3::from(*n)).to_array();
        }
    }
    rotate_cloud_sh(cloud, rotation);
}

/// The Gaussians `indices` of `cloud`, in that order, every field (extras included).
pub fn subset(cloud: &GaussianCloud, indices: &[usize]) -> GaussianCloud {
    let r = cloud.sh_rest_len;
    GaussianCloud {
        positions: indices.iter().map(|&i| cloud.positions[i]).collect(),
        normals: cloud
            .normals
            .as_ref()
            .map(|n| indices.iter().map(|&i| n[i]).collect()),
        sh_degree: cloud.sh_degree,
        sh_dc: indices.iter().map(|&i| cloud.sh_dc[i]).collect(),
        sh_rest: indices
            .iter()
            .flat_map(|&i| cloud.sh_rest[i * r..(i + 1) * r].iter().copied())
            .collect(),
        sh_rest_len: r,
        opacity_logit: indices.iter().map(|&i| cloud.opacity_logit[i]).collect(),
        log_scales: indices.iter().map(|&i| cloud.log_scales[i]).collect(),
        rotations_wxyz: indices.iter().map(|&i| cloud.rotations_wxyz[i]).collect(),
        extra: cloud
            .extra
            .iter()
            .map(|(n, v)| (n.clone(), indices.iter().map(|&i| v[i]).collect()))
            .collect(),
    }
}

/// Appends `b` to `a`. SH layouts are merged to the larger degree (missing coefficients are 0);
/// normals kept only if both have them; extras kept only when both have the same names.
pub fn concat(a: &GaussianCloud, b: &GaussianCloud) -> GaussianCloud {
    if a.is_empty() {
        return b.clone();
    }
    if b.is_empty() {
        return a.clone();
    }
    let deg = a.sh_degree.max(b.sh_degree);
    let rest_len = a.sh_rest_len.max(b.sh_rest_len);
    let widen = |c: &GaussianCloud| -> Vec<f32> {
        if c.sh_rest_len == rest_len {
            return c.sh_rest.clone();
        }
        // Channel-major blocks of k = len / 3 coefficients each, padded with zeros.
        let (k_old, k_new) = (c.sh_rest_len / 3, rest_len / 3);
        let mut out = vec![0.0; c.len() * rest_len];
        for i in 0..c.len() {
            for ch in 0..3 {
                for j in 0..k_old {
                    out[i * rest_len + ch * k_new + j] =
                        c.sh_rest[i * c.sh_rest_len + ch * k_old + j];
                }
            }
        }
        out
    };
    let same_extra =
        a.extra.len() == b.extra.len() && a.extra.iter().zip(&b.extra).all(|(x, y)| x.0 == y.0);
    let cat = |x: &[[f32; 3]], y: &[[f32; 3]]| [x, y].concat();
    GaussianCloud {
        positions: cat(&a.positions, &b.positions),
        normals: match (&a.normals, &b.normals) {
            (Some(x), Some(y)) => Some(cat(x, y)),
            _ => None,
        },
        sh_degree: deg,
        sh_dc: cat(&a.sh_dc, &b.sh_dc),
        sh_rest: [widen(a), widen(b)].concat(),
        sh_rest_len: rest_len,
        opacity_logit: [a.opacity_logit.as_slice(), &b.opacity_logit].concat(),
        log_scales: cat(&a.log_scales, &b.log_scales),
        rotations_wxyz: [a.rotations_wxyz.as_slice(), &b.rotations_wxyz].concat(),
        extra: if same_extra {
            a.extra
                .iter()
                .zip(&b.extra)
                .map(|(x, y)| (x.0.clone(), [x.1.as_slice(), &y.1].concat()))
                .collect()
        } else {
            Vec::new()
        },
    }
}

/// Indices keeping at most one Gaussian (the most opaque; ties: lowest index) per cube of side
/// `voxel_m`, in ascending order.
pub fn voxel_subsample(cloud: &GaussianCloud, indices: &[usize], voxel_m: f32) -> Vec<usize> {
    let mut best: std::collections::HashMap<[i64; 3], usize> = std::collections::HashMap::new();
    for &i in indices {
        let key = cloud.positions[i].map(|v| (v / voxel_m).floor() as i64);
        best.entry(key)
            .and_modify(|j| {
                if cloud.opacity_logit[i] > cloud.opacity_logit[*j] {
                    *j = i;
                }
            })
            .or_insert(i);
    }
    let mut out: Vec<usize> = best.into_values().collect();
    out.sort_unstable();
    out
}
