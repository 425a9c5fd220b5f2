//! Gaussian kinematics: from particle state back to Gaussians a renderer draws (PhysGaussian,
//! Xie et al. 2024, eqs. 3-4): centre x = particle position, covariance Σ = Fe Σ0 Feᵀ with Fe the
//! elastic deformation gradient, and the rotation R of Fe's polar decomposition, which rotates the
//! SH view direction (d_local = Rᵀ d). Opacity, SH and scales are unchanged.

use glam::{Mat3A, Quat, Vec3A};

use crate::math::polar;

/// One published Gaussian's dynamic state. `#[repr(C)]`, 52 bytes: the same layout as the wire
/// type `FrameGaussian`, so the server writes it straight into shared memory.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GaussianState {
    /// Centre (m, world).
    pub position_m: [f32; 3],
    /// Covariance upper triangle xx, xy, xz, yy, yz, zz (m²).
    pub covariance_m2: [f32; 6],
    /// Rotation R of Fe = R S as a unit quaternion w, x, y, z.
    pub rotation_wxyz: [f32; 4],
}

const _: () = assert!(std::mem::size_of::<GaussianState>() == 52);

/// Packs a symmetric matrix's upper triangle (xx, xy, xz, yy, yz, zz).
pub fn pack_symmetric(m: Mat3A) -> [f32; 6] {
    [
        m.x_axis.x, m.y_axis.x, m.z_axis.x, m.y_axis.y, m.z_axis.y, m.z_axis.z,
    ]
}

/// The published state of a Gaussian at `x_m` with deformation gradient `f` and rest covariance
/// `sigma0`. A non-finite F falls back to the identity (the state never carries a NaN).
#[inline]
pub fn gaussian_state(x_m: Vec3A, f: Mat3A, sigma0: Mat3A) -> GaussianState {
    let f = if f.is_finite() { f } else { Mat3A::IDENTITY };
    let cov = f * sigma0 * f.transpose();
    let r = polar(f).r;
    let q = Quat::from_mat3a(&r).normalize();
    GaussianState {
        position_m: x_m.into(),
        covariance_m2: pack_symmetric(cov),
        rotation_wxyz: [q.w, q.x, q.y, q.z],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn unpack(c: [f32; 6]) -> Mat3A {
        Mat3A::from_cols(
            Vec3A::new(c[0], c[1], c[2]),
            Vec3A::new(c[1], c[3], c[4]),
            Vec3A::new(c[2], c[4], c[5]),
        )
    }

    fn eigenvalues(m: Mat3A) -> Vec3A {
        let mut s = crate::math::svd3(m).sigma;
        s = s.abs();
        s
    }

    #[test]
    fn pure_rotation_rotates_covariance_and_keeps_eigenvalues() {
        let sigma0 = Mat3A::from_diagonal(Vec3::new(4e-6, 1e-6, 0.25e-6));
        let r = Mat3A::from_quat(Quat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 2.0));
        let g = gaussian_state(Vec3A::ZERO, r, sigma0);
        let cov = unpack(g.covariance_m2);
        assert!(
            (cov - r * sigma0 * r.transpose())
                .to_cols_array()
                .iter()
                .all(|d| d.abs() < 1e-12)
        );
        let e = eigenvalues(cov);
        assert!((e - Vec3A::new(4e-6, 1e-6, 0.25e-6)).abs().max_element() < 1e-11);
        // The reported rotation is R itself.
        let q = Quat::from_xyzw(
            g.rotation_wxyz[1],
            g.rotation_wxyz[2],
            g.rotation_wxyz[3],
            g.rotation_wxyz[0],
        );
        assert!(
            (Mat3A::from_quat(q) - r)
                .to_cols_array()
                .iter()
                .all(|d| d.abs() < 1e-5)
        );
    }

    #[test]
    fn stretch_scales_eigenvalues_by_its_square() {
        let sigma0 = Mat3A::from_diagonal(Vec3::splat(1e-4));
        let f = Mat3A::from_diagonal(Vec3::new(2.0, 1.0, 0.5));
        let e = eigenvalues(unpack(gaussian_state(Vec3A::ZERO, f, sigma0).covariance_m2));
        assert!((e - Vec3A::new(4e-4, 1e-4, 0.25e-4)).abs().max_element() < 1e-9);
    }

    #[test]
    fn non_finite_f_never_publishes_nan() {
        let g = gaussian_state(
            Vec3A::ONE,
            Mat3A::from_diagonal(Vec3::splat(f32::NAN)),
            Mat3A::IDENTITY,
        );
        assert!(
            g.covariance_m2
                .iter()
                .chain(&g.rotation_wxyz)
                .all(|v| v.is_finite())
        );
    }
}
