//! Sand: Drucker-Prager plasticity on Hencky strain, Klár et al. 2016 ("Drucker-Prager
//! elastoplasticity for sand animation"), section 7.
//!
//! With ε = ln Σ of the trial Fe: if tr ε >= 0 the particle is in tension and projects to the
//! cone's tip (ε = 0); otherwise δγ = |ε̂| + (3 lambda + 2 mu)/(2 mu) tr(ε) α (eq. 27) with
//! α = sqrt(2/3) · 2 sin φ / (3 - sin φ) (eq. 31, no cohesion) and, if δγ > 0, ε ← ε - δγ ε̂/|ε̂|
//! (eq. 28). Elasticity is St. Venant-Kirchhoff on Hencky strain. Friction angle φ is constant (no
//! hardening); the plastic state accumulates |Δε| for diagnostics.

use glam::{Mat3A, Vec3A};

use super::hencky::{hencky_energy, hencky_stress, log_strain};
use super::{ConstitutiveModel, ElasticParams, MaterialError, check_range};
use crate::math::{Svd3, svd3};

/// Drucker-Prager sand.
#[derive(Debug, Clone, PartialEq)]
pub struct Sand {
    /// E, nu, density and Lamé parameters.
    pub params: ElasticParams,
    /// Friction angle φ in degrees.
    pub friction_angle_deg: f32,
    /// Cone coefficient α (eq. 31).
    alpha: f32,
}

impl Sand {
    /// Sand with friction angle in degrees, in [0, 60).
    ///
    /// # Errors
    /// [`MaterialError::OutOfRange`] for an angle outside [0, 60).
    pub fn new(params: ElasticParams, friction_angle_deg: f64) -> Result<Self, MaterialError> {
        let phi = check_range(
            "sand",
            "friction_angle_deg",
            friction_angle_deg,
            0.0,
            59.999,
            "[0, 60)",
        )?;
        let s = phi.to_radians().sin();
        let alpha = (2.0f32 / 3.0).sqrt() * 2.0 * s / (3.0 - s);
        Ok(Self {
            params,
            friction_angle_deg: phi,
            alpha,
        })
    }

    /// The cone coefficient α = √(2/3) · 2 sin φ / (3 − sin φ) (Klár et al. 2016, eq. 31).
    pub fn alpha(&self) -> f32 {
        self.alpha
    }
}

impl ConstitutiveModel for Sand {
    fn name(&self) -> &'static str {
        "sand"
    }
    fn elastic(&self) -> &ElasticParams {
        &self.params
    }
    #[inline]
    fn kirchhoff_stress(&self, f: Mat3A, _plastic: f32) -> Mat3A {
        hencky_stress(f, self.params.mu_pa, self.params.lambda_pa)
    }
    fn energy_density(&self, f: Mat3A, _plastic: f32) -> f32 {
        hencky_energy(f, self.params.mu_pa, self.params.lambda_pa)
    }
    fn project(&self, f: &mut Mat3A, plastic: &mut f32, _dt_s: f32) {
        let ElasticParams {
            mu_pa: mu,
            lambda_pa: lambda,
            ..
        } = self.params;
        let Svd3 { u, sigma, v } = svd3(*f);
        let eps = log_strain(sigma);
        let tr = eps.x + eps.y + eps.z;
        let new_eps = if tr >= 0.0 {
            *plastic += eps.length();
            Vec3A::ZERO
        } else {
            let dev = eps - Vec3A::splat(tr / 3.0);
            let norm = dev.length();
            let dgamma = norm + (3.0 * lambda + 2.0 * mu) / (2.0 * mu) * tr * self.alpha;
            if dgamma <= 0.0 || norm <= 0.0 {
                return;
            }
            *plastic += dgamma;
            eps - dev * (dgamma / norm)
        };
        let s = Vec3A::new(new_eps.x.exp(), new_eps.y.exp(), new_eps.z.exp());
        *f = u * Mat3A::from_diagonal(s.into()) * v.transpose();
    }
}
