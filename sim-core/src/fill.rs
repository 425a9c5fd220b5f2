//! Interior filling (PhysGaussian, Xie et al. 2024, §4.3 "Internal filling"): captured objects
//! carry Gaussians on their surface only; MPM needs volume. An opacity-density grid marks
//! surface cells, and an empty cell is interior when axis-aligned rays from it hit a surface cell
//! in all six directions (PhysGaussian's ray test). Interior cell centres become invisible
//! particles.
//!
//! Bounded work: the density splat puts each Gaussian's opacity into the cell of its centre
//! (no covariance evaluation, so a near-singular covariance cannot stall it); the grid is
//! coarsened (spacing doubled) until it has at most [`FillParams::max_grid_cells`] cells; the six
//! ray tests are prefix sweeps, O(cells); at most [`FillParams::max_particles`] points are
//! returned (an even stride over the interior cells when more qualify).

use crate::gaussians::GaussianCloud;

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
}

impl Default for FillParams {
    fn default() -> Self {
        Self {
            spacing_m: 0.01,
            density_threshold: 0.5,
            max_particles: 200_000,
            max_grid_cells: 8_000_000,
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
    let dims = |h: f32| -> [usize; 3] {
        [0, 1, 2].map(|k| (((hi[k] - lo[k]) / h).floor() as usize).saturating_add(1))
    };
    let mut d = dims(h);
    while d.iter().map(|&v| v as f64).product::<f64>() > params.max_grid_cells.max(1) as f64 {
        h *= 2.0;
        d = dims(h);
    }
    let [nx, ny, nz] = d;
    let idx = |i: usize, j: usize, k: usize| (k * ny + j) * nx + i;
    let mut density = vec![0f32; nx * ny * nz];
    for (g, p) in cloud.positions.iter().enumerate() {
        let c = [0, 1, 2].map(|k| (((p[k] - lo[k]) / h) as usize).min(d[k] - 1));
        density[idx(c[0], c[1], c[2])] += cloud.opacity(g);
    }
    let surface: Vec<bool> = density
        .iter()
        .map(|&v| v >= params.density_threshold)
        .collect();
    // hits[c] counts the directions in which a surface cell lies beyond c.
    let mut hits = vec![0u8; surface.len()];
    let mut sweep =
        |len: usize, others: [usize; 2], cell: &dyn Fn(usize, usize, usize) -> usize| {
            for a in 0..others[0] {
                for b in 0..others[1] {
                    let mut seen = false;
                    for t in 0..len {
                        let c = cell(t, a, b);
                        if seen && !surface[c] {
                            hits[c] += 1;
                        }
                        seen |= surface[c];
                    }
                    seen = false;
                    for t in (0..len).rev() {
                        let c = cell(t, a, b);
                        if seen && !surface[c] {
                            hits[c] += 1;
                        }
                        seen |= surface[c];
                    }
                }
            }
        };
    sweep(nx, [ny, nz], &|t, a, b| idx(t, a, b));
    sweep(ny, [nx, nz], &|t, a, b| idx(a, t, b));
    sweep(nz, [nx, ny], &|t, a, b| idx(a, b, t));
    let interior: Vec<usize> = (0..hits.len()).filter(|&c| hits[c] == 6).collect();
    let stride = interior.len().div_ceil(params.max_particles.max(1)).max(1);
    interior
        .iter()
        .step_by(stride)
        .take(params.max_particles)
        .map(|&c| {
            let i = c % nx;
            let j = (c / nx) % ny;
            let k = c / (nx * ny);
            [
                lo[0] + (i as f32 + 0.5) * h,
                lo[1] + (j as f32 + 0.5) * h,
                lo[2] + (k as f32 + 0.5) * h,
            ]
        })
        .collect()
}
