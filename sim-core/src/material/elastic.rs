//! Elastic parameters shared by every model: E, nu, density and the Lamé parameters.

use super::MaterialError;

/// Young's modulus, Poisson's ratio and density, validated, with the derived Lamé parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ElasticParams {
    /// Young's modulus E in Pa.
    pub youngs_modulus_pa: f32,
    /// Poisson's ratio nu.
    pub poisson_ratio: f32,
    /// Density in kg/m³.
    pub density_kg_m3: f32,
    /// Lamé mu = E / (2 (1 + nu)) in Pa.
    pub mu_pa: f32,
    /// Lamé lambda = E nu / ((1 + nu)(1 - 2 nu)) in Pa.
    pub lambda_pa: f32,
}

impl ElasticParams {
    /// Validates E > 0, nu in (-1, 0.5), density > 0 (all finite) for `model`.
    ///
    /// # Errors
    /// [`MaterialError::OutOfRange`] naming the model, the parameter and the value.
    pub fn new(
        model: &'static str,
        youngs_modulus_pa: f64,
        poisson_ratio: f64,
        density_kg_m3: f64,
    ) -> Result<Self, MaterialError> {
        let bad = |parameter, value, range| MaterialError::OutOfRange {
            model,
            parameter,
            value,
            range,
        };
        if !(youngs_modulus_pa.is_finite() && youngs_modulus_pa > 0.0) {
            return Err(bad("youngs_modulus_pa", youngs_modulus_pa, "(0, inf)"));
        }
        if !(poisson_ratio.is_finite() && poisson_ratio > -1.0 && poisson_ratio < 0.5) {
            return Err(bad("poisson_ratio", poisson_ratio, "(-1, 0.5)"));
        }
        if !(density_kg_m3.is_finite() && density_kg_m3 > 0.0) {
            return Err(bad("density_kg_m3", density_kg_m3, "(0, inf)"));
        }
        let e = youngs_modulus_pa;
        let nu = poisson_ratio;
        let mu = e / (2.0 * (1.0 + nu));
        let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        Ok(Self {
            youngs_modulus_pa: e as f32,
            poisson_ratio: nu as f32,
            density_kg_m3: density_kg_m3 as f32,
            mu_pa: mu as f32,
            lambda_pa: lambda as f32,
        })
    }

    /// Dilational (P-wave) speed c_p = sqrt((lambda + 2 mu) / rho) in m/s.
    pub fn dilational_wave_speed_m_s(&self) -> f32 {
        ((self.lambda_pa + 2.0 * self.mu_pa).max(0.0) / self.density_kg_m3).sqrt()
    }
}
