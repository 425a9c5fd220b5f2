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
use super::p2g::{self, Region};
use super::particles::Particles;
use super::reach::{BARRIER_REACH, NODE_REACH, NodeGaps};
use super::{deep_nodes, grid_update};
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
    /// Whether "separate" plane and box colliders met the particles through the particle
    /// barrier before this substep (`contact::barrier`, as the world does): their grid rule then
    /// waits until particle centres pass a quarter of their size inside the surface.
    pub barrier: bool,
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
    v_ref: Vec3A,
    collider_impulses: grid_update::ColliderImpulses,
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
            v_ref: Vec3A::ZERO,
            collider_impulses: Default::default(),
        }
    }

    /// The sparse grid as of the last substep (node masses and velocities).
    pub fn grid(&self) -> &SparseGrid {
        &self.grid
    }

    /// Advances `particles` by one substep: [`Self::scatter_and_update`] then [`Self::gather`].
    ///
    /// # Errors
    /// [`MpmError`] when the state would become non-finite or a particle leaves the grid; no NaN
    /// is written into `particles`.
    pub fn substep(
        &mut self,
        particles: &mut Particles,
        input: &SubstepInput<'_>,
    ) -> Result<SubstepReport, MpmError> {
        self.scatter_and_update(particles, input)?;
        self.gather(particles, input)
    }

    /// First half of a substep: binning, P2G and the grid update (gravity, colliders). Afterwards
    /// [`Self::grid`] holds this substep's node masses and velocities (relative to
    /// [`Self::reference_velocity_m_s`]), which a coupling scheme may edit through
    /// [`Self::grid_mut`] before [`Self::gather`].
    ///
    /// # Errors
    /// [`MpmError`] for a bad material index, a particle outside the grid or a non-finite grid.
    pub fn scatter_and_update(
        &mut self,
        particles: &Particles,
        input: &SubstepInput<'_>,
    ) -> Result<(), MpmError> {
        self.v_ref = Vec3A::ZERO;
        if particles.is_empty() {
            self.bins = Binning::default();
            self.grid.rebuild(&self.bins);
            return Ok(());
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
        self.v_ref = mean_velocity(particles);
        let dx = self.dx_m;
        let gaps = collider_gaps(&self.grid, dx, particles, input, Collider::is_gated);
        // The thin boxes that hold every node inside them: only which side the material is on.
        let sides = collider_gaps(&self.grid, dx, particles, input, |c| c.takes_sides(dx));
        p2g::scatter(
            particles,
            &self.bins,
            input.materials,
            self.dx_m,
            input.dt_s,
            self.v_ref,
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
            self.v_ref,
            &mut self.collider_impulses,
            (gaps.as_ref(), sides.as_ref()),
        ) {
            return Err(MpmError::NonFiniteGrid { block });
        }
        let (t, colliders) = (input.time_s, input.colliders);
        let barrier = |c: &&Collider| c.takes_barrier() && c.is_active(t);
        if input.barrier && colliders.iter().any(|c| barrier(&c)) {
            deep_nodes::tie(&mut self.grid, dx, |x| {
                colliders
                    .iter()
                    .filter(barrier)
                    .filter_map(|c| c.signed_distance(x, t))
                    .min_by(|a, b| a.0.total_cmp(&b.0))
            });
        }
        Ok(())
    }

    /// Second half of a substep: G2P from the current grid, advecting `particles` (which must be
    /// the set given to [`Self::scatter_and_update`], unchanged).
    ///
    /// # Errors
    /// [`MpmError::NonFiniteParticle`] (the particle is left at its previous state; this also
    /// catches a non-finite grid velocity left by an edit).
    pub fn gather(
        &mut self,
        particles: &mut Particles,
        input: &SubstepInput<'_>,
    ) -> Result<SubstepReport, MpmError> {
        if particles.is_empty() {
            return Ok(SubstepReport::default());
        }
        let r = g2p::gather(
            particles,
            &self.bins,
            &self.grid,
            input.materials,
            self.dx_m,
            input.dt_s,
            self.v_ref,
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

    /// The velocity of the frame the grid works in this substep (m/s): grid node velocities are
    /// relative to it.
    pub fn reference_velocity_m_s(&self) -> Vec3A {
        self.v_ref
    }

    /// The normal impulse each grid collider gave this grid in the last grid update (N s, one
    /// entry per collider; empty before the first update; see [`grid_update::ColliderImpulses`]).
    pub fn collider_impulses_n_s(&self) -> &[glam::DVec3] {
        &self.collider_impulses.total_n_s
    }

    /// The friction impulse each grid collider gave this grid in the last grid update (N s:
    /// each node's impulse less its part along the collider's normal there; one entry per
    /// collider, empty before the first update).
    pub fn collider_friction_n_s(&self) -> &[glam::DVec3] {
        &self.collider_impulses.friction_n_s
    }

    /// Grid nodes with mass inside each grid collider in the last update (one entry per
    /// collider; empty before the first update): the material touching it.
    pub fn collider_nodes(&self) -> &[u64] {
        &self.collider_impulses.nodes
    }

    /// The sparse grid for editing between [`Self::scatter_and_update`] and [`Self::gather`]
    /// (node velocities relative to [`Self::reference_velocity_m_s`]).
    pub fn grid_mut(&mut self) -> &mut SparseGrid {
        &mut self.grid
    }

    /// Releases scratch memory beyond what the last substep used.
    pub fn shrink(&mut self) {
        self.scratch.truncate(self.bins.blocks.len());
        self.scratch.shrink_to_fit();
    }
}

/// The node gaps of `particles` on `grid` (cell `dx_m`) against those of `input`'s colliders
/// that `which` picks, at the start of the substep ([`super::reach`]); `None` where none is
/// active.
fn collider_gaps(
    grid: &SparseGrid,
    dx_m: f32,
    particles: &Particles,
    input: &SubstepInput<'_>,
    which: impl Fn(&Collider) -> bool + Sync,
) -> Option<NodeGaps> {
    let picked = |c: &&Collider| which(c) && c.is_active(input.time_s);
    input.colliders.iter().any(|c| picked(&c)).then(|| {
        NodeGaps::new(grid, dx_m, particles, |x| {
            input
                .colliders
                .iter()
                .filter(picked)
                .filter_map(|c| {
                    let (phi, n) = c.signed_distance(x, input.time_s)?;
                    let barrier = input.barrier && c.takes_barrier();
                    Some((phi, n, if barrier { BARRIER_REACH } else { NODE_REACH }))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))
        })
        .with_barrier(input.barrier)
    })
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
