//! Interior filling (PhysGaussian, Xie et al. 2024, §4.3 "Internal filling"): captured objects
//! carry Gaussians on their surface only; MPM needs volume. An opacity-density grid marks
//! surface cells, and an empty cell is interior when axis-aligned rays from it hit a surface cell
//! in all six directions (PhysGaussian's ray test). Interior cell centres become invisible
//! particles.
//!
//! **Sealing.** A capture samples its surface at its own spacing (a `voxel_m` of 4 mm keeps one
//! Gaussian per 4 mm voxel). A fill finer than that sees gaps between surface cells, the rays
//! leave through them, and the solid loses volume silently: the captured donut filled at 2.5 mm
//! kept 1.68 of its 1.99 L. So the test runs on the surface dilated by k cells (a cube of side
//! 2k + 1), which closes gaps up to 2k cells wide, and the outside it finds is dilated by k cells
//! again, back to the surface (a morphological closing of the shell, as in
//! [`crate::world::carry::volume`]). k = 0 is the plain ray test. k grows from 0 while each step
//! finds more than 5 % more interior cells, up to [`FillParams::max_seal_cells`] and to 1.5
//! median spacings of the Gaussians (the gaps of a surface sampled at spacing s are up to about
//! 3 s wide; wider openings belong to the object): a closed surface keeps k = 0 and the plain
//! test's cells, a leaky one stops at the first k that seals it. The captured donut
//! (`voxel_m = 0.004`, median spacing 4.2 mm) has gaps at 5 mm as well: 7,063 interior cells at
//! k = 0, 10,328 at k = 1 (the added cells spread through the whole tube); at 2.5 mm, 10,401,
//! 95,260, 112,504 (k = 2); at 10 mm the plain test (k = 0).
//!
//! Bounded work: the density splat puts each Gaussian's opacity into the cell of its centre
//! (no covariance evaluation, so a near-singular covariance cannot stall it); the grid is
//! coarsened (spacing doubled) until it has at most [`FillParams::max_grid_cells`] cells; the six
//! ray tests and the dilations are sweeps along grid lines, O(cells) each, for each k; the
//! seal's cap needs the Gaussians' median spacing (a k-d tree, O(N log N), skipped when
//! `max_seal_cells` is 0); at most [`FillParams::max_particles`] points are returned (an even
//! stride over the interior cells when more qualify).

use glam::Vec3A;

use crate::gaussians::GaussianCloud;
use crate::world::carry::volume::local_spacing;

/// The most [`FillParams::max_seal_cells`] can ask for (larger values are clamped to it).
pub const MAX_SEAL_CELLS: usize = 16;
/// The largest seal, in median spacings of the surface's Gaussians.
const SEAL_SPACINGS: f64 = 1.5;
/// Relative gain in interior cells for which the next larger seal is taken.
const SEAL_GAIN: f64 = 0.05;

/// Parameters of [`fill_interior`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FillParams {
    /// Grid spacing, m (fill particles sit at cell centres). Default 0.01.
    pub spacing_m: f32,
    /// Summed opacity in a cell for it to count as surface. Default 0.5.
    pub density_threshold: f32,
    /// Hard limit on returned particles. Default 200 000.
    pub max_particles: usize,
    /// Hard limit on grid cells (spacing is doubled until it fits). Default 8 000 000.
    pub max_grid_cells: usize,
    /// Largest seal k, in cells: gaps in the surface up to 2k cells wide are closed (module
    /// docs, "Sealing"); 0 is PhysGaussian's plain ray test. Default 4, at most
    /// [`MAX_SEAL_CELLS`].
    pub max_seal_cells: usize,
}

impl Default for FillParams {
    fn default() -> Self {
        Self {
            spacing_m: 0.01,
            density_threshold: 0.5,
            max_particles: 200_000,
            max_grid_cells: 8_000_000,
            max_seal_cells: 4,
        }
    }
}

/// Interior points `[M][3]` (m) of the volume the Gaussians of `cloud` enclose; empty for an
/// empty cloud or a bad spacing. M <= `params.max_particles`.
pub fn fill_interior(cloud: &GaussianCloud, params: &FillParams) -> Vec<[f32; 3]> {
    if cloud.is_empty() || !(params.spacing_m.is_finite() && params.spacing_m > 0.0) {
        return Vec::new();
    }
    let [lo, hi] = crate::formats::inspect::bounds(cloud);
    let mut h = params.spacing_m;
    // A margin of empty cells all round, more than the largest seal, so that the outside
    // surrounds a sealed surface. Cells are counted from `lo` and shifted by the margin, so a
    // Gaussian at the box's edge lands in the first cell inside the margin, whatever the
    // rounding.
    let wanted = params.max_seal_cells.min(MAX_SEAL_CELLS);
    let margin = wanted + 1;
    let inner = |h: f32| -> [usize; 3] {
        [0, 1, 2].map(|k| (((hi[k] - lo[k]) / h).floor() as usize).saturating_add(1))
    };
    let dims = |h: f32| inner(h).map(|n| n.saturating_add(2 * margin));
    let mut d = dims(h);
    while d.iter().map(|&v| v as f64).product::<f64>() > params.max_grid_cells.max(1) as f64
        && d.iter().any(|&v| v > 1 + 2 * margin)
    {
        h *= 2.0;
        d = dims(h);
    }
    // The cap in cells of the spacing the grid ended up with.
    let max_seal = if wanted > 0 {
        wanted.min(seal_reach_cells(cloud, h))
    } else {
        0
    };
    let n = inner(h);
    let grid = Lines { dims: d };
    let mut density = vec![0f32; grid.len()];
    for (g, p) in cloud.positions.iter().enumerate() {
        let c = [0, 1, 2].map(|k| (((p[k] - lo[k]) / h) as usize).min(n[k] - 1) + margin);
        density[grid.index(c)] += cloud.opacity(g);
    }
    let surface: Vec<bool> = density
        .iter()
        .map(|&v| v >= params.density_threshold)
        .collect();
    let mut interior = grid.interior(&surface, 0);
    let mut count = interior.iter().filter(|&&i| i).count();
    for seal in 1..=max_seal {
        let candidate = grid.interior(&surface, seal);
        let n = candidate.iter().filter(|&&i| i).count();
        if n as f64 <= (1.0 + SEAL_GAIN) * count as f64 {
            break;
        }
        (interior, count) = (candidate, n);
    }
    let stride = count.div_ceil(params.max_particles.max(1)).max(1);
    let [nx, ny, _] = d;
    (0..interior.len())
        .filter(|&c| interior[c])
        .step_by(stride)
        .take(params.max_particles)
        .map(|c| {
            let i = c % nx;
            let j = (c / nx) % ny;
            let k = c / (nx * ny);
            let centre = |lo: f32, i: usize| lo + (i as f32 - margin as f32 + 0.5) * h;
            [centre(lo[0], i), centre(lo[1], j), centre(lo[2], k)]
        })
        .collect()
}

/// The largest seal worth trying at fill spacing `h_m`, in cells: gaps in a surface sampled at
/// median spacing s (of its Gaussians, [`local_spacing`]) are up to about 3 s wide (what
/// [`crate::world::carry::volume`] seals to measure the solid), so k h ≤ 1.5 s. A larger seal
/// would close openings of the object itself, such as a donut's hole; 0 when there is no spacing
/// to go by.
fn seal_reach_cells(cloud: &GaussianCloud, h_m: f32) -> usize {
    let x: Vec<Vec3A> = cloud.positions.iter().map(|&p| Vec3A::from(p)).collect();
    let Some(mut spacing) = local_spacing(&x) else {
        return 0;
    };
    let mid = spacing.len() / 2;
    let median = *spacing.select_nth_unstable_by(mid, f64::total_cmp).1;
    (SEAL_SPACINGS * median / h_m as f64).floor() as usize
}

/// A dense grid of `dims` cells (x fastest) and the sweeps along its lines.
struct Lines {
    dims: [usize; 3],
}

impl Lines {
    fn len(&self) -> usize {
        self.dims.iter().product()
    }

    fn index(&self, [i, j, k]: [usize; 3]) -> usize {
        (k * self.dims[1] + j) * self.dims[0] + i
    }

    /// Calls `f` with the cell indices of every grid line along `axis`, in order.
    fn each_line(&self, axis: usize, mut f: impl FnMut(&mut dyn Iterator<Item = usize>)) {
        let [a, b] = match axis {
            0 => [1, 2],
            1 => [0, 2],
            _ => [0, 1],
        };
        for u in 0..self.dims[a] {
            for v in 0..self.dims[b] {
                let mut cell = [0; 3];
                cell[a] = u;
                cell[b] = v;
                f(&mut (0..self.dims[axis]).map(|t| {
                    cell[axis] = t;
                    self.index(cell)
                }));
            }
        }
    }

    /// Cells that are not `surface` and not outside it when its gaps up to 2 `seal` cells wide
    /// are closed (module docs, "Sealing").
    fn interior(&self, surface: &[bool], seal: usize) -> Vec<bool> {
        let sealed = self.dilate(surface, seal);
        let hits = self.ray_hits(&sealed);
        let outside: Vec<bool> = (0..sealed.len())
            .map(|c| !sealed[c] && hits[c] < 6)
            .collect();
        let outside = self.dilate(&outside, seal);
        (0..surface.len())
            .map(|c| !surface[c] && !outside[c])
            .collect()
    }

    /// For each cell, the number of the six axis directions in which a `wall` cell lies beyond
    /// it.
    fn ray_hits(&self, wall: &[bool]) -> Vec<u8> {
        let mut hits = vec![0u8; wall.len()];
        let mut line = Vec::new();
        for axis in 0..3 {
            self.each_line(axis, |cells| {
                line.clear();
                line.extend(cells);
                for order in [false, true] {
                    let mut seen = false;
                    for n in 0..line.len() {
                        let c = line[if order { line.len() - 1 - n } else { n }];
                        if seen && !wall[c] {
                            hits[c] += 1;
                        }
                        seen |= wall[c];
                    }
                }
            });
        }
        hits
    }

    /// `mask` dilated by a cube of side 2 `r` + 1 cells (Chebyshev distance ≤ `r`), one axis
    /// at a time.
    fn dilate(&self, mask: &[bool], r: usize) -> Vec<bool> {
        let mut out = mask.to_vec();
        if r == 0 {
            return out;
        }
        let mut line = Vec::new();
        let mut reach = Vec::new();
        for axis in 0..3 {
            let src = out.clone();
            self.each_line(axis, |cells| {
                line.clear();
                line.extend(cells);
                // reach[n]: distance from n to the nearest set cell of the line (capped).
                reach.clear();
                reach.resize(line.len(), usize::MAX);
                for order in [false, true] {
                    let mut last = usize::MAX;
                    for n in 0..line.len() {
                        let n = if order { line.len() - 1 - n } else { n };
                        last = if src[line[n]] {
                            0
                        } else {
                            last.saturating_add(1)
                        };
                        reach[n] = reach[n].min(last);
                    }
                }
                for (n, &c) in line.iter().enumerate() {
                    out[c] = reach[n] <= r;
                }
            });
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_dilation_reaches_r_cells_along_each_axis_and_diagonal() {
        let grid = Lines { dims: [7, 7, 7] };
        let mut mask = vec![false; grid.len()];
        mask[grid.index([3, 3, 3])] = true;
        let out = grid.dilate(&mask, 1);
        assert_eq!(out.iter().filter(|&&m| m).count(), 27);
        assert!(out[grid.index([2, 4, 2])] && out[grid.index([4, 4, 4])]);
        assert!(!out[grid.index([5, 3, 3])]);
        assert_eq!(grid.dilate(&mask, 0), mask);
    }

    #[test]
    fn a_seal_closes_a_hole_in_a_box_wall_and_keeps_the_box_inside() {
        // A hollow box of walls one cell thick, cells 2..=12 of 15, with a hole of 2 x 2 cells
        // in its top wall: the plain ray test loses the cells under the hole.
        let grid = Lines { dims: [15, 15, 15] };
        let mut wall = vec![false; grid.len()];
        for k in 2..=12 {
            for j in 2..=12 {
                for i in 2..=12 {
                    let edge = [i, j, k].iter().any(|&v| v == 2 || v == 12);
                    let hole = k == 12 && (6..=7).contains(&i) && (6..=7).contains(&j);
                    wall[grid.index([i, j, k])] = edge && !hole;
                }
            }
        }
        let inside = |seal| grid.interior(&wall, seal).iter().filter(|&&c| c).count();
        assert_eq!(inside(0), 9 * 9 * 9 - 2 * 2 * 9);
        // Sealed: the whole inside, and the hole's own 2 x 2 cells of wall with it.
        assert_eq!(inside(1), 9 * 9 * 9 + 2 * 2);
    }
}
