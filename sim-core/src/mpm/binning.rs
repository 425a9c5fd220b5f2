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
        // so the list is usually already sorted and the sort is skipped. (block, index) pairs are
        // unique, so the sorted result never depends on the input order or the thread count.
        let n = x.len();
        let reuse = self.order.len() == n;
        // An invalid position gets the key u64::MAX (packed keys are < 2^63).
        let key_of =
            |i: u32| block_key(x[i as usize], inv_dx).map_or((u64::MAX, i), |k| (pack(k), i));
        let mut keyed = std::mem::take(&mut self.scratch);
        keyed.clear();
        if reuse {
            keyed.par_extend(self.order.par_iter().map(|&i| key_of(i)));
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
            keyed.par_sort_unstable();
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
}
