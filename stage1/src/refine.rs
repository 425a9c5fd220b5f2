//! Optional refinement of uplifted features by the rendered-feature cosine loss of Feature
//! Splatting's semantic term L_s (Qiu et al. 2024, §3.2):
//!
//!   L = Σ_p (1 − cos(R(p), F(p))),   R(p) = Σᵢ wᵢ(p) fᵢ,
//!
//! over the pixels where both the rendered feature R and the target F are non-zero. Its gradient
//! is ∂L/∂fᵢ = Σ_p wᵢ(p) g(p) with g(p) = −(F̂ − cos·R̂) / |R| (R̂, F̂ unit vectors). One step of
//! full-batch gradient descent, preconditioned by the diagonal Σ_p wᵢ(p) (Jacobi), is
//!
//!   fᵢ ← fᵢ − η · (∂L/∂fᵢ) / Σ_p wᵢ(p),
//!
//! so η is in units of "one pixel's full correction" and the same η suits every Gaussian size.
//! The blending weights are the rasterizer's ([`crate::uplift`]); sums run in tile order, so the
//! result is bit-identical for any thread count.

use splatphys_render::project::TILE_PX;
use splatphys_render::raster::blend_tile;

use crate::feature_map::FeatureMap;
use crate::uplift::{ProjectedView, TileSums, render_tile_features};

/// Norms below this count as zero (pixel skipped).
const TINY: f32 = 1e-12;

/// Loss of one view.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ViewLoss {
    /// Σ_p (1 − cos) over the counted pixels.
    pub loss: f64,
    /// Pixels counted (R and F non-zero).
    pub pixels: u64,
}

/// Adds one view's ∂L/∂fᵢ to `grad` (`[N][D]`, like `features`) and returns its loss.
///
/// # Panics
/// Never for consistent input; `map.dim` must equal `dim` (checked by the caller's uplift).
pub fn add_view_gradient(
    projected: &ProjectedView,
    map: &FeatureMap,
    features: &[f32],
    dim: usize,
    tiles_per_batch: usize,
    grad: &mut [f32],
) -> ViewLoss {
    let mut total = ViewLoss::default();
    projected.map_tiles(
        tiles_per_batch,
        |t, keys| {
            let entries = projected.bins.tile(t);
            let mut sums = TileSums::default();
            if entries.is_empty() {
                return (sums, ViewLoss::default());
            }
            let rendered = render_tile_features(projected, t, features, dim, keys);
            let target = projected.tile_features(t, map);
            let rect = projected.tile_rect(t);
            let mut g = vec![0.0f32; rendered.len()];
            let mut loss = ViewLoss::default();
            for y in 0..rect.rows() {
                for x in 0..rect.cols() {
                    let p = y * TILE_PX as usize + x;
                    let r = &rendered[p * dim..(p + 1) * dim];
                    let f = &target[p * dim..(p + 1) * dim];
                    let nr = r.iter().map(|v| v * v).sum::<f32>().sqrt();
                    let nf = f.iter().map(|v| v * v).sum::<f32>().sqrt();
                    if nr <= TINY || nf <= TINY {
                        continue;
                    }
                    let cos = r.iter().zip(f).map(|(a, b)| a * b).sum::<f32>() / (nr * nf);
                    loss.loss += f64::from(1.0 - cos);
                    loss.pixels += 1;
                    for ((gv, &rv), &fv) in g[p * dim..(p + 1) * dim].iter_mut().zip(r).zip(f) {
                        *gv = -(fv / nf - cos * rv / nr) / nr;
                    }
                }
            }
            blend_tile(
                &rect,
                entries,
                &projected.splats,
                keys,
                |id, _, first, alpha, tr| {
                    sums.add(id, dim, first, (alpha * tr).to_array(), &g);
                },
            );
            (sums, loss)
        },
        |_, (sums, loss)| {
            total.loss += loss.loss;
            total.pixels += loss.pixels;
            for (slot, &id) in sums.ids.iter().enumerate() {
                let i = id as usize;
                for (a, &x) in grad[i * dim..(i + 1) * dim]
                    .iter_mut()
                    .zip(&sums.sums[slot * dim..(slot + 1) * dim])
                {
                    *a += x;
                }
            }
        },
    );
    total
}

/// One preconditioned step: fᵢ ← fᵢ − η gradᵢ / weightᵢ for Gaussians with weight >=
/// `min_weight` (the others keep their zero feature). A step that would produce a non-finite
/// value leaves that Gaussian unchanged.
pub fn apply_step(
    features: &mut [f32],
    grad: &[f32],
    weights: &[f32],
    dim: usize,
    step: f32,
    min_weight: f32,
) {
    for (i, &w) in weights.iter().enumerate() {
        if !(w >= min_weight && w > 0.0) {
            continue;
        }
        let f = &mut features[i * dim..(i + 1) * dim];
        let g = &grad[i * dim..(i + 1) * dim];
        if g.iter().all(|v| v.is_finite()) {
            for (fv, &gv) in f.iter_mut().zip(g) {
                *fv -= step * gv / w;
            }
        }
    }
}
