//! Grid update: sums each grid block's node momenta and masses from the (up to 8) particle-block
//! regions that reach it, in a fixed corner order, turns momentum into velocity, adds gravity
//! (v ← p / m + dt g) and applies the colliders in the order given. Node velocities are relative
//! to the solver's reference velocity.

use glam::{IVec3, Vec3A, Vec4};
use rayon::prelude::*;

use super::binning::{BLOCK, BLOCK_NODES, REGION};
use super::grid::{CORNERS, NONE, SparseGrid};
use super::p2g::{Region, region_index};
use crate::collider::Collider;

/// Reduces `scratch` into `grid`, then updates node velocities. Sets `collider_impulse_n_s`
/// (one entry per collider) to the impulse each collider gave the grid, Σ m Δv over the nodes
/// it touched (summed per block, blocks in order: independent of the thread count). Returns the
/// first non-finite node velocity's block index if any.
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
    collider_impulse_n_s: &mut Vec<glam::DVec3>,
) -> Option<usize> {
    let SparseGrid {
        keys,
        contributors,
        mass_kg,
        velocity_m_s,
        ..
    } = grid;
    let per_block: Vec<(bool, Option<Vec<glam::DVec3>>)> = mass_kg
        .par_chunks_mut(BLOCK_NODES)
        .zip(velocity_m_s.par_chunks_mut(BLOCK_NODES))
        .zip(keys.par_iter().zip(contributors.par_iter()))
        .map(|((mass, vel), (key, contrib))| {
            let origin = *key * BLOCK;
            let mut finite = true;
            let mut pushed: Option<Vec<glam::DVec3>> = None;
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
                                if collider.contact_normal(node, time_s).is_some() {
                                    let before = v;
                                    v = collider.apply(node, v + v_ref, time_s) - v_ref;
                                    let j = pushed.get_or_insert_with(|| {
                                        vec![glam::DVec3::ZERO; colliders.len()]
                                    });
                                    j[ci] += ((v - before) * sum.w).as_dvec3();
                                }
                            }
                            finite &= v.is_finite();
                            v
                        } else {
                            Vec3A::ZERO
                        };
                    }
                }
            }
            (finite, pushed)
        })
        .collect();
    collider_impulse_n_s.clear();
    collider_impulse_n_s.resize(colliders.len(), glam::DVec3::ZERO);
    let mut bad = None;
    for (gb, (finite, pushed)) in per_block.into_iter().enumerate() {
        if !finite && bad.is_none() {
            bad = Some(gb);
        }
        for (total, j) in collider_impulse_n_s.iter_mut().zip(pushed.iter().flatten()) {
            *total += *j;
        }
    }
    bad
}
