//! Snow, Stomakhin et al. 2013 ("A material point method for snow simulation").
//!
//! Multiplicative plasticity F = Fe Fp. After each G2P the singular values of the trial Fe are
//! clamped to [1 - θc, 1 + θs] (eq. 11: θc = 2.5e-2, θs = 4.5e-3), the removed part goes to
//! Jp = det Fp, and the Lamé parameters harden as mu = mu0 e^{ξ(1 - Jp)}, lambda likewise (eq. 8,
//! ξ = 10). Stress is fixed-corotated on Fe. The hardening factor is clamped to [0.1, 5], as in
//! Taichi's reference implementation, so a fully crushed or stretched particle stays stable.

use glam::{Mat3A, Vec3A};

use super::jelly::{corotated_energy, corotated_stress};
use super::{ConstitutiveModel, ElasticParams, MaterialError, check_range};
use crate::math::{Svd3, svd3};

/// Critical compression θc (Stomakhin et al. 2013, table 2).
pub const THETA_C: f32 = 2.5e-2;
/// Critical stretch θs.
pub const THETA_S: f32 = 4.5e-3;
/// Bounds of the hardening factor e^{ξ(1 - Jp)}.
const HARDENING_RANGE: (f32, f32) = (0.1, 5.0);

/// Snow: fixed-corotated elasticity with clamped singular values and hardening.
#[derive(Debug, Clone, PartialEq)]
pub struct Snow {
    /// E, nu, density and Lamé parameters (mu0, lambda0).
    pub params: ElasticParams,
    /// Hardening coefficient ξ (dimensionless, default 10).
    pub hardening: f32,
    /// Critical compression θc (default 2.5e-2).
    pub theta_c: f32,
    /// Critical stretch θs (default 4.5e-3).
    pub theta_s: f32,
}

impl Snow {
    /// Snow with hardening ξ in [0, 100].
    ///
    /// # Errors
    /// [`MaterialError::OutOfRange`] for ξ outside [0, 100].
    pub fn new(params: ElasticParams, hardening: f64) -> Result<Self, MaterialError> {
        let hardening = check_range("snow", "hardening", hardening, 0.0, 100.0, "[0, 100]")?;
        Ok(Self {
            params,
            hardening,
            theta_c: THETA_C,
            theta_s: THETA_S,
        })
    }

    /// Overrides the critical compression θc and stretch θs, each in (0, 0.5].
    ///
    /// # Errors
    /// [`MaterialError::OutOfRange`] for a value outside (0, 0.5].
    pub fn with_thresholds(mut self, theta_c: f64, theta_s: f64) -> Result<Self, MaterialError> {
        self.theta_c = check_range(
            "snow",
            "critical_compression",
            theta_c,
            1e-9,
            0.5,
            "(0, 0.5]",
        )?;
        self.theta_s = check_range("snow", "critical_stretch", theta_s, 1e-9, 0.5, "(0, 0.5]")?;
        Ok(self)
    }

    #[inline]
    fn hardening_factor(&self, jp: f32) -> f32 {
        (self.hardening * (1.0 - jp))
            .exp()
            .clamp(HARDENING_RANGE.0, HARDENING_RANGE.1)
    }
}

impl ConstitutiveModel for Snow {
    fn name(&self) -> &'static str {
        "snow"
    }
    fn elastic(&self) -> &ElasticParams {
        &self.params
    }
    #[inline]
    fn kirchhoff_stress(&self, f: Mat3A, jp: f32) -> Mat3A {
        let h = self.hardening_factor(jp);
        corotated_stress(f, self.params.mu_pa * h, self.params.lambda_pa * h)
    }
    fn energy_density(&self, f: Mat3A, jp: f32) -> f32 {
        let h = self.hardening_factor(jp);
        corotated_energy(f, self.params.mu_pa * h, self.params.lambda_pa * h)
    }
    fn project(&self, f: &mut Mat3A, jp: &mut f32, _dt_s: f32) {
        let Svd3 { u, sigma, v } = svd3(*f);
        let clamped = sigma.clamp(
            Vec3A::splat(1.0 - self.theta_c),
            Vec3A::splat(1.0 + self.theta_s),
        );
        let old_j = sigma.x * sigma.y * sigma.z;
        let new_j = clamped.x * clamped.y * clamped.z;
        *jp *= old_j / new_j;
        *f = u * Mat3A::from_diagonal(clamped.into()) * v.transpose();
    }
    fn initial_plastic_state(&self) -> f32 {
        1.0
    }
    fn max_wave_speed_m_s(&self) -> f32 {
        self.params.dilational_wave_speed_m_s() * HARDENING_RANGE.1.sqrt()
    }
}
