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
mod spec;

pub use elastic::{ElasticParams, MAX_DAMPING_VISCOSITY_PA_S};
pub use foam::Foam;
pub use jelly::Jelly;
pub use metal::Metal;
pub use neo_hookean::NeoHookean;
pub use plasticine::Plasticine;
pub use sand::Sand;
pub use snow::Snow;
pub use spec::{MaterialSpec, defaults};
pub use splatphys_types::MaterialModel;

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
}

/// What every constitutive model provides.
pub trait ConstitutiveModel {
    /// The model's name as used in scene files.
    fn name(&self) -> &'static str;
    /// The elastic parameters (E, nu, density) the model was built with.
    fn elastic(&self) -> &ElasticParams;
    /// Kirchhoff stress τ = P(F) Fᵀ in Pa for elastic deformation gradient `f` and plastic state
    /// `plastic` (see [`ConstitutiveModel::initial_plastic_state`]).
    fn kirchhoff_stress(&self, f: Mat3A, plastic: f32) -> Mat3A;
    /// [`Self::kirchhoff_stress`] of four particles at once (Pa): element l is the stress of
    /// `f[l]` with `plastic[l]`, bit for bit what the one-particle call gives. Models whose
    /// stress has a four-lane SIMD form override it; the default calls the one-particle form.
    fn kirchhoff_stress_x4(&self, f: &[Mat3A; 4], plastic: &[f32; 4]) -> [Mat3A; 4] {
        std::array::from_fn(|l| self.kirchhoff_stress(f[l], plastic[l]))
    }
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
    /// Largest dilational wave speed in m/s that particles in the plastic states `plastic`
    /// (`[N]`) can reach within the next substep: the CFL bound of the current state. The same
    /// as [`Self::max_wave_speed_m_s`] for models whose moduli do not depend on it.
    fn wave_speed_for_m_s(&self, _plastic: &[f32]) -> f32 {
        self.max_wave_speed_m_s()
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
    #[inline]
    fn kirchhoff_stress_x4(&self, f: &[Mat3A; 4], plastic: &[f32; 4]) -> [Mat3A; 4] {
        dispatch!(self, m => m.kirchhoff_stress_x4(f, plastic))
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
    fn wave_speed_for_m_s(&self, plastic: &[f32]) -> f32 {
        dispatch!(self, m => m.wave_speed_for_m_s(plastic))
    }
}

impl Material {
    /// Builds a material from plain parameters.
    ///
    /// # Errors
    /// [`MaterialError::OutOfRange`] naming the model and value for E <= 0, nu outside (-1, 0.5),
    /// density <= 0, a non-finite value, or a model parameter outside its range.
    pub fn from_spec(spec: &MaterialSpec) -> Result<Self, MaterialError> {
        let model = spec.model;
        let e = ElasticParams::new(
            model.name(),
            spec.youngs_modulus_pa,
            spec.poisson_ratio,
            spec.density_kg_m3,
        )?
        .with_damping(model.name(), spec.damping_viscosity_pa_s.unwrap_or(0.0))?;
        let yield_stress = |fraction: f64| {
            spec.yield_stress_pa
                .unwrap_or(spec.youngs_modulus_pa * fraction)
        };
        Ok(match model {
            MaterialModel::FixedCorotated => Material::Jelly(Jelly::new(e)),
            MaterialModel::NeoHookean => Material::NeoHookean(NeoHookean::new(e)),
            MaterialModel::Snow => Material::Snow(
                Snow::new(e, spec.hardening.unwrap_or(defaults::HARDENING))?.with_thresholds(
                    spec.critical_compression
                        .unwrap_or(defaults::CRITICAL_COMPRESSION),
                    spec.critical_stretch.unwrap_or(defaults::CRITICAL_STRETCH),
                )?,
            ),
            MaterialModel::Sand => Material::Sand(Sand::new(
                e,
                spec.friction_angle_deg
                    .unwrap_or(defaults::FRICTION_ANGLE_DEG),
            )?),
            MaterialModel::Metal => {
                Material::Metal(Metal::new(e, yield_stress(defaults::METAL_YIELD_OVER_E))?)
            }
            MaterialModel::Plasticine => Material::Plasticine(Plasticine::new(
                e,
                yield_stress(defaults::PLASTICINE_YIELD_OVER_E),
                spec.softening.unwrap_or(defaults::SOFTENING),
            )?),
            MaterialModel::Foam => Material::Foam(Foam::new(
                e,
                spec.viscosity_pa_s.unwrap_or(defaults::VISCOSITY_PA_S),
            )?),
        })
    }

    /// The spec this material was built from, every model parameter filled in (what an edit
    /// starts from, so it changes only the fields it names). Values round-trip through the
    /// solver's f32.
    pub fn spec(&self) -> MaterialSpec {
        let e = self.elastic();
        let mut s = MaterialSpec::new(
            self.model(),
            f64::from(e.youngs_modulus_pa),
            f64::from(e.poisson_ratio),
            f64::from(e.density_kg_m3),
        );
        if e.damping_viscosity_pa_s > 0.0 {
            s.damping_viscosity_pa_s = Some(f64::from(e.damping_viscosity_pa_s));
        }
        match self {
            Material::Jelly(_) | Material::NeoHookean(_) => {}
            Material::Snow(m) => {
                s.hardening = Some(f64::from(m.hardening));
                s.critical_compression = Some(f64::from(m.theta_c));
                s.critical_stretch = Some(f64::from(m.theta_s));
            }
            Material::Sand(m) => s.friction_angle_deg = Some(f64::from(m.friction_angle_deg)),
            Material::Metal(m) => s.yield_stress_pa = Some(f64::from(m.yield_stress_pa)),
            Material::Plasticine(m) => {
                s.yield_stress_pa = Some(f64::from(m.yield_stress_pa));
                s.softening = Some(f64::from(m.softening));
            }
            Material::Foam(m) => s.viscosity_pa_s = Some(f64::from(m.viscosity_pa_s)),
        }
        s
    }

    /// The constitutive model.
    pub fn model(&self) -> MaterialModel {
        match self {
            Material::Jelly(_) => MaterialModel::FixedCorotated,
            Material::NeoHookean(_) => MaterialModel::NeoHookean,
            Material::Snow(_) => MaterialModel::Snow,
            Material::Sand(_) => MaterialModel::Sand,
            Material::Metal(_) => MaterialModel::Metal,
            Material::Plasticine(_) => MaterialModel::Plasticine,
            Material::Foam(_) => MaterialModel::Foam,
        }
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
        Self::from_spec(&MaterialSpec::jelly(
            youngs_modulus_pa,
            poisson_ratio,
            density_kg_m3,
        ))
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Every model's four-lane stress is its one-particle stress, bit for bit, lane by lane:
    /// including a lane that takes the SVD fallback (an inverted F) and snow lanes at different
    /// hardening.
    #[test]
    fn four_lane_stress_equals_the_one_particle_stress() {
        let f = [
            Mat3A::from_cols_array(&[1.02, 0.03, -0.01, 0.02, 0.97, 0.04, -0.03, 0.01, 1.05]),
            Mat3A::from_rotation_z(0.7) * Mat3A::from_diagonal(glam::Vec3::new(1.1, 0.9, 0.95)),
            Mat3A::from_diagonal(glam::Vec3::new(1.0, 1.0, -0.8)),
            Mat3A::IDENTITY,
        ];
        let plastic = [1.0, 0.93, 1.0, 0.99];
        for model in MaterialModel::ALL {
            let m = Material::from_spec(&MaterialSpec::new(model, 2e5, 0.3, 1000.0))
                .expect("default parameters are valid");
            let lanes = m.kirchhoff_stress_x4(&f, &plastic);
            for l in 0..4 {
                let one = m.kirchhoff_stress(f[l], plastic[l]);
                assert_eq!(
                    lanes[l].to_cols_array().map(f32::to_bits),
                    one.to_cols_array().map(f32::to_bits),
                    "{} lane {l}",
                    m.name()
                );
            }
        }
    }
}
