//! Elastic parameters shared by every model: E, nu, density and the Lamé parameters.

use super::MaterialError;

/// The largest Kelvin–Voigt damping viscosity accepted, Pa·s (a 1 cm grid of water-dense
/// material then needs substeps of about 1e-8 s).
pub const MAX_DAMPING_VISCOSITY_PA_S: f64 = 1e6;

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
    /// Kelvin–Voigt damping viscosity η_d in Pa·s (0: none). MLS-MPM's P2G adds the viscous
    /// Kirchhoff stress τ_d = J η_d (C + Cᵀ) to the model's (C the particle's APIC velocity
    /// gradient, J = det F): a Newtonian viscous stress 2 η_d D in parallel with the elastic
    /// one, which dissipates 2 η_d D:D per unit volume and leaves rigid motion (D = 0) alone.
    /// F is the elastic deformation gradient, so in a plastic model (snow, sand) that has
    /// compacted or dilated the viscous force scales with the elastic volume ratio, not the
    /// whole one.
    pub damping_viscosity_pa_s: f32,
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
            damping_viscosity_pa_s: 0.0,
        })
    }

    /// These parameters with Kelvin–Voigt damping viscosity `eta_pa_s` (Pa·s, in
    /// [0, [`MAX_DAMPING_VISCOSITY_PA_S`]]).
    ///
    /// # Errors
    /// [`MaterialError::OutOfRange`] naming `model` for a value outside that range.
    pub fn with_damping(self, model: &'static str, eta_pa_s: f64) -> Result<Self, MaterialError> {
        let eta = super::check_range(
            model,
            "damping_viscosity_pa_s",
            eta_pa_s,
            0.0,
            MAX_DAMPING_VISCOSITY_PA_S,
            "[0, 1e6]",
        )?;
        Ok(Self {
            damping_viscosity_pa_s: eta,
            ..self
        })
    }

    /// The speed (m/s) that stands for the damping's own stability limit in the CFL bound
    /// C dx / (c_p + this + |v|max) on a grid of cell `dx_m`: 6 η_d / (ρ dx), so that the bound
    /// keeps dt ≤ C ρ dx² / (6 η_d). The viscous operator's largest eigenvalue on MLS-MPM's
    /// quadratic B-spline grid is at most 8 η_d / (ρ dx²) (|C_p|² ≤ (4 / dx²) Σ w |v_i|² by
    /// Cauchy–Schwarz with the inertia D = dx²/4 I), so forward Euler needs dt ≤ ρ dx² / (4 η_d);
    /// with C ≤ 1 the bound stays inside that.
    pub fn damping_speed_m_s(&self, dx_m: f32) -> f32 {
        if self.damping_viscosity_pa_s > 0.0 {
            6.0 * self.damping_viscosity_pa_s / (self.density_kg_m3 * dx_m)
        } else {
            0.0
        }
    }

    /// Dilational (P-wave) speed c_p = sqrt((lambda + 2 mu) / rho) in m/s.
    pub fn dilational_wave_speed_m_s(&self) -> f32 {
        ((self.lambda_pa + 2.0 * self.mu_pa).max(0.0) / self.density_kg_m3).sqrt()
    }
}
