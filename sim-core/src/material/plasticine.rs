//! Plasticine: von Mises plasticity on Hencky strain with softening. The yield stress falls
//! linearly with the accumulated plastic strain κ: τ_y = τ_y0 · max(0.1, 1 - softening · κ), so
//! worked material flows more easily (a floor of 10 % keeps it from turning into a fluid).

use glam::Mat3A;

use super::hencky::{hencky_energy, hencky_stress, von_mises_project};
use super::{ConstitutiveModel, ElasticParams, MaterialError, check_range};

/// Softening von Mises material.
#[derive(Debug, Clone, PartialEq)]
pub struct Plasticine {
    /// E, nu, density and Lamé parameters.
    pub params: ElasticParams,
    /// Initial uniaxial yield stress τ_y0 in Pa (the convention of [`super::Metal`]).
    pub yield_stress_pa: f32,
    /// Fraction of the yield stress lost per unit accumulated plastic strain (dimensionless).
    pub softening: f32,
}

impl Plasticine {
    /// Plasticine with yield stress (Pa, > 0) and softening in [0, 1000].
    ///
    /// # Errors
    /// [`MaterialError::OutOfRange`] for a parameter outside its range.
    pub fn new(
        params: ElasticParams,
        yield_stress_pa: f64,
        softening: f64,
    ) -> Result<Self, MaterialError> {
        let y = check_range(
            "plasticine",
            "yield_stress_pa",
            yield_stress_pa,
            f64::MIN_POSITIVE,
            f64::MAX,
            "(0, inf)",
        )?;
        let s = check_range(
            "plasticine",
            "softening",
            softening,
            0.0,
            1000.0,
            "[0, 1000]",
        )?;
        Ok(Self {
            params,
            yield_stress_pa: y,
            softening: s,
        })
    }
}

impl ConstitutiveModel for Plasticine {
    fn name(&self) -> &'static str {
        "plasticine"
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
    fn project(&self, f: &mut Mat3A, kappa: &mut f32, _dt_s: f32) {
        let yield_now = self.yield_stress_pa * (1.0 - self.softening * *kappa).max(0.1);
        *kappa += von_mises_project(f, self.params.mu_pa, yield_now, 1.0);
    }
}
