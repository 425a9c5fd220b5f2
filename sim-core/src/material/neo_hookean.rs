//! Compressible neo-Hookean elasticity (Bonet and Wood; as in Sifakis and Barbič's course notes).
//!
//! ψ(F) = mu/2 (tr(FᵀF) - 3) - mu ln J + lambda/2 (ln J)²;  τ = mu (F Fᵀ - I) + lambda ln J I.
//! J is clamped to at least 1e-4 so an inverted particle gets a large restoring stress, not a NaN.

use glam::{Mat3A, Vec3};

use super::{ConstitutiveModel, ElasticParams};

/// Smallest J the model evaluates ln J at.
const MIN_J: f32 = 1e-4;

/// Neo-Hookean elastic material.
#[derive(Debug, Clone, PartialEq)]
pub struct NeoHookean {
    /// E, nu, density and Lamé parameters.
    pub params: ElasticParams,
}

impl NeoHookean {
    /// A neo-Hookean material with validated elastic parameters.
    pub fn new(params: ElasticParams) -> Self {
        Self { params }
    }
}

impl ConstitutiveModel for NeoHookean {
    fn name(&self) -> &'static str {
        "neo-hookean"
    }
    fn elastic(&self) -> &ElasticParams {
        &self.params
    }
    #[inline]
    fn kirchhoff_stress(&self, f: Mat3A, _plastic: f32) -> Mat3A {
        let ElasticParams {
            mu_pa: mu,
            lambda_pa: lambda,
            ..
        } = self.params;
        let log_j = f.determinant().max(MIN_J).ln();
        (f * f.transpose() - Mat3A::IDENTITY) * mu
            + Mat3A::from_diagonal(Vec3::splat(lambda * log_j))
    }
    fn energy_density(&self, f: Mat3A, _plastic: f32) -> f32 {
        let ElasticParams {
            mu_pa: mu,
            lambda_pa: lambda,
            ..
        } = self.params;
        let log_j = f.determinant().max(MIN_J).ln();
        let i1 = f.x_axis.length_squared() + f.y_axis.length_squared() + f.z_axis.length_squared();
        0.5 * mu * (i1 - 3.0) - mu * log_j + 0.5 * lambda * log_j * log_j
    }
}
