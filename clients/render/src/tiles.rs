//! Tile binning (the duplication step of the 3DGS reference rasterizer, Kerbl et al. 2023 sec. 6:
//! one entry per Gaussian per covered 16×16 tile). Instead of one global radix sort over
//! (tile, depth) keys, a counting sort groups the entries by tile, in Gaussian-index order; each
//! tile then sorts its own list by depth inside the parallel raster pass ([`crate::raster`]).
//! The result does not depend on the thread count: the per-chunk counts are combined in a fixed
//! order and each chunk writes its own, precomputed slots.

use crate::project::Splat2D;

/// Gaussian indices grouped by tile: the entries of tile `t` are
/// `entries[offsets[t] as usize..offsets[t + 1] as usize]`, in increasing Gaussian index.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct TileBins {
    /// `[tiles + 1]` start of each tile's entries; the last value is the total.
    pub offsets: Vec<u32>,
    /// Gaussian indices, grouped by tile.
    pub entries: Vec<u32>,
}

impl TileBins {
    /// Entries of tile `t` (row-major tile index).
    pub fn tile(&self, t: usize) -> &[u32] {
        &self.entries[self.offsets[t] as usize..self.offsets[t + 1] as usize]
    }
}

/// Gaussians per chunk in the parallel counting passes.
const CHUNK: usize = 8192;

/// Bins the visible splats into a grid `grid_w` tiles across (row-major tile index
/// `y * grid_w + x`); `num_tiles = grid_w * grid_h`.
pub fn bin(splats: &[Splat2D], grid_w: u32, num_tiles: usize) -> TileBins {
    let chunks: Vec<&[Splat2D]> = splats.chunks(CHUNK).collect();
    // Pass 1: per-chunk counts per tile.
    let count_chunk = |chunk: &&[Splat2D]| {
        let mut counts = vec![0u32; num_tiles];
        for s in chunk.iter().filter(|s| s.visible) {
            for_each_tile(s, grid_w, |t| counts[t] += 1);
        }
        counts
    };
    #[cfg(feature = "parallel")]
    let mut counts: Vec<Vec<u32>> = {
        use rayon::prelude::*;
        chunks.par_iter().map(count_chunk).collect()
    };
    #[cfg(not(feature = "parallel"))]
    let mut counts: Vec<Vec<u32>> = chunks.iter().map(count_chunk).collect();

    // Exclusive prefix over (tile, chunk): `counts[c][t]` becomes chunk c's first slot in tile t.
    let mut offsets = vec![0u32; num_tiles + 1];
    let mut running = 0u32;
    for t in 0..num_tiles {
        offsets[t] = running;
        for chunk_counts in counts.iter_mut() {
            let n = chunk_counts[t];
            chunk_counts[t] = running;
            running += n;
        }
    }
    offsets[num_tiles] = running;

    // Pass 2: every chunk scatters into its own slots.
    let mut entries = vec![0u32; running as usize];
    let fill_chunk = |(c, (chunk, cursor)): (usize, (&&[Splat2D], &mut Vec<u32>)),
                      out: &SlotWriter| {
        let base = (c * CHUNK) as u32;
        for (j, s) in chunk.iter().enumerate().filter(|(_, s)| s.visible) {
            for_each_tile(s, grid_w, |t| {
                out.write(cursor[t] as usize, base + j as u32);
                cursor[t] += 1;
            });
        }
    };
    let writer = SlotWriter::new(&mut entries);
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        chunks
            .par_iter()
            .zip(counts.par_iter_mut())
            .enumerate()
            .for_each(|item| fill_chunk(item, &writer));
    }
    #[cfg(not(feature = "parallel"))]
    chunks
        .iter()
        .zip(counts.iter_mut())
        .enumerate()
        .for_each(|item| fill_chunk(item, &writer));

    TileBins { offsets, entries }
}

/// Calls `f` with the row-major index of every tile `s` covers.
fn for_each_tile(s: &Splat2D, grid_w: u32, mut f: impl FnMut(usize)) {
    let [x0, y0, x1, y1] = s.tiles;
    for ty in y0..y1 {
        let row = (ty * grid_w) as usize;
        for tx in x0..x1 {
            f(row + tx as usize);
        }
    }
}

/// Shared write access to disjoint slots of one buffer from several threads.
struct SlotWriter {
    ptr: *mut u32,
    len: usize,
}

// SAFETY: the writer only hands out single-slot writes; the binning guarantees that every slot is
// written by exactly one chunk (the prefix sum gives each (tile, chunk) pair its own range), so no
// two threads write the same slot and nobody reads until all writes have finished.
unsafe impl Sync for SlotWriter {}

impl SlotWriter {
    fn new(buf: &mut [u32]) -> Self {
        Self {
            ptr: buf.as_mut_ptr(),
            len: buf.len(),
        }
    }

    /// Writes `value` at `index`; out-of-range indices are ignored (they cannot occur: the counts
    /// and the fill visit the same tiles).
    fn write(&self, index: usize, value: u32) {
        if index < self.len {
            // SAFETY: in bounds (checked above) and written by one thread only (see `Sync`).
            unsafe { self.ptr.add(index).write(value) };
        }
    }
}
