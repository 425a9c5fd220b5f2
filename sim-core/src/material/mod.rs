//! Constitutive models for MLS-MPM, one file each, behind one trait ([`ConstitutiveModel`]).
//!
//! Every model maps the elastic deformation gradient F (and one scalar of plastic state) to the
//! Kirchhoff stress τ = P Fᵀ (Pa), the quantity MLS-MPM's P2G needs (Hu et al. 2018, eq. 18 with
//! the APIC affine term), and may project a trial F back onto its yield surface after each G2P
//! (the return mapping of the plastic models).
//!
//! Parameters are SI: Young's modulus E (Pa), Poisson's ratio nu (dimensionless), density
//! (kg/m³), with Lamé mu = E / (2(1 + nu)) and lambda = E nu / ((1 + nu)(1 - 2 nu)).

mod elastic;
mod foam;
mod hencky;
mod jelly;
mod metal;
mod neo_hookean;
mod plasticine;
mod sand;
pub mod snow;

pub use elastic::ElasticParams;
pub use foam::Foam;
pub use jelly::Jelly;
pub use metal::Metal;
pub use neo_hookean::NeoHookean;
pub use plasticine::Plasticine;
pub use sand::Sand;
pub use snow::Snow;

use glam::Mat3A;

/// Why a material was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MaterialError {
    /// A parameter outside its admissible range.
    #[error("material {model}: {parameter} = {value} is outside {range}")]
    OutOfRange {
        /// Model name ("jelly", "snow", ...).
        model: &'static str,
        /// Parameter name with its unit.
        parameter: &'static str,
        /// The value given.
        value: f64,
        /// The admissible range in words.
        range: &'static str,
    },
    /// An unknown model name.
    #[error("unknown material model {0:?} (expected one of: {models})", models = MODEL_NAMES.join(", "))]
    UnknownModel(String),
}

/// The model names accepted by [`Material::from_spec`].
pub const MODEL_NAMES: [&str; 7] = [
    "jelly",
    "neo-hookean",
    "snow",
    "sand",
    "metal",
    "plasticine",
    "foam",
];

/// What every constitutive model provides.
pub trait ConstitutiveModel {
    /// The model's name as used in scene files.
    fn name(&self) -> &'static str;
    /// The elastic parameters (E, nu, density) the model was built with.
    fn elastic(&self) -> &ElasticParams;
    /// Kirchhoff stress τ = P(F) Fᵀ in Pa for elastic deformation gradient `f` and plastic state
    /// `plastic` (see [`ConstitutiveModel::initial_plastic_state`]).
    fn kirchhoff_stress(&self, f: Mat3A, plastic: f32) -> Mat3A;
    /// Elastic strain energy density ψ(F) in J/m³ (per unit initial volume).
    fn energy_density(&self, f: Mat3A, plastic: f32) -> f32;
    /// Return mapping after G2P: projects the trial elastic F onto the admissible set and updates
    /// the plastic state. Elastic models leave both unchanged.
    fn project(&self, _f: &mut Mat3A, _plastic: &mut f32, _dt_s: f32) {}
    /// The plastic state a fresh particle starts with (snow: Jp = 1; others: 0).
    fn initial_plastic_state(&self) -> f32 {
        0.0
    }
    /// Largest dilational wave speed c_p = sqrt((lambda + 2 mu) / rho) in m/s the model can reach
    /// (snow hardens, so its bound uses the hardened moduli at the compression limit).
    fn max_wave_speed_m_s(&self) -> f32 {
        self.elastic().dilational_wave_speed_m_s()
    }
}

/// Parameters of any model as plain data, as a scene file or a command gives them.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MaterialSpec {
    /// One of [`MODEL_NAMES`].
    pub model: String,
    /// Young's modulus E in Pa (> 0).
    pub youngs_modulus_pa: f64,
    /// Poisson's ratio nu in (-1, 0.5).
    pub poisson_ratio: f64,
    /// Density in kg/m³ (> 0).
    pub density_kg_m3: f64,
    /// Sand: friction angle in degrees (default 30).
    pub friction_angle_deg: Option<f64>,
    /// Metal and plasticine: yield stress in Pa (default E / 100 for metal, E / 50 for plasticine).
    pub yield_stress_pa: Option<f64>,
    /// Plasticine: fraction of the yield stress lost per unit accumulated plastic strain (default 2).
    pub softening: Option<f64>,
    /// Foam: viscosity of the viscoplastic flow in Pa·s (default 10).
    pub viscosity_pa_s: Option<f64>,
    /// Snow: hardening coefficient ξ (default 10).
    pub hardening: Option<f64>,
    /// Snow: critical compression θc (default 2.5e-2).
    pub critical_compression: Option<f64>,
    /// Snow: critical stretch θs (default 4.5e-3).
    pub critical_stretch: Option<f64>,
}

impl From<&crate::scene::MaterialSpec> for MaterialSpec {
    fn from(s: &crate::scene::MaterialSpec) -> Self {
        let f = |v: Option<f32>| v.map(f64::from);
        Self {
            model: s.model.clone(),
            youngs_modulus_pa: s.youngs_modulus_pa as f64,
            poisson_ratio: s.poisson_ratio as f64,
            density_kg_m3: s.density_kg_m3 as f64,
            friction_angle_deg: f(s.friction_angle_deg),
            yield_stress_pa: f(s.yield_stress_pa),
            softening: f(s.softening),
            viscosity_pa_s: f(s.viscosity_pa_s),
            hardening: f(s.hardening),
            critical_compression: f(s.critical_compression),
            critical_stretch: f(s.critical_stretch),
        }
    }
}

/// A material, dispatched by enum (no virtual call per particle).
#[derive(Debug, Clone, PartialEq)]
pub enum Material {
    /// Fixed-corotated elastic.
    Jelly(Jelly),
    /// Compressible neo-Hookean.
    NeoHookean(NeoHookean),
    /// Stomakhin et al. 2013 snow.
    Snow(Snow),
    /// Drucker-Prager sand, Klár et al. 2016.
    Sand(Sand),
    /// Von Mises plasticity on Hencky strain.
    Metal(Metal),
    /// Von Mises with softening.
    Plasticine(Plasticine),
    /// Viscoplastic foam.
    Foam(Foam),
}

macro_rules! dispatch {
    ($self:ident, $m:ident => $e:expr) => {
        match $self {
            Material::Jelly($m) => $e,
            Material::NeoHookean($m) => $e,
            Material::Snow($m) => $e,
            Material::Sand($m) => $e,
            Material::Metal($m) => $e,
            Material::Plasticine($m) => $e,
            Material::Foam($m) => $e,
        }
    };
}

impl ConstitutiveModel for Material {
    fn name(&self) -> &'static str {
        dispatch!(self, m => m.name())
    }
    fn elastic(&self) -> &ElasticParams {
        dispatch!(self, m => m.elastic())
    }
    #[inline]
    fn kirchhoff_stress(&self, f: Mat3A, plastic: f32) -> Mat3A {
        dispatch!(self, m => m.kirchhoff_stress(f, plastic))
    }
    fn energy_density(&self, f: Mat3A, plastic: f32) -> f32 {
        dispatch!(self, m => m.energy_density(f, plastic))
    }
    #[inline]
    fn project(&self, f: &mut Mat3A, plastic: &mut f32, dt_s: f32) {
        dispatch!(self, m => m.project(f, plastic, dt_s))
    }
    fn initial_plastic_state(&self) -> f32 {
        dispatch!(self, m => m.initial_plastic_state())
    }
    fn max_wave_speed_m_s(&self) -> f32 {
        dispatch!(self, m => m.max_wave_speed_m_s())
    }
}

impl Material {
    /// Builds a material from plain parameters.
    ///
    /// # Errors
    /// [`MaterialError::UnknownModel`] for a name not in [`MODEL_NAMES`];
    /// [`MaterialError::OutOfRange`] naming the model and value for E <= 0, nu outside (-1, 0.5),
    /// density <= 0, a non-finite value, or a model parameter outside its range.
    pub fn from_spec(spec: &MaterialSpec) -> Result<Self, MaterialError> {
        let model: &'static str = MODEL_NAMES
            .iter()
            .find(|m| **m == spec.model)
            .ok_or_else(|| MaterialError::UnknownModel(spec.model.clone()))?;
        let e = ElasticParams::new(
            model,
            spec.youngs_modulus_pa,
            spec.poisson_ratio,
            spec.density_kg_m3,
        )?;
        Ok(match model {
            "jelly" => Material::Jelly(Jelly::new(e)),
            "neo-hookean" => Material::NeoHookean(NeoHookean::new(e)),
            "snow" => Material::Snow(
                Snow::new(e, spec.hardening.unwrap_or(10.0))?.with_thresholds(
                    spec.critical_compression.unwrap_or(snow::THETA_C as f64),
                    spec.critical_stretch.unwrap_or(snow::THETA_S as f64),
                )?,
            ),
            "sand" => Material::Sand(Sand::new(e, spec.friction_angle_deg.unwrap_or(30.0))?),
            "metal" => {
                let y = spec
                    .yield_stress_pa
                    .unwrap_or(spec.youngs_modulus_pa / 100.0);
                Material::Metal(Metal::new(e, y)?)
            }
            "plasticine" => {
                let y = spec
                    .yield_stress_pa
                    .unwrap_or(spec.youngs_modulus_pa / 50.0);
                Material::Plasticine(Plasticine::new(e, y, spec.softening.unwrap_or(2.0))?)
            }
            _ => Material::Foam(Foam::new(e, spec.viscosity_pa_s.unwrap_or(10.0))?),
        })
    }

    /// Jelly (fixed-corotated) with the given E (Pa), nu and density (kg/m³).
    ///
    /// # Errors
    /// As [`Material::from_spec`].
    pub fn jelly(
        youngs_modulus_pa: f64,
        poisson_ratio: f64,
        density_kg_m3: f64,
    ) -> Result<Self, MaterialError> {
        Self::from_spec(&MaterialSpec {
            model: "jelly".into(),
            youngs_modulus_pa,
            poisson_ratio,
            density_kg_m3,
            ..Default::default()
        })
    }

    /// Density in kg/m³.
    pub fn density_kg_m3(&self) -> f32 {
        self.elastic().density_kg_m3
    }
}

/// Checks that a model parameter is finite and within `[lo, hi]`.
pub(crate) fn check_range(
    model: &'static str,
    parameter: &'static str,
    value: f64,
    lo: f64,
    hi: f64,
    range: &'static str,
) -> Result<f32, MaterialError> {
    if value.is_finite() && value >= lo && value <= hi {
        Ok(value as f32)
    } else {
        Err(MaterialError::OutOfRange {
            model,
            parameter,
            value,
            range,
        })
    }
}
