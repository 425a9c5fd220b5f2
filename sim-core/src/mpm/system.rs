//! A self-contained MPM system: particles, materials, colliders, gravity and a time-step policy,
//! advanced substep by substep with the CFL rule. Validation tests, the `bench mpm` benchmark and
//! the shared-grid baseline drive this directly.

use glam::Vec3A;

use super::diagnostics::Diagnostics;
use super::particles::Particles;
use super::solver::{MpmError, MpmSolver, SubstepInput, SubstepReport};
use super::timestep::{TimeStepError, TimeStepPolicy};
use crate::collider::Collider;
use crate::material::{ConstitutiveModel, Material};

/// Why a run stopped.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// The solver failed at a substep.
    #[error("substep {substep} (t = {time_s:.6} s): {source}")]
    Solver {
        /// Substep index (0-based, counted over the whole run).
        substep: u64,
        /// Simulated time at its start (s).
        time_s: f64,
        /// What failed.
        source: MpmError,
    },
    /// The time-step policy refused the step.
    #[error("substep {substep} (t = {time_s:.6} s): {source}")]
    TimeStep {
        /// Substep index.
        substep: u64,
        /// Simulated time (s).
        time_s: f64,
        /// Why.
        source: TimeStepError,
    },
}

/// Particles with their materials, colliders and clock.
#[derive(Debug, Clone)]
pub struct MpmSystem {
    /// The particles.
    pub particles: Particles,
    /// Material table indexed by `particles.material`.
    pub materials: Vec<Material>,
    /// Grid colliders.
    pub colliders: Vec<Collider>,
    /// Gravity (m/s²).
    pub gravity_m_s2: Vec3A,
    /// How substeps are sized.
    pub policy: TimeStepPolicy,
    /// The solver and its grid.
    pub solver: MpmSolver,
    /// Simulated time (s).
    pub time_s: f64,
    /// Substeps taken.
    pub substeps: u64,
    /// Largest particle speed after the last substep (m/s).
    pub max_speed_m_s: f32,
    /// The last substep's report.
    pub last: SubstepReport,
}

impl MpmSystem {
    /// A system with grid cell `dx_m`, default gravity (0, 0, -9.81) and CFL 0.5.
    pub fn new(particles: Particles, materials: Vec<Material>, dx_m: f32) -> Self {
        let max_speed_m_s = particles.v.iter().map(|v| v.length()).fold(0.0, f32::max);
        Self {
            particles,
            materials,
            colliders: Vec::new(),
            gravity_m_s2: Vec3A::new(0.0, 0.0, -9.81),
            policy: TimeStepPolicy::default(),
            solver: MpmSolver::new(dx_m),
            time_s: 0.0,
            substeps: 0,
            max_speed_m_s,
            last: SubstepReport::default(),
        }
    }

    /// Largest dilational wave speed over the materials in use, in their current plastic state
    /// (m/s; see [`ConstitutiveModel::wave_speed_for_m_s`]), plus the speed that stands for a
    /// damped material's viscous limit ([`crate::material::ElasticParams::damping_speed_m_s`]).
    pub fn max_wave_speed_m_s(&self) -> f32 {
        let mut used = vec![false; self.materials.len()];
        for &m in &self.particles.material {
            if let Some(u) = used.get_mut(m as usize) {
                *u = true;
            }
        }
        self.materials
            .iter()
            .zip(used)
            .filter(|(_, u)| *u)
            .map(|(m, _)| {
                m.wave_speed_for_m_s(&self.particles.plastic)
                    + m.elastic().damping_speed_m_s(self.solver.dx_m)
            })
            .fold(0.0, f32::max)
    }

    /// Takes one substep of at most `max_dt_s`; returns the dt taken (s).
    ///
    /// # Errors
    /// [`SimError`] with the substep and time; the particles hold no NaN afterwards.
    pub fn substep(&mut self, max_dt_s: f64) -> Result<f32, SimError> {
        let dt_s = self
            .policy
            .next_dt_s(
                self.solver.dx_m,
                self.max_wave_speed_m_s(),
                self.max_speed_m_s,
                max_dt_s,
            )
            .map_err(|source| SimError::TimeStep {
                substep: self.substeps,
                time_s: self.time_s,
                source,
            })?;
        let input = SubstepInput {
            materials: &self.materials,
            colliders: &self.colliders,
            gravity_m_s2: self.gravity_m_s2,
            dt_s,
            time_s: self.time_s,
            barrier: false,
        };
        let report = self
            .solver
            .substep(&mut self.particles, &input)
            .map_err(|source| SimError::Solver {
                substep: self.substeps,
                time_s: self.time_s,
                source,
            })?;
        self.max_speed_m_s = report.max_speed_m_s;
        self.last = report;
        self.time_s += dt_s as f64;
        self.substeps += 1;
        Ok(dt_s)
    }

    /// Advances by `duration_s`, landing exactly on the end time.
    ///
    /// # Errors
    /// As [`MpmSystem::substep`].
    pub fn advance(&mut self, duration_s: f64) -> Result<(), SimError> {
        let end = self.time_s + duration_s;
        while end - self.time_s > 1e-12 {
            self.substep(end - self.time_s)?;
        }
        self.time_s = end;
        Ok(())
    }

    /// Conservation diagnostics of the current state.
    pub fn diagnostics(&self) -> Diagnostics {
        Diagnostics::measure(
            &self.particles,
            &self.materials,
            self.gravity_m_s2,
            self.solver.dx_m,
        )
    }
}
