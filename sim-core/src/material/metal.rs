//! Metal: von Mises plasticity on Hencky strain with St. Venant-Kirchhoff elasticity (as in
//! PhysGaussian's metal, after Klár et al. 2016's return mapping in log-strain space).
//!
//! Yield when |dev τ| = 2 mu |ε̂| exceeds √(2/3) σ_y, σ_y the uniaxial yield stress (a bar in
//! tension yields at σ_y); the return mapping removes the excess deviatoric strain (perfect
//! plasticity, no hardening). The plastic state accumulates |Δε̂|.

use glam::Mat3A;

use super::hencky::{hencky_energy, hencky_stress, von_mises_project};
use super::{ConstitutiveModel, ElasticParams, MaterialError, check_range};

/// Von Mises elastoplastic metal.
#[derive(Debug, Clone, PartialEq)]
pub struct Metal {
    /// E, nu, density and Lamé parameters.
    pub params: ElasticParams,
    /// Uniaxial yield stress σ_y in Pa (a bar in tension yields at σ_y; the deviatoric
    /// Kirchhoff stress's norm at yield is √(2/3) σ_y).
    pub yield_stress_pa: f32,
}

impl Metal {
    /// Metal with a positive yield stress in Pa.
    ///
    /// # Errors
    /// [`MaterialError::OutOfRange`] for a yield stress <= 0 or non-finite.
    pub fn new(params: ElasticParams, yield_stress_pa: f64) -> Result<Self, MaterialError> {
        let y = check_range(
            "metal",
            "yield_stress_pa",
            yield_stress_pa,
            f64::MIN_POSITIVE,
            f64::MAX,
            "(0, inf)",
        )?;
        Ok(Self {
            params,
            yield_stress_pa: y,
        })
    }
}

impl ConstitutiveModel for Metal {
    fn name(&self) -> &'static str {
        "metal"
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
        *plastic += von_mises_project(f, self.params.mu_pa, self.yield_stress_pa, 1.0);
    }
}
