//! Foam: viscoplastic flow (Perzyna type) on Hencky strain. Beyond a small uniaxial yield stress
//! (√(3/2) E / 100, a deviatoric stress norm of E / 100) the excess deviatoric strain relaxes with time constant η / mu, so each substep removes
//! the fraction dt / (dt + η / mu) of it: slow deformations flow, fast impacts bounce back
//! elastically. η is the viscosity in Pa·s.

use glam::Mat3A;

use super::hencky::{hencky_energy, hencky_stress, von_mises_project};
use super::{ConstitutiveModel, ElasticParams, MaterialError, check_range};

/// Viscoplastic foam.
#[derive(Debug, Clone, PartialEq)]
pub struct Foam {
    /// E, nu, density and Lamé parameters.
    pub params: ElasticParams,
    /// Viscosity η in Pa·s.
    pub viscosity_pa_s: f32,
    /// Uniaxial yield stress in Pa (√(3/2) E / 100).
    pub yield_stress_pa: f32,
}

/// Foam's uniaxial yield stress as a fraction of E: √(3/2) / 100, a deviatoric stress norm of
/// E / 100 at yield.
const FOAM_YIELD_OVER_E: f32 = 1.224_744_9 / 100.0;

impl Foam {
    /// Foam with viscosity η in Pa·s, in [0, 1e12].
    ///
    /// # Errors
    /// [`MaterialError::OutOfRange`] for η outside that range.
    pub fn new(params: ElasticParams, viscosity_pa_s: f64) -> Result<Self, MaterialError> {
        let eta = check_range(
            "foam",
            "viscosity_pa_s",
            viscosity_pa_s,
            0.0,
            1e12,
            "[0, 1e12]",
        )?;
        Ok(Self {
            yield_stress_pa: params.youngs_modulus_pa * FOAM_YIELD_OVER_E,
            params,
            viscosity_pa_s: eta,
        })
    }
}

impl ConstitutiveModel for Foam {
    fn name(&self) -> &'static str {
        "foam"
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
    fn project(&self, f: &mut Mat3A, plastic: &mut f32, dt_s: f32) {
        let fraction = dt_s / (dt_s + self.viscosity_pa_s / self.params.mu_pa);
        *plastic += von_mises_project(f, self.params.mu_pa, self.yield_stress_pa, fraction);
    }
}
