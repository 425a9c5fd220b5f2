//! One MLS-MPM substep on one particle set with its own sparse grid: binning, P2G, grid update,
//! G2P. The COM layer gives every deformable object its own solver; the shared-grid baseline uses
//! one for all particles.
//!
//! The grid works in a frame moving with the particles' mass-weighted mean velocity v_ref (MPM is
//! Galilean invariant; the transfers are unchanged in exact arithmetic). In f32 this keeps a fast
//! object's uniform velocity from leaking rounding noise into C and F: a free-falling block's F
//! stays the identity to 1e-6 instead of drifting by ~3e-5 over 0.5 s.

use glam::Vec3A;

use super::binning::Binning;
use super::g2p;
use super::grid::SparseGrid;
use super::grid_update;
use super::p2g::{self, Region};
use super::particles::Particles;
use crate::collider::Collider;
use crate::material::Material;

/// Why a substep failed. The particle state holds no NaN afterwards.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MpmError {
    /// A particle's update was not finite (left at its previous state).
    #[error(
        "particle {particle} became non-finite (NaN or inf) in G2P: the run is unstable (dt too large for the material?)"
    )]
    NonFiniteParticle {
        /// Particle index.
        particle: usize,
    },
    /// A grid node velocity was not finite before G2P (nothing was written to particles).
    #[error(
        "grid block {block} has a non-finite velocity after the grid update: the run is unstable"
    )]
    NonFiniteGrid {
        /// Grid block index.
        block: usize,
    },
    /// A particle position outside the addressable grid or not finite.
    #[error("particle {particle} is outside the addressable grid or not finite")]
    OutOfGrid {
        /// Particle index.
        particle: usize,
    },
    /// A particle refers to a material the solver was not given.
    #[error("particle {particle} has material index {material} but only {count} materials exist")]
    BadMaterial {
        /// Particle index.
        particle: usize,
        /// Its material index.
        material: u16,
        /// Materials given.
        count: usize,
    },
}

/// What one substep needs besides the particles.
#[derive(Debug, Clone, Copy)]
pub struct SubstepInput<'a> {
    /// Material table indexed by `Particles::material`.
    pub materials: &'a [Material],
    /// Colliders, applied in order at every grid node.
    pub colliders: &'a [Collider],
    /// Gravity (m/s²).
    pub gravity_m_s2: Vec3A,
    /// Substep (s).
    pub dt_s: f32,
    /// Simulated time at the start of the substep (s), for moving colliders.
    pub time_s: f64,
}

/// What one substep did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SubstepReport {
    /// Largest particle speed after the substep (m/s).
    pub max_speed_m_s: f32,
    /// Grid blocks allocated (each 4³ nodes).
    pub grid_blocks: usize,
    /// Particle blocks (occupied 4³-cell blocks).
    pub particle_blocks: usize,
}

/// An MLS-MPM solver with cell size `dx_m` and reusable sparse-grid buffers.
#[derive(Debug, Clone)]
pub struct MpmSolver {
    /// Grid cell size (m).
    pub dx_m: f32,
    bins: Binning,
    grid: SparseGrid,
    scratch: Vec<Region>,
    velocity_regions: Vec<g2p::VelocityRegion>,
}

impl MpmSolver {
    /// A solver with grid cell size `dx_m` (m, > 0).
    pub fn new(dx_m: f32) -> Self {
        Self {
            dx_m,
            bins: Binning::default(),
            grid: SparseGrid::default(),
            scratch: Vec::new(),
            velocity_regions: Vec::new(),
        }
    }

    /// The sparse grid as of the last substep (node masses and velocities).
    pub fn grid(&self) -> &SparseGrid {
        &self.grid
    }

    /// Advances `particles` by one substep.
    ///
    /// # Errors
    /// [`MpmError`] when the state would become non-finite or a particle leaves the grid; no NaN
    /// is written into `particles`.
    pub fn substep(
        &mut self,
        particles: &mut Particles,
        input: &SubstepInput<'_>,
    ) -> Result<SubstepReport, MpmError> {
        if particles.is_empty() {
            return Ok(SubstepReport::default());
        }
        if let Some(p) = particles
            .material
            .iter()
            .position(|&m| m as usize >= input.materials.len())
        {
            return Err(MpmError::BadMaterial {
                particle: p,
                material: particles.material[p],
                count: input.materials.len(),
            });
        }
        let inv_dx = 1.0 / self.dx_m;
        self.bins
            .rebuild(&particles.x, inv_dx)
            .map_err(|particle| MpmError::OutOfGrid { particle })?;
        self.grid.rebuild(&self.bins);
        let v_ref = mean_velocity(particles);
        p2g::scatter(
            particles,
            &self.bins,
            input.materials,
            self.dx_m,
            input.dt_s,
            v_ref,
            &mut self.scratch,
        );
        if let Some(block) = grid_update::update(
            &mut self.grid,
            &self.scratch,
            self.dx_m,
            input.dt_s,
            input.gravity_m_s2,
            input.colliders,
            input.time_s,
            v_ref,
        ) {
            return Err(MpmError::NonFiniteGrid { block });
        }
        let r = g2p::gather(
            particles,
            &self.bins,
            &self.grid,
            input.materials,
            self.dx_m,
            input.dt_s,
            v_ref,
            &mut self.velocity_regions,
        );
        if let Some(particle) = r.first_non_finite {
            return Err(MpmError::NonFiniteParticle { particle });
        }
        Ok(SubstepReport {
            max_speed_m_s: r.max_speed_m_s,
            grid_blocks: self.grid.block_count(),
            particle_blocks: self.bins.blocks.len(),
        })
    }

    /// Releases scratch memory beyond what the last substep used.
    pub fn shrink(&mut self) {
        self.scratch.truncate(self.bins.blocks.len());
        self.scratch.shrink_to_fit();
    }
}

/// Mass-weighted mean velocity (m/s), summed in f64 over fixed chunks (thread-count independent).
fn mean_velocity(p: &Particles) -> Vec3A {
    use rayon::prelude::*;
    const CHUNK: usize = 4096;
    let n = p.len();
    let parts: Vec<(glam::DVec3, f64)> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut mv = glam::DVec3::ZERO;
            let mut m = 0.0f64;
            for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                mv += p.v[i].as_dvec3() * p.mass_kg[i] as f64;
                m += p.mass_kg[i] as f64;
            }
            (mv, m)
        })
        .collect();
    let (mv, m) = parts
        .iter()
        .fold((glam::DVec3::ZERO, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    if m > 0.0 && mv.is_finite() {
        (mv / m).as_vec3a()
    } else {
        Vec3A::ZERO
    }
}
