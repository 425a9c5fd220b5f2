//! The two-way solve of movable solids with the grid nodes that touch them
//! ([`super::coupling`]), over the grids of every deformable object that touches them at once.
//!
//! Each deformable object has its own grid. Solved one grid after another, a solid moved by what
//! the later grids pushed it with after the earlier ones had been solved: a 216 g rigid block
//! between an 8 cm jelly cube under it and a 4 cm one on it (1 cm cells) sank into the lower
//! jelly at 0.8 mm/s, which had met the block before the upper jelly's weight reached it, and
//! with the order reversed the upper jelly sank into the block and slid off it. So every grid's
//! touching nodes take part in one solve: in each Jacobi sweep each node meets the solid's
//! velocity at the start of the sweep with its share of the solid's mass (node mass over the
//! touching mass of all the grids), and the solid takes the sum of all their impulses after the
//! sweep, held on its supports, as on one grid (Tonge et al. 2012's mass splitting).

use glam::{DVec3, Vec3A};
use rayon::prelude::*;

use super::boundary::{GridTouches, Obstacle, Reaction, sum_in_order};
use super::coupling::{COUPLING_CONVERGED_M_S, COUPLING_SWEEPS, Hold, node_impulse};
use crate::mpm::binning::BLOCK_NODES;

/// One deformable object's grid in a two-way solve.
pub struct CoupledGrid<'g, 'o> {
    /// Node masses (kg), in the grid's node order.
    pub mass_kg: &'g [f32],
    /// Node velocities relative to `v_ref` (m/s); the solve changes those that touch solids.
    pub velocity_m_s: &'g mut [Vec3A],
    /// The grid's reference velocity (m/s).
    pub v_ref: Vec3A,
    /// The obstacles as this grid meets them (its pair friction and rule).
    pub obstacles: &'g [Obstacle<'o>],
    /// Per obstacle, which of the solve's solids it is; `None` for one the solve leaves alone
    /// (an immovable obstacle, whose rule the grid has taken already).
    pub solid_of: &'g [Option<usize>],
    /// Per grid block, the nodes touching movable obstacles.
    pub touches: &'g GridTouches,
    /// Per obstacle, the reaction it received from this grid: the solve adds to it.
    pub total: &'g mut [Reaction],
}

/// The two-way solve of `grids` with the movable `solids` they touch (each one's mass, inertia,
/// velocity at the start and supports): Jacobi sweeps with mass splitting, at most
/// [`COUPLING_SWEEPS`], until no node's velocity changes by more than
/// [`COUPLING_CONVERGED_M_S`] (module docs). Adds each grid's impulses to its `total`. The
/// grids are taken in order and their blocks in order, so the sums do not depend on the thread
/// count.
pub fn couple(grids: &mut [CoupledGrid], solids: &[Obstacle]) {
    // Each solid's touching node mass Σ m over every grid, in order: a node's share is m / Σ m.
    let mut contact_mass = vec![0.0f64; solids.len()];
    for g in grids.iter() {
        for (b, ts) in g.touches.iter().enumerate() {
            for t in ts {
                if let Some(s) = g.solid_of[t.obstacle as usize] {
                    contact_mass[s] += g.mass_kg[b * BLOCK_NODES + t.node as usize] as f64;
                }
            }
        }
    }
    let mut motion = Solids::new(solids);
    for _ in 0..COUPLING_SWEEPS {
        let mut sweep = vec![Reaction::default(); solids.len()];
        let mut converged = true;
        for g in grids.iter_mut() {
            let (parts, changes) = sweep_grid(g, solids, &motion, &contact_mass);
            for (k, r) in sum_in_order(&parts, g.obstacles.len()).iter().enumerate() {
                g.total[k].add(r);
                if let Some(s) = g.solid_of[k] {
                    sweep[s].add(r);
                }
            }
            converged &= changes.iter().all(|&c| c <= COUPLING_CONVERGED_M_S);
        }
        motion.take(solids, &sweep);
        if converged {
            break;
        }
    }
}

/// One Jacobi sweep over grid `g`'s touching nodes against the `solids`' `motion`: per block,
/// each obstacle's reaction and the largest node velocity change (m/s).
fn sweep_grid(
    g: &mut CoupledGrid,
    solids: &[Obstacle],
    motion: &Solids,
    contact_mass: &[f64],
) -> (Vec<Vec<Reaction>>, Vec<f32>) {
    let (n, v_ref) = (g.obstacles.len(), g.v_ref);
    let (obstacles, solid_of) = (g.obstacles, g.solid_of);
    g.mass_kg
        .par_chunks(BLOCK_NODES)
        .zip(g.velocity_m_s.par_chunks_mut(BLOCK_NODES))
        .zip(g.touches.par_iter())
        .map(|((mass, vel), ts)| {
            if ts.is_empty() {
                return (Vec::new(), 0.0);
            }
            let mut out = vec![Reaction::default(); n];
            let mut change = 0.0f32;
            for t in ts {
                let k = t.obstacle as usize;
                let Some(s) = solid_of[k] else {
                    continue;
                };
                let (o, m) = (&obstacles[k], mass[t.node as usize]);
                let solid = solids[s].share(m as f64 / contact_mass[s]);
                let (v_solid, w_solid) = motion.motion[s];
                let at = (v_solid + w_solid.cross(t.r_m.as_dvec3())).as_vec3a();
                let v = vel[t.node as usize] + v_ref;
                let j = node_impulse(v - at, t.normal, m, t.r_m, &solid, o.surface, o.friction);
                vel[t.node as usize] += j / m;
                change = change.max((j / m).length());
                out[k].receive(j.as_dvec3(), t.r_m, t.normal);
            }
            (out, change)
        })
        .unzip()
}

/// The solids' motion over a two-way solve: each one's velocity and angular velocity as the
/// sweeps have left it, held on its supports.
pub(super) struct Solids {
    /// Velocity (m/s) and angular velocity (rad/s) of each solid.
    pub(super) motion: Vec<(DVec3, DVec3)>,
    /// Each solid's hold on its supports.
    holds: Vec<Hold>,
}

impl Solids {
    /// The `solids` as they start the solve, held on their supports.
    pub(super) fn new(solids: &[Obstacle]) -> Self {
        let (motion, holds) = solids
            .iter()
            .map(|o| {
                let mut hold = Hold::new(o.supports);
                let (mut v, mut w) = (o.velocity_m_s.as_dvec3(), o.omega_rad_s.as_dvec3());
                o.hold_motion(&mut hold, &mut v, &mut w);
                ((v, w), hold)
            })
            .unzip();
        Self { motion, holds }
    }

    /// Each of `solids` takes its impulses of a sweep, `sweep`, and is held on its supports.
    fn take(&mut self, solids: &[Obstacle], sweep: &[Reaction]) {
        for (((o, r), (v, w)), hold) in solids
            .iter()
            .zip(sweep)
            .zip(&mut self.motion)
            .zip(&mut self.holds)
        {
            *v += r.impulse_n_s * o.inverse_mass;
            *w += o.inverse_inertia * r.angular_impulse_n_m_s;
            o.hold_motion(hold, v, w);
        }
    }

    /// After a sweep whose per-part reactions are `parts` and largest velocity changes (m/s)
    /// `changes`: each of `solids` takes the sweep's impulses and is held on its supports, and
    /// `total` gains them. Whether the solve has converged ([`COUPLING_CONVERGED_M_S`]).
    pub(super) fn follow(
        &mut self,
        solids: &[Obstacle],
        parts: &[Vec<Reaction>],
        changes: &[f32],
        total: &mut [Reaction],
    ) -> bool {
        let sweep = sum_in_order(parts, solids.len());
        self.take(solids, &sweep);
        for (t, r) in total.iter_mut().zip(&sweep) {
            t.add(r);
        }
        changes.iter().all(|&c| c <= COUPLING_CONVERGED_M_S)
    }
}
