//! The light grid nodes deep inside a solid that meets material through the particle barrier
//! (`contact::barrier`), tied to the node above them.
//!
//! The barrier holds the particles a quarter of their size above the surface and leaves the
//! grid free, so the nodes more than [`HELD_DEPTH`] cells inside the solid carry only the
//! tails of the bottom layer's stencils: their mass is a few per cent of a particle's, and the
//! stress of that layer, which P2G spreads by the stencil's gradient, moves them fast. G2P then
//! brought that motion back into the bottom layer's velocity and its velocity gradient C (a
//! node below a particle moving down reads as the particle's stretching): the barrier held the
//! layer's positions while its deformation gradient relaxed, and the layer above drew towards it
//! with no strain to show for it. Measured on a 5 cm jelly slab (E = 1e5 Pa, ν 0.3, 5 mm
//! particles and cells) on a "separate" plane under a 1.6 kg rigid block: the gap between its
//! two lowest layers of particles closed by 0.47 mm, every gap above by about 0.12 mm.
//!
//! So after the grid update each such node and the node one cell above it (along the
//! surface's normal) share their normal velocity, the mass-weighted mean, which keeps the
//! grid's momentum: the solid takes nothing from it, and the barrier still carries the load
//! (and with it the contact's friction). Tied, the gap closes by 0.16 mm. Holding those nodes'
//! normal velocity at the solid's instead did as well for the gap, but then the nodes carried
//! the load, the particles no longer reached the barrier, and a jelly on a 30° ramp slid at
//! twice Coulomb's acceleration.

use glam::{IVec3, Vec3A};
use rayon::prelude::*;

use super::binning::{BLOCK, BLOCK_NODES, pack};
use super::grid::SparseGrid;

/// Depth inside the surface (cells) past which a node is tied to the node above it: three
/// quarters of a cell, past the stencil of a particle resting on the surface but for its tail.
pub const HELD_DEPTH: f32 = 0.75;

/// Ties every node of `grid` (cell `dx_m`, m) with mass that lies deeper than [`HELD_DEPTH`]
/// inside `surface` to the node one cell out along the surface's normal there (module docs).
/// `surface(x)` gives the signed distance (m) and outward unit normal at a node position `x`
/// (m), `None` where no barrier surface is near. Deterministic: the nodes are tied in the
/// grid's node order, whatever the thread count.
pub fn tie(
    grid: &mut SparseGrid,
    dx_m: f32,
    surface: impl Fn(Vec3A) -> Option<(f32, Vec3A)> + Sync,
) {
    let depth = -HELD_DEPTH * dx_m;
    let SparseGrid {
        keys,
        mass_kg,
        velocity_m_s,
        ..
    } = grid;
    let deep: Vec<(usize, IVec3, IVec3)> = keys
        .par_iter()
        .zip(mass_kg.par_chunks(BLOCK_NODES))
        .enumerate()
        .flat_map_iter(|(b, (key, mass))| {
            let origin = *key * BLOCK;
            let surface = &surface;
            mass.iter().enumerate().filter_map(move |(l, &m)| {
                if m <= 0.0 {
                    return None;
                }
                let local = IVec3::new((l % 4) as i32, ((l / 4) % 4) as i32, (l / 16) as i32);
                let node = origin + local;
                let (phi, n) = surface(node.as_vec3a() * dx_m)?;
                let up = n.round().as_ivec3();
                (phi < depth && n.is_finite() && up != IVec3::ZERO).then_some((
                    b * BLOCK_NODES + l,
                    node + up,
                    up,
                ))
            })
        })
        .collect();
    for (i, above, up) in deep {
        let key = IVec3::new(
            above.x.div_euclid(BLOCK),
            above.y.div_euclid(BLOCK),
            above.z.div_euclid(BLOCK),
        );
        let Ok(b) = keys.binary_search_by_key(&pack(key), |k| pack(*k)) else {
            continue;
        };
        let l = above - key * BLOCK;
        let j = b * BLOCK_NODES + (l.x + 4 * l.y + 16 * l.z) as usize;
        let (mi, mj) = (mass_kg[i], mass_kg[j]);
        if !(mi > 0.0 && mj > 0.0) {
            continue;
        }
        // The normal along the lattice step between them: both take the same component.
        let n = up.as_vec3a().normalize();
        let (vi, vj) = (velocity_m_s[i].dot(n), velocity_m_s[j].dot(n));
        let shared = (mi * vi + mj * vj) / (mi + mj);
        velocity_m_s[i] += n * (shared - vi);
        velocity_m_s[j] += n * (shared - vj);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid of two blocks stacked along z, every node with mass `m` and velocity `v`.
    fn column(m: [f32; 2], v: [Vec3A; 2]) -> SparseGrid {
        let keys = vec![IVec3::new(0, 0, -1), IVec3::new(0, 0, 0)];
        let mut mass_kg = vec![m[0]; BLOCK_NODES];
        mass_kg.extend(vec![m[1]; BLOCK_NODES]);
        let mut velocity_m_s = vec![v[0]; BLOCK_NODES];
        velocity_m_s.extend(vec![v[1]; BLOCK_NODES]);
        SparseGrid {
            keys,
            contributors: Vec::new(),
            pb_grid: Vec::new(),
            mass_kg,
            velocity_m_s,
        }
    }

    #[test]
    fn a_deep_node_and_the_one_above_share_their_normal_velocity_and_keep_the_momentum() {
        // A plane at z = 0 (1 cm cells): the nodes of the lower block lie 1 to 4 cells deep, the
        // upper block's on or above the surface. Light fast nodes below, heavy slow ones above.
        let dx = 0.01;
        let (m, v) = (
            [0.1, 1.0],
            [Vec3A::new(0.3, 0.0, -2.0), Vec3A::new(0.0, 0.0, 0.1)],
        );
        let mut g = column(m, v);
        let momentum = |g: &SparseGrid| {
            g.mass_kg
                .iter()
                .zip(&g.velocity_m_s)
                .map(|(m, v)| *v * *m)
                .sum::<Vec3A>()
        };
        let before = momentum(&g);
        tie(&mut g, dx, |x| Some((x.z, Vec3A::Z)));
        let after = momentum(&g);
        assert!(
            (after - before).length() < 1e-5 * before.length(),
            "{before} -> {after}"
        );
        // The node 1 cell deep (local z = 3 of the lower block), tied in turn to the ones below
        // it, was tied last to the surface node (local z = 0 of the upper block): they share a
        // normal velocity between the light nodes' -2 m/s and the heavy node's 0.1 m/s.
        let (deep, top) = (3 * 16, BLOCK_NODES);
        let dz = g.velocity_m_s[deep].z;
        assert!((dz - g.velocity_m_s[top].z).abs() < 1e-6);
        assert!(dz < 0.1 && dz > -2.0, "{dz}");
        // Only the normal component changes.
        assert_eq!(g.velocity_m_s[deep].x, 0.3);
        assert_eq!(g.velocity_m_s[top].x, 0.0);
        // A node on the surface or outside it is never tied to anything further out.
        assert_eq!(g.velocity_m_s[BLOCK_NODES + 16].z, 0.1);
    }

    #[test]
    fn nodes_within_three_quarters_of_a_cell_of_the_surface_are_left_free() {
        // The plane at z = -0.8 cm: the lower block's top node layer lies 0.8 cells above it
        // (outside), the next 0.2 cells deep, the one below 1.2 cells deep.
        let dx = 0.01;
        let v = [Vec3A::new(0.0, 0.0, -2.0), Vec3A::ZERO];
        let mut g = column([0.1, 1.0], v);
        tie(&mut g, dx, |x| Some((x.z + 0.008, Vec3A::Z)));
        // Local z = 2 of the lower block (node z = -2 cm, 1.2 cells deep) was tied to z = 3.
        assert_eq!(g.velocity_m_s[2 * 16].z, g.velocity_m_s[3 * 16].z);
        // Local z = 3 (0.2 cells deep) ties nothing above it: the upper block keeps its rest.
        assert_eq!(g.velocity_m_s[BLOCK_NODES].z, 0.0);
    }
}
