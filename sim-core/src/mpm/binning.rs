//! Sorting particles into blocks of 4×4×4 grid cells, the unit of the sparse grid and of parallel
//! work. A particle whose stencil base node lies in block K scatters into nodes 4K .. 4K + 5 per
//! axis (a 6³ region), i.e. into grid blocks K + {0, 1}³.

use glam::{IVec3, Vec3A};
use rayon::prelude::*;

/// Grid nodes per block edge.
pub const BLOCK: i32 = 4;
/// Nodes per grid block.
pub const BLOCK_NODES: usize = 64;
/// Nodes per axis of the region one particle block scatters into.
pub const REGION: usize = 6;
/// Nodes in that region.
pub const REGION_NODES: usize = REGION * REGION * REGION;
/// Length of the run of region indices (x fastest) from a particle's first 3³ stencil node to its
/// last: the stencil read or written as one fixed-size window of its region.
pub const STENCIL_SPAN: usize = 2 * REGION * REGION + 2 * REGION + 3;
/// Block coordinates must satisfy |k| < 2^20 (a grid of 4M cells per axis).
const KEY_LIMIT: i32 = 1 << 20;

/// Particles that share a stencil base block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ParticleBlock {
    /// Block coordinates (base node / 4).
    pub key: IVec3,
    /// Range into [`Binning::order`].
    pub start: u32,
    /// End of the range (exclusive).
    pub end: u32,
}

/// Particle order by block, rebuilt every substep.
#[derive(Debug, Clone, Default)]
pub struct Binning {
    /// Particle indices sorted by (block, index).
    pub order: Vec<u32>,
    /// Occupied blocks in lexicographic key order.
    pub blocks: Vec<ParticleBlock>,
    /// `[N]` index into `blocks` of each particle.
    pub block_of: Vec<u32>,
    /// Reused (key, particle) buffer.
    scratch: Vec<(u64, u32)>,
    /// Reused buffer of the particles that changed blocks.
    movers: Vec<(u64, u32)>,
}

/// Packs block coordinates into a u64 that sorts lexicographically by (x, y, z).
#[inline]
pub(crate) fn pack(k: IVec3) -> u64 {
    let b = |v: i32| (v + KEY_LIMIT) as u64;
    (b(k.x) << 42) | (b(k.y) << 21) | b(k.z)
}

/// The stencil base block of a position, `None` if not finite or outside the addressable grid.
#[inline]
pub(crate) fn block_key(x_m: Vec3A, inv_dx: f32) -> Option<IVec3> {
    let xp = x_m * inv_dx - Vec3A::splat(0.5);
    let lim = (KEY_LIMIT as f32 - 2.0) * BLOCK as f32;
    if !(xp.is_finite() && xp.abs().max_element() < lim) {
        return None;
    }
    // Floor division by BLOCK = 4 is an arithmetic shift, also for negative indices.
    Some(xp.floor().as_ivec3() >> 2)
}

impl Binning {
    /// Re-sorts `x` (m) into blocks for cell size 1 / `inv_dx`.
    ///
    /// # Errors
    /// The smallest index of a particle whose position is not finite or out of range.
    pub fn rebuild(&mut self, x: &[Vec3A], inv_dx: f32) -> Result<(), usize> {
        // Keys in the previous substep's order: particles rarely change blocks between substeps,
        // so the list is usually already sorted, or sorted but for the few particles that moved
        // (see `sort_from_previous`). (block, index) pairs are unique, so the sorted result never
        // depends on the input order, the method or the thread count.
        let n = x.len();
        let reuse = self.order.len() == n;
        // An invalid position gets the key u64::MAX (packed keys are < 2^63).
        let key_of =
            |i: u32| block_key(x[i as usize], inv_dx).map_or((u64::MAX, i), |k| (pack(k), i));
        let mut keyed = std::mem::take(&mut self.scratch);
        keyed.clear();
        if reuse {
            let order = &self.order;
            keyed.par_extend(order.par_iter().enumerate().map(|(k, &i)| {
                // Positions are read in the previous block order, at scattered addresses.
                if let Some(&ahead) = order.get(k + 16) {
                    super::prefetch::prefetch(&x[ahead as usize]);
                }
                key_of(i)
            }));
        } else {
            keyed.par_extend((0..n as u32).into_par_iter().map(key_of));
        }
        if let Some(bad) = keyed
            .iter()
            .filter(|k| k.0 == u64::MAX)
            .map(|k| k.1 as usize)
            .min()
        {
            self.scratch = keyed;
            return Err(bad);
        }
        if !keyed.windows(2).all(|w| w[0] < w[1]) {
            let covered = self.blocks.first().is_some_and(|b| b.start == 0)
                && self.blocks.last().is_some_and(|b| b.end as usize == n);
            if reuse && covered {
                self.sort_from_previous(&mut keyed);
            } else {
                keyed.par_sort_unstable();
            }
        }
        self.order.clear();
        self.blocks.clear();
        self.block_of.resize(x.len(), 0);
        let mut current = u64::MAX;
        for (i, &(k, p)) in keyed.iter().enumerate() {
            if k != current {
                if let Some(last) = self.blocks.last_mut() {
                    last.end = i as u32;
                }
                current = k;
                let key = block_key(x[p as usize], inv_dx).unwrap_or_default();
                self.blocks.push(ParticleBlock {
                    key,
                    start: i as u32,
                    end: i as u32,
                });
            }
            self.order.push(p);
            self.block_of[p as usize] = (self.blocks.len() - 1) as u32;
        }
        if let Some(last) = self.blocks.last_mut() {
            last.end = keyed.len() as u32;
        }
        self.scratch = keyed;
        Ok(())
    }

    /// Sorts `keyed`, (key, particle) pairs listed in the previous [`Self::order`] that
    /// [`Self::blocks`] still describes. The pairs whose key is their previous block's are still
    /// in order; the others (the particles that changed blocks) are sorted apart and merged in,
    /// in O(N) plus a sort of the movers.
    fn sort_from_previous(&mut self, keyed: &mut [(u64, u32)]) {
        let mut movers = std::mem::take(&mut self.movers);
        movers.clear();
        let mut stayed = 0;
        for pb in &self.blocks {
            let previous = pack(pb.key);
            for i in pb.start as usize..pb.end as usize {
                let entry = keyed[i];
                if entry.0 == previous {
                    keyed[stayed] = entry;
                    stayed += 1;
                } else {
                    movers.push(entry);
                }
            }
        }
        movers.sort_unstable();
        // Merge from the back, in place: keyed[..stayed] and movers into keyed.
        let (mut i, mut j) = (stayed, movers.len());
        while j > 0 {
            let w = i + j - 1;
            if i > 0 && keyed[i - 1] > movers[j - 1] {
                keyed[w] = keyed[i - 1];
                i -= 1;
            } else {
                keyed[w] = movers[j - 1];
                j -= 1;
            }
        }
        self.movers = movers;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Positions on a jittered lattice spanning several blocks (cell 0.1 m).
    fn cloud(n: u32, shift: f32) -> Vec<Vec3A> {
        (0..n)
            .map(|i| {
                let h = i.wrapping_mul(2_654_435_761);
                let j = Vec3A::new(
                    (h % 97) as f32,
                    (h / 97 % 89) as f32,
                    (h / 8633 % 83) as f32,
                );
                j * 0.031 + Vec3A::splat(shift * (i % 3) as f32)
            })
            .collect()
    }

    #[test]
    fn rebuild_after_moves_matches_a_fresh_sort() {
        let inv_dx = 10.0;
        let mut bins = Binning::default();
        bins.rebuild(&cloud(5000, 0.0), inv_dx).expect("valid");
        // A third of the particles move by up to a block; the merge path must give the fresh
        // sort's order, blocks and block indices.
        let moved = cloud(5000, 0.37);
        bins.rebuild(&moved, inv_dx).expect("valid");
        let mut fresh = Binning::default();
        fresh.rebuild(&moved, inv_dx).expect("valid");
        assert_eq!(bins.order, fresh.order);
        assert_eq!(bins.blocks, fresh.blocks);
        assert_eq!(bins.block_of, fresh.block_of);
    }
}
