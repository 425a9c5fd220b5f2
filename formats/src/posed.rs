//! Gaussians as a simulation frame poses them, turned back into the INRIA parameterisation so a
//! frame can be written as a file any 3DGS viewer opens.
//!
//! A simulated Gaussian carries its world covariance Σ = Fe Σ0 Feᵀ (not scales and a rotation),
//! the rotation R of the polar decomposition of Fe (which turns its view-dependent colour), and
//! the static attributes of its scene: SH coefficients in the world frame at rest and opacity.
//! [`cloud_from_posed`] decomposes Σ = V Λ Vᵀ (symmetric eigen-decomposition, V a rotation,
//! det +1), so scales are √λ and the rotation is V's quaternion, turns the SH coefficients by R
//! ([`ShRotation`]) and takes the logit of the opacity. The result renders as the simulation's
//! frame does: same centres, same covariances (to f32 rounding), same colours in every direction.

use glam::{DMat3, DQuat, DVec3, Quat};
use rayon::prelude::*;

use crate::gaussians::sh_rotation::ShRotation;
use crate::gaussians::{GaussianCloud, sh_coeffs_per_channel};
use crate::splat::alpha_to_logit;

/// Smallest standard deviation an exported Gaussian gets, m: a flattened Gaussian (an
/// eigenvalue of Σ at or below zero from f32 rounding) keeps a finite log scale, ln(1e-7) ≈ −16.1.
pub const MIN_SCALE_M: f64 = 1e-7;

/// Name of the [`GaussianCloud::extra`] property [`cloud_from_posed`] adds with each Gaussian's
/// object id (a PLY property of that name); [`BACKGROUND_ID`] for the captured background.
pub const OBJECT_ID_PROPERTY: &str = "object_id";

/// The `object_id` value of a Gaussian that belongs to no object (the captured background).
pub const BACKGROUND_ID: f32 = -1.0;

/// One Gaussian of a simulation frame with its static scene attributes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PosedGaussian {
    /// Centre, m.
    pub position_m: [f32; 3],
    /// World covariance, upper triangle (xx, xy, xz, yy, yz, zz), m².
    pub covariance_m2: [f32; 6],
    /// Rotation R (w, x, y, z) of the polar decomposition of the elastic deformation gradient:
    /// the colour towards R d now is the scene's colour towards d at rest.
    pub rotation_wxyz: [f32; 4],
    /// Opacity in [0, 1] (after the sigmoid).
    pub opacity: f32,
    /// Object id, or `None` for the captured background.
    pub object_id: Option<u32>,
}

/// The Gaussians of one frame (`posed`, `[N]`) with their SH coefficients (`sh`, `[N][48]`,
/// coefficient-major with RGB inner, DC first, world frame at rest: the wire's `SceneGaussian`
/// layout) as a [`GaussianCloud`] of SH degree `sh_degree` (0..=3; higher is clamped to 3), in
/// world metres. With `object_ids` the cloud gets the [`OBJECT_ID_PROPERTY`] extra property.
///
/// Gaussians are independent, so the result does not depend on the thread count.
///
/// # Panics
/// When `sh` and `posed` differ in length (a caller's bug, not input).
pub fn cloud_from_posed(
    posed: &[PosedGaussian],
    sh: &[[f32; 48]],
    sh_degree: u8,
    object_ids: bool,
) -> GaussianCloud {
    assert_eq!(posed.len(), sh.len(), "one SH block per posed Gaussian");
    let degree = sh_degree.min(3);
    let rest_per_channel = sh_coeffs_per_channel(degree) - 1;
    let rest_len = 3 * rest_per_channel;
    let exported: Vec<Exported> = posed
        .par_iter()
        .zip(sh.par_iter())
        .map(|(g, sh)| export_one(g, sh, rest_per_channel))
        .collect();
    let mut cloud = GaussianCloud::with_capacity(posed.len(), rest_len);
    cloud.sh_degree = degree;
    for (g, e) in posed.iter().zip(&exported) {
        cloud.positions.push(g.position_m);
        cloud.sh_dc.push(e.sh_dc);
        cloud.sh_rest.extend_from_slice(&e.sh_rest[..rest_len]);
        cloud
            .opacity_logit
            .push(alpha_to_logit(f64::from(g.opacity)));
        cloud.log_scales.push(e.log_scales);
        cloud.rotations_wxyz.push(e.rotation_wxyz);
    }
    if object_ids {
        let ids = posed
            .iter()
            .map(|g| g.object_id.map_or(BACKGROUND_ID, |id| id as f32))
            .collect();
        cloud.extra.push((OBJECT_ID_PROPERTY.to_string(), ids));
    }
    cloud
}

/// What one Gaussian exports to besides its centre and opacity.
struct Exported {
    sh_dc: [f32; 3],
    /// Channel-major `f_rest_*`, the first `3 * rest_per_channel` used.
    sh_rest: [f32; 45],
    log_scales: [f32; 3],
    rotation_wxyz: [f32; 4],
}

fn export_one(g: &PosedGaussian, sh: &[f32; 48], rest_per_channel: usize) -> Exported {
    let (log_scales, rotation_wxyz) = scales_and_rotation(&g.covariance_m2);
    let mut sh_rest = [0.0f32; 45];
    for c in 0..3 {
        for j in 0..rest_per_channel {
            sh_rest[c * rest_per_channel + j] = sh[3 * (j + 1) + c];
        }
    }
    let used = &mut sh_rest[..3 * rest_per_channel];
    let [w, x, y, z] = g.rotation_wxyz;
    let r = Quat::from_xyzw(x, y, z, w);
    let turned =
        r.is_finite() && r.length() > 1e-6 && !r.normalize().abs_diff_eq(Quat::IDENTITY, 1e-7);
    if turned && used.iter().any(|&v| v != 0.0) {
        ShRotation::from_quat(r).rotate_gaussian(used);
    }
    Exported {
        sh_dc: [sh[0], sh[1], sh[2]],
        sh_rest,
        log_scales,
        rotation_wxyz,
    }
}

/// Log scales and rotation quaternion (w, x, y, z; unit, det +1) of a covariance given as its
/// upper triangle (xx, xy, xz, yy, yz, zz): Σ = R diag(exp(2 s)) Rᵀ. Eigenvalues below
/// [`MIN_SCALE_M`]² (a flattened or, from rounding, slightly indefinite Σ) are raised to it; a
/// non-finite Σ gives the smallest isotropic Gaussian.
pub fn scales_and_rotation(covariance_m2: &[f32; 6]) -> ([f32; 3], [f32; 4]) {
    let floor = MIN_SCALE_M.ln() as f32;
    if !covariance_m2.iter().all(|v| v.is_finite()) {
        return ([floor; 3], [1.0, 0.0, 0.0, 0.0]);
    }
    let [xx, xy, xz, yy, yz, zz] = covariance_m2.map(f64::from);
    let m = nalgebra::Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz);
    let eigen = nalgebra::SymmetricEigen::new(m);
    let v = eigen.eigenvectors;
    let mut cols = [0, 1, 2].map(|k| DVec3::new(v[(0, k)], v[(1, k)], v[(2, k)]).normalize());
    // Gram–Schmidt keeps V orthonormal to f64 rounding; the third axis is the cross product,
    // which also makes det V = +1.
    cols[1] = (cols[1] - cols[0] * cols[0].dot(cols[1])).normalize();
    cols[2] = cols[0].cross(cols[1]);
    let rotation = DQuat::from_mat3(&DMat3::from_cols(cols[0], cols[1], cols[2])).normalize();
    let log_scale =
        |k: usize| (0.5 * eigen.eigenvalues[k].max(MIN_SCALE_M * MIN_SCALE_M).ln()) as f32;
    if !rotation.is_finite() {
        return ([floor; 3], [1.0, 0.0, 0.0, 0.0]);
    }
    (
        [log_scale(0), log_scale(1), log_scale(2)],
        [
            rotation.w as f32,
            rotation.x as f32,
            rotation.y as f32,
            rotation.z as f32,
        ],
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat3;

    fn upper(m: Mat3) -> [f32; 6] {
        [
            m.x_axis.x, m.y_axis.x, m.z_axis.x, m.y_axis.y, m.z_axis.y, m.z_axis.z,
        ]
    }

    #[test]
    fn covariance_survives_the_decomposition() {
        let r = Quat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 2.0);
        let s = glam::Vec3::new(0.01, 0.002, 0.0005);
        let rs = Mat3::from_quat(r) * Mat3::from_diagonal(s);
        let sigma = rs * rs.transpose();
        let (log_s, q) = scales_and_rotation(&upper(sigma));
        let cloud = GaussianCloud {
            positions: vec![[0.0; 3]],
            sh_dc: vec![[0.0; 3]],
            opacity_logit: vec![0.0],
            log_scales: vec![log_s],
            rotations_wxyz: vec![q],
            ..GaussianCloud::default()
        };
        let back = cloud.covariance(0);
        for (a, b) in back.to_cols_array().iter().zip(sigma.to_cols_array()) {
            assert!((a - b).abs() < 1e-9, "{back:?} vs {sigma:?}");
        }
        let mut got = log_s.map(f32::exp);
        got.sort_by(f32::total_cmp);
        let want = [0.0005, 0.002, 0.01];
        for (g, w) in got.iter().zip(want) {
            assert!((g / w - 1.0).abs() < 1e-4, "{got:?}");
        }
        assert!((Quat::from_xyzw(q[1], q[2], q[3], q[0]).length() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn degenerate_covariance_gets_the_floor_not_nan() {
        let (s, q) = scales_and_rotation(&[0.0; 6]);
        assert!(
            s.iter()
                .all(|v| (*v - MIN_SCALE_M.ln() as f32).abs() < 1e-5),
            "{s:?}"
        );
        assert!(q.iter().all(|v| v.is_finite()));
        let (s, _) = scales_and_rotation(&[f32::NAN, 0.0, 0.0, 1.0, 0.0, 1.0]);
        assert!(s.iter().all(|v| v.is_finite()));
        // Slightly indefinite from rounding.
        let (s, _) = scales_and_rotation(&[1e-4, 0.0, 0.0, -1e-18, 0.0, 1e-4]);
        assert!(s.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn colours_turn_with_the_polar_rotation() {
        // Degree 1, red channel only along band-1 coefficient 0; R a quarter turn about z.
        let mut sh = [0.0f32; 48];
        sh[0] = 0.5;
        sh[3] = 0.8; // coefficient 1, red
        sh[7] = -0.3; // coefficient 2, green
        let r = Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
        let g = PosedGaussian {
            position_m: [1.0, 2.0, 3.0],
            covariance_m2: [1e-4, 0.0, 0.0, 1e-4, 0.0, 1e-4],
            rotation_wxyz: [r.w, r.x, r.y, r.z],
            opacity: 0.9,
            object_id: Some(3),
        };
        let cloud = cloud_from_posed(&[g], &[sh], 1, true);
        assert_eq!(cloud.sh_rest_len, 9);
        let rest_scene = [0.8, 0.0, 0.0, 0.0, -0.3, 0.0, 0.0, 0.0, 0.0];
        let basis = |d: glam::DVec3| crate::gaussians::sh_rotation::sh_basis(d);
        for d in [DVec3::X, DVec3::Y, DVec3::new(0.3, -0.5, 0.8).normalize()] {
            let rd = DQuat::from_xyzw(0.0, 0.0, r.z as f64, r.w as f64) * d;
            for c in 0..3 {
                let now: f64 = (0..3)
                    .map(|j| f64::from(cloud.sh_rest[c * 3 + j]) * basis(rd)[j])
                    .sum();
                let then: f64 = (0..3).map(|j| rest_scene[c * 3 + j] * basis(d)[j]).sum();
                assert!((now - then).abs() < 1e-5, "channel {c} direction {d}");
            }
        }
        assert_eq!(cloud.sh_dc[0], [0.5, 0.0, 0.0]);
        assert!((cloud.opacity(0) - 0.9).abs() < 1e-6);
        assert_eq!(cloud.extra[0].1, vec![3.0]);
    }
}
