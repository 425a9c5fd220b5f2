//! What a command may do to an object, checked before it is applied so that no command can make
//! the next step non-finite or stall it: the speed an impulse or a set-velocity gives the object
//! (linear plus the spin's speed at its farthest particle), material values that fit the
//! solver's f32, and a substep budget for material edits.
//!
//! The budget: a stiffer or lighter material raises the wave speed c_p and shrinks the CFL
//! substep dt = C dx / c_p, so one frame needs (frame time / dt) substeps over the object's
//! particles. An edit that would raise the world above [`World::max_particle_substeps_per_frame`]
//! particle-substeps per frame (all objects) is refused, naming the limit and the value; an edit
//! that does not raise the cost is never refused by it, so a large scene can still be softened.
//! The number is a count, not a time, so the same edit is accepted or refused on every machine.

use glam::DVec3;

use super::{World, WorldError};
use crate::material::{ConstitutiveModel, Material, MaterialSpec};
use crate::scene::ObjectKind;

pub(crate) use splatphys_types::limits::{
    DEFAULT_MAX_PARTICLE_SUBSTEPS_PER_FRAME, DENSITY_RANGE_KG_M3, MAX_COMMAND_SPEED_M_S,
    MAX_POISSON_RATIO, MAX_YOUNGS_MODULUS_PA,
};

impl World {
    fn refuse(&self, id: usize, reason: String) -> WorldError {
        WorldError::Refused {
            object: self.bodies[id].name.clone(),
            reason,
        }
    }

    /// Refuses impulse `j_n_s` (N s) at `point_m` on object `id` when it would move a particle
    /// faster than [`MAX_COMMAND_SPEED_M_S`]: Δv = J/m plus |I⁻¹ (r × J)| times the object's
    /// farthest particle distance from its COM.
    pub(super) fn check_impulse(
        &self,
        id: usize,
        j_n_s: DVec3,
        point_m: Option<DVec3>,
    ) -> Result<(), WorldError> {
        let b = &self.bodies[id];
        let s = b.state();
        if s.mass_kg <= 0.0 {
            return Ok(());
        }
        let inv_i = super::measure::inverse_or_zero(s.inertia);
        let r = point_m.map_or(DVec3::ZERO, |p| p - s.com_m);
        let spin = (inv_i * r.cross(j_n_s)).length() * s.radius_m;
        let speed = s.velocity_m_s.length() + j_n_s.length() / s.mass_kg + spin;
        if !speed.is_finite() || speed > MAX_COMMAND_SPEED_M_S {
            return Err(self.refuse(
                id,
                format!(
                    "the impulse would move it at up to {speed:.3e} m/s ({:.3e} m/s from the \
                     impulse on {:.3} kg, {spin:.3e} m/s from the spin about a lever arm of \
                     {:.3} m); the limit is {MAX_COMMAND_SPEED_M_S} m/s",
                    j_n_s.length() / s.mass_kg,
                    s.mass_kg,
                    r.length()
                ),
            ));
        }
        Ok(())
    }

    /// Refuses a COM velocity `v_m_s` plus, when given, an angular velocity `omega_rad_s` whose
    /// speed at the object's farthest particle from its COM exceeds [`MAX_COMMAND_SPEED_M_S`].
    pub(super) fn check_velocity(
        &self,
        id: usize,
        v_m_s: DVec3,
        omega_rad_s: Option<DVec3>,
    ) -> Result<(), WorldError> {
        let arm = match omega_rad_s {
            Some(_) => {
                let b = &self.bodies[id];
                b.state().radius_m
            }
            None => 0.0,
        };
        let spin = omega_rad_s.map_or(0.0, |w| w.length() * arm);
        let speed = v_m_s.length() + spin;
        if !speed.is_finite() || speed > MAX_COMMAND_SPEED_M_S {
            return Err(self.refuse(
                id,
                format!(
                    "speed {speed:.3e} m/s ({spin:.3e} m/s of it from the spin about a lever arm \
                     of {arm:.3} m) is above the limit of {MAX_COMMAND_SPEED_M_S} m/s"
                ),
            ));
        }
        Ok(())
    }

    /// Refuses a material spec for object `id` whose values do not fit the solver, or whose CFL
    /// substep would exceed the particle-substep budget (module docs).
    pub(super) fn check_material(
        &self,
        id: usize,
        spec: &MaterialSpec,
        material: &Material,
    ) -> Result<(), WorldError> {
        let e = spec.youngs_modulus_pa;
        if !e.is_finite() || e > MAX_YOUNGS_MODULUS_PA {
            return Err(self.refuse(
                id,
                format!("youngs_modulus_pa = {e:e} is above {MAX_YOUNGS_MODULUS_PA:e} Pa"),
            ));
        }
        let (lo, hi) = DENSITY_RANGE_KG_M3;
        let rho = spec.density_kg_m3;
        if !(lo..=hi).contains(&rho) {
            return Err(self.refuse(
                id,
                format!("density_kg_m3 = {rho} is outside [{lo}, {hi}] kg/m³"),
            ));
        }
        let nu = spec.poisson_ratio;
        if nu.is_nan() || nu > MAX_POISSON_RATIO {
            return Err(self.refuse(
                id,
                format!("poisson_ratio = {nu} is above {MAX_POISSON_RATIO}"),
            ));
        }
        if self.bodies[id].kind != ObjectKind::Deformable {
            return Ok(());
        }
        // The substep budget with the new material in place of the old.
        let cfl = match self.policy {
            crate::mpm::TimeStepPolicy::Cfl { number } => number as f64,
            crate::mpm::TimeStepPolicy::Fixed { .. } => return Ok(()),
        };
        // As if the whole world stepped at its smallest bound C dx / c_p (islands only save).
        let bound = |b: &super::Body, m: &Material| {
            let speed = m.max_wave_speed_m_s() + m.elastic().damping_speed_m_s(b.dx_m());
            cfl * b.dx_m() as f64 / (speed as f64).max(f64::MIN_POSITIVE)
        };
        let mut others = f64::INFINITY;
        for (k, b) in self.bodies.iter().enumerate() {
            if k != id && b.kind == ObjectKind::Deformable {
                others = others.min(bound(b, &b.materials[0]));
            }
        }
        let particles = self.particle_count() as f64;
        let need = |dt: f64| (dt, (self.frame_dt_s() / dt).ceil() * particles);
        let b = &self.bodies[id];
        let old_dt = others.min(bound(b, &b.materials[0]));
        let wave = material.max_wave_speed_m_s();
        let damping = material.elastic().damping_speed_m_s(b.dx_m());
        let (dt, needed) = need(others.min(bound(b, material)));
        if needed > self.max_particle_substeps_per_frame && needed > need(old_dt).1 {
            return Err(self.refuse(
                id,
                format!(
                    "that material needs substeps of {dt:.2e} s (c_p = {wave:.3e} m/s, \
                     damping limit as a speed {damping:.3e} m/s): \
                     {needed:.3e} particle-substeps per frame, above the limit of {:.3e} \
                     (max_particle_substeps_per_frame)",
                    self.max_particle_substeps_per_frame
                ),
            ));
        }
        Ok(())
    }
}
