//! Grid update: sums each grid block's node momenta and masses from the (up to 8) particle-block
//! regions that reach it, in a fixed corner order, turns momentum into velocity, adds gravity
//! (v ← p / m + dt g) and applies the colliders in the order given. Node velocities are relative
//! to the solver's reference velocity.

use glam::{IVec3, Vec3A, Vec4};
use rayon::prelude::*;

use super::binning::{BLOCK, BLOCK_NODES, REGION};
use super::grid::{CORNERS, NONE, SparseGrid};
use super::p2g::{Region, region_index};
use super::reach::NodeGaps;
use crate::collider::Collider;

/// The impulse each grid collider gave a grid in its last update, split at each node it touched
/// into the normal part Σ m n (n·Δv), n the collider's normal there, and the rest, its friction
/// (N s). Kept by the solver between updates, so that no substep allocates for it.
#[derive(Debug, Clone, Default)]
pub struct ColliderImpulses {
    /// `[blocks × colliders]` per grid block (one slot when there is no collider): the normal
    /// impulse, the friction impulse and the nodes with mass inside the collider.
    per_block: Vec<(glam::DVec3, glam::DVec3, u32)>,
    /// `[colliders]` the normal impulses summed over the blocks, in block order (independent of
    /// the thread count).
    pub total_n_s: Vec<glam::DVec3>,
    /// `[colliders]` the friction impulses (each node's impulse less its normal part), summed
    /// as `total_n_s` is.
    pub friction_n_s: Vec<glam::DVec3>,
    /// `[colliders]` grid nodes with mass inside each, whether or not they took its rule (a
    /// gated collider's rule waits for material to reach it), and those outside it that took
    /// its rule ([`super::reach::OUTSIDE`]): the material touching it.
    pub nodes: Vec<u64>,
}

/// Reduces `scratch` into `grid`, then updates node velocities; `impulses` gets each collider's
/// normal impulse on the grid. With `gaps` (the grid's particles against the colliders' surfaces),
/// a node inside a plane or box collider takes its rule only where material meets the surface
/// within the substep ([`super::reach`]), and so does a node up to half a cell outside it
/// ([`super::reach::OUTSIDE`]); the domain bound holds every node outside it. With `sides` (the
/// grid's particles against the boxes that hold every node inside them), a node behind such a
/// thin box holds the material on its near side, as one behind a thin gated box does
/// ([`NodeGaps::behind_normal`]). Returns the first non-finite node velocity's block index if
/// any.
#[allow(clippy::too_many_arguments)]
pub fn update(
    grid: &mut SparseGrid,
    scratch: &[Region],
    dx_m: f32,
    dt_s: f32,
    gravity_m_s2: Vec3A,
    colliders: &[Collider],
    time_s: f64,
    v_ref: Vec3A,
    impulses: &mut ColliderImpulses,
    (gaps, sides): (Option<&NodeGaps>, Option<&NodeGaps>),
) -> Option<usize> {
    let SparseGrid {
        keys,
        contributors,
        mass_kg,
        velocity_m_s,
        ..
    } = grid;
    let stride = colliders.len().max(1);
    impulses.per_block.clear();
    impulses.per_block.resize(
        keys.len() * stride,
        (glam::DVec3::ZERO, glam::DVec3::ZERO, 0),
    );
    let bad = mass_kg
        .par_chunks_mut(BLOCK_NODES)
        .zip(velocity_m_s.par_chunks_mut(BLOCK_NODES))
        .zip(keys.par_iter().zip(contributors.par_iter()))
        .zip(impulses.per_block.par_chunks_mut(stride))
        .enumerate()
        .map(|(gb, (((mass, vel), (key, contrib)), pushed))| {
            let origin = *key * BLOCK;
            let mut finite = true;
            // Sum the regions corner by corner (a fixed order per node): corner d covers local
            // nodes 0..4 on axes where d = 0 and 0..2 on axes where d = 1 (region index l + 4d).
            let mut acc = [Vec4::ZERO; BLOCK_NODES];
            for (c, d) in CORNERS.iter().enumerate() {
                let pb = contrib[c];
                if pb == NONE {
                    continue;
                }
                let region = &scratch[pb as usize];
                let span = |k: i32| if k == 0 { 4 } else { REGION - 4 };
                let (d, sx, sy, sz) = (d.as_uvec3(), span(d.x), span(d.y), span(d.z));
                for lz in 0..sz {
                    for ly in 0..sy {
                        let row = region_index(
                            4 * d.x as usize,
                            ly + 4 * d.y as usize,
                            lz + 4 * d.z as usize,
                        );
                        let out = 4 * ly + 16 * lz;
                        for lx in 0..sx {
                            acc[out + lx] += region[row + lx];
                        }
                    }
                }
            }
            for lz in 0..BLOCK as usize {
                for ly in 0..BLOCK as usize {
                    for lx in 0..BLOCK as usize {
                        let sum = acc[lx + 4 * ly + 16 * lz];
                        let l = lx + 4 * ly + 16 * lz;
                        mass[l] = sum.w;
                        vel[l] = if sum.w > 0.0 {
                            let mut v =
                                Vec3A::new(sum.x, sum.y, sum.z) / sum.w + gravity_m_s2 * dt_s;
                            let node = (origin + IVec3::new(lx as i32, ly as i32, lz as i32))
                                .as_vec3a()
                                * dx_m;
                            // v is relative to v_ref; colliders see absolute velocity, and only the
                            // nodes they touch take the round trip through it.
                            for (ci, collider) in colliders.iter().enumerate() {
                                let i = gb * BLOCK_NODES + l;
                                let gate = gaps.filter(|_| collider.is_gated());
                                let inside = collider.contact_normal(node, time_s);
                                if inside.is_some() {
                                    pushed[ci].2 += 1;
                                }
                                // A gated collider's rule also acts up to half a cell outside
                                // it, and behind a thin one (`NodeGaps::rule_normal`).
                                let n = match (inside, gate) {
                                    (Some(n), None) => sides
                                        .filter(|_| collider.takes_sides(dx_m))
                                        .and_then(|s| s.behind_normal(i, 0.0, n, dx_m))
                                        .unwrap_or(n),
                                    (None, None) => {
                                        let behind = sides
                                            .filter(|_| collider.takes_sides(dx_m))
                                            .and_then(|s| {
                                                let (phi, n) =
                                                    collider.signed_distance(node, time_s)?;
                                                let phi = phi.max(f32::MIN_POSITIVE);
                                                s.behind_normal(i, phi, n, dx_m)
                                            });
                                        match behind {
                                            Some(n) => {
                                                pushed[ci].2 += 1;
                                                n
                                            }
                                            None => continue,
                                        }
                                    }
                                    (_, Some(g)) => {
                                        // Inside by the contact test, whatever the distance's
                                        // round-off says, and the other way round.
                                        let rule = match inside {
                                            Some(n) => g.rule_normal(i, 0.0, n, dx_m),
                                            None => collider
                                                .signed_distance(node, time_s)
                                                .and_then(|(phi, n)| {
                                                    let phi = phi.max(f32::MIN_POSITIVE);
                                                    g.rule_normal(i, phi, n, dx_m)
                                                }),
                                        };
                                        match rule {
                                            Some(n) => n,
                                            None => continue,
                                        }
                                    }
                                };
                                let vc = collider.velocity_at(time_s);
                                if let Some(g) = gate {
                                    // Deep inside a barrier's surface: tied after the update
                                    // (`deep_nodes`), not held.
                                    let tied = g.barrier
                                        && collider.takes_barrier()
                                        && collider
                                            .signed_distance(node, time_s)
                                            .is_some_and(|(phi, _)| g.tied(true, phi, dx_m));
                                    if tied || !g.reaches(i, (v + v_ref - vc).dot(n), dt_s) {
                                        continue;
                                    }
                                    if inside.is_none() {
                                        // It holds material at the surface: a contact, as a
                                        // node inside is.
                                        pushed[ci].2 += 1;
                                    }
                                }
                                let before = v;
                                v = collider.apply_along(n, v + v_ref, time_s) - v_ref;
                                let normal = n * n.dot(v - before) * sum.w;
                                pushed[ci].0 += normal.as_dvec3();
                                pushed[ci].1 += ((v - before) * sum.w - normal).as_dvec3();
                            }
                            finite &= v.is_finite();
                            v
                        } else {
                            Vec3A::ZERO
                        };
                    }
                }
            }
            if finite { usize::MAX } else { gb }
        })
        .min()
        .unwrap_or(usize::MAX);
    impulses.total_n_s.clear();
    impulses
        .total_n_s
        .resize(colliders.len(), glam::DVec3::ZERO);
    impulses.friction_n_s.clear();
    impulses
        .friction_n_s
        .resize(colliders.len(), glam::DVec3::ZERO);
    impulses.nodes.clear();
    impulses.nodes.resize(colliders.len(), 0);
    for block in impulses.per_block.chunks(stride) {
        for (((total, friction), nodes), (j, f, n)) in impulses
            .total_n_s
            .iter_mut()
            .zip(impulses.friction_n_s.iter_mut())
            .zip(impulses.nodes.iter_mut())
            .zip(block)
        {
            *total += *j;
            *friction += *f;
            *nodes += u64::from(*n);
        }
    }
    (bad != usize::MAX).then_some(bad)
}
