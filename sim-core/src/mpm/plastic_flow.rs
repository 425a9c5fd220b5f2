//! The plastic deformation gradient F_p that a particle's Gaussians follow.
//!
//! Plastic models keep only the elastic part F of the deformation on the particle (their return
//! mapping projects the trial F* = (I + dt C) F back to the yield surface). The material has
//! deformed by F* F_p in total, and the projection does not change that: F_p' = F'⁻¹ F* F_p, so
//! that F' F_p' = F* F_p (the multiplicative split F = F_e F_p of finite-strain plasticity;
//! Simo and Hughes 1998, chapter 9). A dented metal plate's Gaussians follow F F_p and close
//! over the dent, where following F alone left holes between them.
//!
//! Sand and snow flow without bound, and a Gaussian stretched by all of it becomes a needle:
//! F_p's stretches (singular values) are kept within [`PLASTIC_STRETCH_MIN`],
//! [`PLASTIC_STRETCH_MAX`].

use glam::{Mat3A, Vec3A};

use super::particles::{PLASTIC_STRETCH_MAX, PLASTIC_STRETCH_MIN};
use crate::math::svd::svd3;

/// F_p after a return mapping took the trial elastic deformation `trial` to `elastic`, from
/// `f_plastic` (module docs). Unchanged when the mapping changed nothing (elastic models and
/// steps inside the yield surface) or when `elastic` cannot be inverted.
#[inline]
pub fn after_return_mapping(trial: Mat3A, elastic: Mat3A, f_plastic: Mat3A) -> Mat3A {
    if trial == elastic {
        return f_plastic;
    }
    let det = elastic.determinant();
    if det.is_nan() || det.abs() <= 1e-12 {
        return f_plastic;
    }
    let next = elastic.inverse() * trial * f_plastic;
    if !next.is_finite() {
        return f_plastic;
    }
    bounded(next)
}

/// `f` with its singular values clamped to [[`PLASTIC_STRETCH_MIN`], [`PLASTIC_STRETCH_MAX`]];
/// the singular value decomposition only when a cheap bound cannot rule it out.
fn bounded(f: Mat3A) -> Mat3A {
    // σ_max² ≤ |F|²_F and σ_min ≥ det F / |F|²_F (σ_a σ_b ≤ (σ_a² + σ_b²) / 2 for the other two).
    let norm2 = f.x_axis.length_squared() + f.y_axis.length_squared() + f.z_axis.length_squared();
    let det = f.determinant();
    if norm2 <= PLASTIC_STRETCH_MAX * PLASTIC_STRETCH_MAX && det >= PLASTIC_STRETCH_MIN * norm2 {
        return f;
    }
    let s = svd3(f);
    let sigma = s.sigma.clamp(
        Vec3A::splat(PLASTIC_STRETCH_MIN),
        Vec3A::splat(PLASTIC_STRETCH_MAX),
    );
    s.u * Mat3A::from_diagonal(sigma.into()) * s.v.transpose()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_total_deformation_is_what_it_was_before_the_return_mapping() {
        // A trial shear-stretch projected to a smaller elastic part: F' F_p' = F* F_p.
        let trial = Mat3A::from_cols(
            Vec3A::new(1.3, 0.1, 0.0),
            Vec3A::new(0.2, 0.9, 0.05),
            Vec3A::new(0.0, -0.1, 1.1),
        );
        let elastic = Mat3A::from_cols(
            Vec3A::new(1.05, 0.02, 0.0),
            Vec3A::new(0.03, 0.98, 0.01),
            Vec3A::new(0.0, -0.02, 1.01),
        );
        let fp = Mat3A::from_cols(
            Vec3A::new(1.1, 0.0, 0.0),
            Vec3A::new(0.0, 0.95, 0.0),
            Vec3A::new(0.05, 0.0, 1.0),
        );
        let next = after_return_mapping(trial, elastic, fp);
        let (a, b) = (elastic * next, trial * fp);
        for (x, y) in [
            (a.x_axis, b.x_axis),
            (a.y_axis, b.y_axis),
            (a.z_axis, b.z_axis),
        ] {
            assert!((x - y).length() < 1e-5, "{a} vs {b}");
        }
        // Elastic models: nothing changes.
        assert_eq!(after_return_mapping(trial, trial, fp), fp);
    }

    #[test]
    fn unbounded_flow_keeps_stretches_between_the_bounds() {
        // Sand flowing to a 10:1 stretch in x and a tenth in z.
        let trial = Mat3A::from_diagonal(Vec3A::new(10.0, 1.0, 0.1).into());
        let next = after_return_mapping(trial, Mat3A::IDENTITY, Mat3A::IDENTITY);
        let s = svd3(next).sigma;
        let mut sorted = [s.x, s.y, s.z];
        sorted.sort_by(f32::total_cmp);
        assert!((sorted[0] - PLASTIC_STRETCH_MIN).abs() < 1e-4, "{s}");
        assert!((sorted[1] - 1.0).abs() < 1e-4, "{s}");
        assert!((sorted[2] - PLASTIC_STRETCH_MAX).abs() < 1e-4, "{s}");
    }
}
