//! The sparse grid: only blocks of 4³ nodes that some particle's stencil reaches exist, so memory
//! and time follow the occupied cells, not the domain's bounding box. Nodes are stored block-major
//! (64 per block, local index lx + 4 ly + 16 lz).

use glam::{IVec3, Vec3A};
use rayon::prelude::*;

use super::binning::{BLOCK_NODES, Binning, pack};

/// Marks an absent neighbour.
pub const NONE: u32 = u32::MAX;

/// Offsets of the 8 corners {0, 1}³, corner index c = dx + 2 dy + 4 dz.
pub const CORNERS: [IVec3; 8] = [
    IVec3::new(0, 0, 0),
    IVec3::new(1, 0, 0),
    IVec3::new(0, 1, 0),
    IVec3::new(1, 1, 0),
    IVec3::new(0, 0, 1),
    IVec3::new(1, 0, 1),
    IVec3::new(0, 1, 1),
    IVec3::new(1, 1, 1),
];

/// Sparse block grid with per-node mass and velocity.
#[derive(Debug, Clone, Default)]
pub struct SparseGrid {
    /// Grid block coordinates, sorted.
    pub keys: Vec<IVec3>,
    /// Per grid block G: the particle block K = G - `CORNERS[c]` scattering into it, for each c.
    pub contributors: Vec<[u32; 8]>,
    /// Per particle block K: the grid block K + `CORNERS[c]`, for each c.
    pub pb_grid: Vec<[u32; 8]>,
    /// `[blocks × 64]` node mass (kg).
    pub mass_kg: Vec<f32>,
    /// `[blocks × 64]` node velocity (m/s) after the grid update.
    pub velocity_m_s: Vec<Vec3A>,
}

impl SparseGrid {
    /// Number of allocated blocks.
    pub fn block_count(&self) -> usize {
        self.keys.len()
    }

    /// Rebuilds the block set and neighbour tables for the particle blocks in `bins`.
    pub fn rebuild(&mut self, bins: &Binning) {
        let mut entries: Vec<(u64, u8, u32)> = Vec::with_capacity(bins.blocks.len() * 8);
        for (b, pb) in bins.blocks.iter().enumerate() {
            for (c, d) in CORNERS.iter().enumerate() {
                entries.push((pack(pb.key + *d), c as u8, b as u32));
            }
        }
        entries.par_sort_unstable();
        self.keys.clear();
        self.contributors.clear();
        self.pb_grid.clear();
        self.pb_grid.resize(bins.blocks.len(), [NONE; 8]);
        let mut current = u64::MAX;
        for &(g, c, b) in &entries {
            if g != current {
                current = g;
                let key = bins.blocks[b as usize].key + CORNERS[c as usize];
                self.keys.push(key);
                self.contributors.push([NONE; 8]);
            }
            let gb = self.keys.len() - 1;
            self.contributors[gb][c as usize] = b;
            self.pb_grid[b as usize][c as usize] = gb as u32;
        }
        let nodes = self.keys.len() * BLOCK_NODES;
        self.mass_kg.resize(nodes, 0.0);
        self.velocity_m_s.resize(nodes, Vec3A::ZERO);
    }
}
