//! The MPM part of a world substep, one function per method: `com` (every awake deformable
//! object on its own grid), `multi-field` (per-object fields coupled at shared nodes, Bardenhagen
//! et al. 2000, [`crate::mpm::multi_field`]) and `mpm` (every awake deformable object on one
//! shared grid, contact through the grid). Rigid and static objects never reach this file; the
//! COM layer steps them afterwards.

use glam::Vec3A;

use super::{Body, World, WorldError, WorldStats};
use crate::collider::Collider;
use crate::material::Material;
use crate::mpm::{MpmError, Particles, SubstepInput, SubstepReport, multi_field};
use crate::scene::ObjectKind;

/// Whether `b` runs MPM this substep.
fn simulated(b: &Body) -> bool {
    b.is_active() && b.kind == ObjectKind::Deformable
}

/// What every solver call of one substep shares: colliders, gravity (m/s²), dt (s) and the time
/// at the start of the substep (s).
#[derive(Clone, Copy)]
struct Step<'a> {
    colliders: &'a [Collider],
    gravity_m_s2: Vec3A,
    dt_s: f32,
    time_s: f64,
}

impl<'a> Step<'a> {
    fn new(colliders: &'a [Collider], gravity_m_s2: Vec3A, dt_s: f32, time_s: f64) -> Self {
        Self {
            colliders,
            gravity_m_s2,
            dt_s,
            time_s,
        }
    }

    /// The solver input for `materials`.
    fn input(self, materials: &'a [Material]) -> SubstepInput<'a> {
        SubstepInput {
            materials,
            colliders: self.colliders,
            gravity_m_s2: self.gravity_m_s2,
            dt_s: self.dt_s,
            time_s: self.time_s,
        }
    }

    /// A solver error as the world reports it: object, substep and time.
    fn error(self, stats: &WorldStats, object: &str, source: MpmError) -> WorldError {
        WorldError::Solver {
            object: object.to_string(),
            substep: stats.substeps,
            time_s: self.time_s,
            source,
        }
    }

    /// Records body `b`'s result in it and in `stats`, or names it in the error.
    fn finish(
        self,
        stats: &mut WorldStats,
        b: &mut Body,
        r: Result<SubstepReport, MpmError>,
    ) -> Result<(), WorldError> {
        let r = r.map_err(|e| self.error(stats, &b.name, e))?;
        b.max_speed_m_s = r.max_speed_m_s;
        stats.mpm_particle_substeps += b.particles.len() as u64;
        Ok(())
    }
}

impl World {
    /// Method `com`: every awake deformable object runs a whole substep on its own grid.
    pub(super) fn mpm_per_object_substep(&mut self, dt_s: f32) -> Result<(), WorldError> {
        let step = Step::new(&self.colliders, self.gravity_m_s2, dt_s, self.time_s);
        for b in &mut self.bodies {
            if !simulated(b) {
                b.substeps_skipped += 1;
                continue;
            }
            let r = b
                .solver
                .substep(&mut b.particles, &step.input(&b.materials));
            step.finish(&mut self.stats, b, r)?;
        }
        Ok(())
    }

    /// Method `multi-field`: per-object P2G and grid update, multi-field contact at shared
    /// nodes, per-object G2P.
    pub(super) fn multi_field_substep(&mut self, dt_s: f32) -> Result<(), WorldError> {
        let dx_m = self.dx_m();
        let step = Step::new(&self.colliders, self.gravity_m_s2, dt_s, self.time_s);
        for b in &mut self.bodies {
            if !simulated(b) {
                b.substeps_skipped += 1;
                continue;
            }
            let input = step.input(&b.materials);
            if let Err(e) = b.solver.scatter_and_update(&b.particles, &input) {
                return Err(step.error(&self.stats, &b.name, e));
            }
        }
        let mut fields: Vec<multi_field::Field<'_>> = self
            .bodies
            .iter_mut()
            .filter(|b| simulated(b))
            .map(|b| {
                let v_ref_m_s = b.solver.reference_velocity_m_s();
                multi_field::Field {
                    grid: b.solver.grid_mut(),
                    v_ref_m_s,
                    friction: b.friction,
                }
            })
            .collect();
        let r = multi_field::couple(&mut fields, dx_m, step.colliders, step.time_s);
        drop(fields);
        self.stats.contact_nodes += r.corrected as u64;
        for b in self.bodies.iter_mut().filter(|b| simulated(b)) {
            let r = b.solver.gather(&mut b.particles, &step.input(&b.materials));
            step.finish(&mut self.stats, b, r)?;
        }
        Ok(())
    }

    /// Method `mpm`: every awake deformable object on one shared grid; each object's particles
    /// are copied in, stepped together and copied back.
    pub(super) fn mpm_shared_substep(&mut self, dt_s: f32) -> Result<(), WorldError> {
        let ids: Vec<usize> = (0..self.bodies.len())
            .filter(|&k| simulated(&self.bodies[k]))
            .collect();
        let mut all = Particles::default();
        let mut materials = Vec::new();
        for &k in &ids {
            let b = &self.bodies[k];
            let start = all.len();
            all.extend_from(&b.particles);
            all.material[start..].fill(materials.len() as u16);
            materials.push(b.materials[0].clone());
        }
        let step = Step::new(&self.colliders, self.gravity_m_s2, dt_s, self.time_s);
        let r = self
            .shared
            .substep(&mut all, &step.input(&materials))
            .map_err(|e| step.error(&self.stats, "shared grid", e))?;
        self.stats.mpm_particle_substeps += all.len() as u64;
        let mut start = 0;
        for &k in &ids {
            let b = &mut self.bodies[k];
            let end = start + b.particles.len();
            b.particles.x.copy_from_slice(&all.x[start..end]);
            b.particles.v.copy_from_slice(&all.v[start..end]);
            b.particles.c.copy_from_slice(&all.c[start..end]);
            b.particles.f.copy_from_slice(&all.f[start..end]);
            b.particles
                .plastic
                .copy_from_slice(&all.plastic[start..end]);
            b.max_speed_m_s = r.max_speed_m_s;
            start = end;
        }
        Ok(())
    }
}
