//! Fixed-corotated elasticity ("jelly"), Stomakhin et al. 2012, as used by MLS-MPM (Hu et al.
//! 2018) and PhysGaussian.
//!
//! ψ(F) = mu Σ(σ_i - 1)² + lambda/2 (J - 1)²;  P = 2 mu (F - R) + lambda (J - 1) J F⁻ᵀ;
//! τ = P Fᵀ = 2 mu (F - R) Fᵀ + lambda (J - 1) J I, with R from the polar decomposition of F
//! ([`crate::math::polar_rotation`]).

use glam::Mat3A;

use super::{ConstitutiveModel, ElasticParams};
use crate::math::{Mat3x4, polar_rotation, polar_rotation_x4};

/// Fixed-corotated elastic material.
#[derive(Debug, Clone, PartialEq)]
pub struct Jelly {
    /// E, nu, density and Lamé parameters.
    pub params: ElasticParams,
}

impl Jelly {
    /// A jelly material with validated elastic parameters.
    pub fn new(params: ElasticParams) -> Self {
        Self { params }
    }
}

/// Fixed-corotated Kirchhoff stress with explicit Lamé parameters (shared by snow).
#[inline]
pub(crate) fn corotated_stress(f: Mat3A, mu: f32, lambda: f32) -> Mat3A {
    let r = polar_rotation(f);
    let j = f.determinant();
    (f - r) * f.transpose() * (2.0 * mu)
        + Mat3A::from_diagonal(glam::Vec3::splat(lambda * (j - 1.0) * j))
}

/// [`corotated_stress`] of four deformation gradients at once (one per lane, with per-lane Lamé
/// parameters in Pa): lane l equals `corotated_stress(f.lane(l), mu[l], lambda[l])` bit for bit.
#[inline]
pub(crate) fn corotated_stress_x4(f: &Mat3x4, mu: wide::f32x4, lambda: wide::f32x4) -> Mat3x4 {
    let r = polar_rotation_x4(f);
    let j = f.determinant();
    let one = wide::f32x4::ONE;
    f.sub(&r)
        .mul_transpose(f)
        .scale(wide::f32x4::splat(2.0) * mu)
        .add_diagonal(lambda * (j - one) * j)
}

/// Fixed-corotated energy density with explicit Lamé parameters (shared by snow).
pub(crate) fn corotated_energy(f: Mat3A, mu: f32, lambda: f32) -> f32 {
    let s = crate::math::svd3(f).sigma;
    let j = s.x * s.y * s.z;
    mu * (s - glam::Vec3A::ONE).length_squared() + 0.5 * lambda * (j - 1.0) * (j - 1.0)
}

impl ConstitutiveModel for Jelly {
    fn name(&self) -> &'static str {
        "jelly"
    }
    fn elastic(&self) -> &ElasticParams {
        &self.params
    }
    #[inline]
    fn kirchhoff_stress(&self, f: Mat3A, _plastic: f32) -> Mat3A {
        corotated_stress(f, self.params.mu_pa, self.params.lambda_pa)
    }
    #[inline]
    fn kirchhoff_stress_x4(&self, f: &[Mat3A; 4], _plastic: &[f32; 4]) -> [Mat3A; 4] {
        let tau = corotated_stress_x4(
            &Mat3x4::from_lanes(f),
            wide::f32x4::splat(self.params.mu_pa),
            wide::f32x4::splat(self.params.lambda_pa),
        );
        std::array::from_fn(|l| tau.lane(l))
    }
    fn energy_density(&self, f: Mat3A, _plastic: f32) -> f32 {
        corotated_energy(f, self.params.mu_pa, self.params.lambda_pa)
    }
}
