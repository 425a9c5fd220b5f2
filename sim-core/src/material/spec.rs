//! [`MaterialSpec`]: a material as plain data, as a scene file, a builder or an edit gives it,
//! with the one set of model defaults ([`defaults`]).

use serde::{Deserialize, Serialize};
use splatphys_types::{MaterialEdit, MaterialModel};

/// The default of every optional model parameter, in one place.
pub mod defaults {
    /// Sand: Drucker-Prager friction angle, degrees (Klár et al. 2016 use 30-40°).
    pub const FRICTION_ANGLE_DEG: f64 = 30.0;
    /// Metal: uniaxial yield stress as a fraction of E (√(3/2) / 100: the deviatoric stress
    /// norm E / 100 at yield that the default was before the yield stress became uniaxial).
    pub const METAL_YIELD_OVER_E: f64 = 1.224_744_871 / 100.0;
    /// Plasticine: uniaxial yield stress as a fraction of E (√(3/2) / 50, as for metal).
    pub const PLASTICINE_YIELD_OVER_E: f64 = 1.224_744_871 / 50.0;
    /// Plasticine: fraction of the yield stress lost per unit accumulated plastic strain.
    pub const SOFTENING: f64 = 2.0;
    /// Foam: viscosity of the viscoplastic flow, Pa·s.
    pub const VISCOSITY_PA_S: f64 = 10.0;
    /// Snow: hardening coefficient ξ (Stomakhin et al. 2013, table 2).
    pub const HARDENING: f64 = 10.0;
    /// Snow: critical compression θc (Stomakhin et al. 2013, table 2).
    pub const CRITICAL_COMPRESSION: f64 = super::super::snow::THETA_C as f64;
    /// Snow: critical stretch θs. See [`super::super::snow::THETA_S`] for why 4.5e-3.
    pub const CRITICAL_STRETCH: f64 = super::super::snow::THETA_S as f64;
}

/// Parameters of any model as plain data (SI units). Optional parameters default to
/// [`defaults`] when the material is built; a parameter another model uses is ignored.
///
/// In a scene file this is the `material` table of an object; unknown keys are refused.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// The constitutive model.
    pub model: MaterialModel,
    /// Young's modulus E, Pa (> 0).
    pub youngs_modulus_pa: f64,
    /// Poisson's ratio nu, in (-1, 0.5).
    pub poisson_ratio: f64,
    /// Density rho, kg/m³ (> 0).
    pub density_kg_m3: f64,
    /// Sand: Drucker-Prager friction angle, degrees (default 30).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction_angle_deg: Option<f64>,
    /// Metal and plasticine: uniaxial yield stress σ_y, Pa (a bar in tension yields at σ_y; the
    /// norm of the deviatoric Kirchhoff stress at yield is √(2/3) σ_y)
    /// (default √(3/2) E / 100 for metal, √(3/2) E / 50 for plasticine).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub yield_stress_pa: Option<f64>,
    /// Plasticine: fraction of the yield stress lost per unit accumulated plastic strain
    /// (default 2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub softening: Option<f64>,
    /// Foam: viscosity of the viscoplastic flow, Pa·s (default 10).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub viscosity_pa_s: Option<f64>,
    /// Any model: Kelvin–Voigt damping viscosity η_d, Pa·s (default 0, no damping): a viscous
    /// Kirchhoff stress J η_d (∇v + ∇vᵀ) added to the model's, from each particle's APIC
    /// velocity gradient C (see [`super::ElasticParams::damping_viscosity_pa_s`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub damping_viscosity_pa_s: Option<f64>,
    /// Snow: hardening coefficient ξ (default 10).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hardening: Option<f64>,
    /// Snow: critical compression θc (default 2.5e-2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub critical_compression: Option<f64>,
    /// Snow: critical stretch θs (default 4.5e-3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub critical_stretch: Option<f64>,
}

impl MaterialSpec {
    /// A material with only the three common parameters (model parameters at their defaults).
    pub fn new(
        model: MaterialModel,
        youngs_modulus_pa: f64,
        poisson_ratio: f64,
        density_kg_m3: f64,
    ) -> Self {
        Self {
            model,
            youngs_modulus_pa,
            poisson_ratio,
            density_kg_m3,
            friction_angle_deg: None,
            yield_stress_pa: None,
            softening: None,
            viscosity_pa_s: None,
            damping_viscosity_pa_s: None,
            hardening: None,
            critical_compression: None,
            critical_stretch: None,
        }
    }

    /// Jelly (fixed-corotated) with E (Pa), nu and density (kg/m³).
    pub fn jelly(youngs_modulus_pa: f64, poisson_ratio: f64, density_kg_m3: f64) -> Self {
        Self::new(
            MaterialModel::FixedCorotated,
            youngs_modulus_pa,
            poisson_ratio,
            density_kg_m3,
        )
    }

    /// This spec with the fields `edit` names changed and every other field kept (a snow
    /// object keeps its θc, θs and ξ when only E is edited). The contact coefficients of the
    /// edit (e, mu) are not material parameters and are ignored here.
    pub fn edited(&self, edit: &MaterialEdit) -> Self {
        Self {
            model: edit.model.unwrap_or(self.model),
            youngs_modulus_pa: edit.youngs_modulus_pa.unwrap_or(self.youngs_modulus_pa),
            poisson_ratio: edit.poisson_ratio.unwrap_or(self.poisson_ratio),
            density_kg_m3: edit.density_kg_m3.unwrap_or(self.density_kg_m3),
            ..self.clone()
        }
    }
}

impl Default for MaterialSpec {
    /// Jelly, E = 1e5 Pa, nu = 0.3, rho = 1000 kg/m³: the default of an object that names no
    /// material.
    fn default() -> Self {
        Self::jelly(1e5, 0.3, 1000.0)
    }
}
