//! Fixed-corotated elasticity ("jelly"), Stomakhin et al. 2012, as used by MLS-MPM (Hu et al.
//! 2018) and PhysGaussian.
//!
//! ψ(F) = mu Σ(σ_i - 1)² + lambda/2 (J - 1)²;  P = 2 mu (F - R) + lambda (J - 1) J F⁻ᵀ;
//! τ = P Fᵀ = 2 mu (F - R) Fᵀ + lambda (J - 1) J I, with R from the polar decomposition of F
//! ([`crate::math::polar_rotation`]).

use glam::Mat3A;

use super::{ConstitutiveModel, ElasticParams};
use crate::math::polar_rotation;

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
    fn energy_density(&self, f: Mat3A, _plastic: f32) -> f32 {
        corotated_energy(f, self.params.mu_pa, self.params.lambda_pa)
    }
}
