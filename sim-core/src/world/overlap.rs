//! Interpenetration of two objects measured on occupied grid cells (cell = dx), the check of the
//! paper-scene tests and of `splatphys bench stability`.
//!
//! Each cell B's particles occupy gets a depth: 1 for a boundary cell of B (one of its 6 face
//! neighbours is not occupied), d + 1 for an occupied cell next to a cell of depth d (a
//! breadth-first search inward). A particle of A in a cell of depth d lies d - 1 cells inside B:
//! touching surfaces share boundary cells only (depth 1, penetration 0), and a particle in an
//! interior cell of B (B occupies it and all 6 face neighbours) lies at least one cell deep.

use std::collections::{HashMap, VecDeque};

use glam::{IVec3, Vec3A};

/// The 6 face neighbours of a cell.
const FACES: [IVec3; 6] = [
    IVec3::X,
    IVec3::NEG_X,
    IVec3::Y,
    IVec3::NEG_Y,
    IVec3::Z,
    IVec3::NEG_Z,
];

/// How deep one particle set lies inside another.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Penetration {
    /// Deepest particle of A inside B, in cells (0: at most touching).
    pub depth_cells: u32,
    /// Particles of A at least one cell inside B (in an interior cell of B).
    pub deep_particles: usize,
}

#[inline]
fn cell(x: Vec3A, inv_dx: f32) -> IVec3 {
    (x * inv_dx).floor().as_ivec3()
}

/// Cell depths of the cells `b` occupies (see the module docs). Non-finite positions are skipped.
pub fn cell_depths(b: &[Vec3A], dx_m: f32) -> HashMap<IVec3, u32> {
    let inv = 1.0 / dx_m;
    let mut depth: HashMap<IVec3, u32> = b
        .iter()
        .filter(|x| x.is_finite())
        .map(|x| (cell(*x, inv), 0))
        .collect();
    let mut queue: VecDeque<IVec3> = depth
        .keys()
        .copied()
        .filter(|c| FACES.iter().any(|d| !depth.contains_key(&(*c + *d))))
        .collect();
    // Sorted so that the search (and nothing else) is independent of hash order.
    queue
        .make_contiguous()
        .sort_unstable_by_key(|c| c.to_array());
    for c in &queue {
        depth.insert(*c, 1);
    }
    while let Some(c) = queue.pop_front() {
        let d = depth[&c];
        for f in FACES {
            if let Some(n) = depth.get_mut(&(c + f))
                && *n == 0
            {
                *n = d + 1;
                queue.push_back(c + f);
            }
        }
    }
    depth
}

/// How deep the particles at `a` lie inside the cells occupied by the particles at `b` (m), on a
/// grid of cell size `dx_m`.
pub fn penetration(a: &[Vec3A], b: &[Vec3A], dx_m: f32) -> Penetration {
    let depth = cell_depths(b, dx_m);
    let inv = 1.0 / dx_m;
    let mut out = Penetration::default();
    for x in a.iter().filter(|x| x.is_finite()) {
        if let Some(&d) = depth.get(&cell(*x, inv))
            && d >= 2
        {
            out.depth_cells = out.depth_cells.max(d - 1);
            out.deep_particles += 1;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Particle centres of the cells of an n³ block starting at cell `origin` (dx = 1).
    fn block(origin: IVec3, n: i32) -> Vec<Vec3A> {
        let mut out = Vec::new();
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    out.push((origin + IVec3::new(x, y, z)).as_vec3a() + Vec3A::splat(0.5));
                }
            }
        }
        out
    }

    #[test]
    fn depths_grow_inward_one_per_cell() {
        let d = cell_depths(&block(IVec3::ZERO, 5), 1.0);
        assert_eq!(d[&IVec3::new(0, 2, 2)], 1);
        assert_eq!(d[&IVec3::new(1, 2, 2)], 2);
        assert_eq!(d[&IVec3::new(2, 2, 2)], 3);
        assert_eq!(d[&IVec3::new(1, 1, 1)], 2);
    }

    #[test]
    fn touching_blocks_do_not_penetrate_and_overlapping_ones_do() {
        let b = block(IVec3::ZERO, 5);
        // Sharing the face layer x = 4 of B: touching.
        let a = block(IVec3::new(4, 0, 0), 5);
        assert_eq!(penetration(&a, &b, 1.0), Penetration::default());
        // Two layers in: one cell deep.
        let a = block(IVec3::new(3, 0, 0), 5);
        let p = penetration(&a, &b, 1.0);
        assert_eq!(p.depth_cells, 1);
        assert!(p.deep_particles > 0);
        // Three layers in reaches the centre cell (depth 3).
        let a = block(IVec3::new(2, 0, 0), 5);
        assert_eq!(penetration(&a, &b, 1.0).depth_cells, 2);
    }
}
