//! Learning-free feature uplift: every Gaussian's feature is the blending-weighted mean of the
//! 2-D features it contributes to,
//!
//!   fᵢ = Σ_p wᵢ(p) F(p) / Σ_p wᵢ(p),   wᵢ(p) = αᵢ(p) Tᵢ(p),
//!
//! over the pixels p of every training view, with wᵢ(p) the alpha-blending weight of 3DGS eq. 3
//! from the very rasterizer that renders frames ([`splatphys_render::raster::blend_tile`]). This
//! is the minimiser of Σ_p Σ_i wᵢ(p) |fᵢ − F(p)|², the weighted least-squares fit that a rendered
//! feature loss reaches at its optimum for the linear model (the starting point of Feature
//! Splatting's distillation, Qiu et al. 2024 §3.2; see [`crate::refine`] for the cosine-loss
//! refinement).
//!
//! Memory is bounded: per view, tiles run in parallel batches, each tile returns the sums of the
//! Gaussians it blends (no per-pixel lists), and the batches are folded into the per-Gaussian
//! sums in tile order, so the result is bit-identical for any thread count.

use rayon::prelude::*;
use splatphys_render::SplatView;
use splatphys_render::camera::ViewParams;
use splatphys_render::project::{Splat2D, TILE_PX, project_one};
use splatphys_render::raster::{TILE_PIXELS, TileRect, blend_tile};
use splatphys_render::tiles::{TileBins, bin};

use crate::feature_map::FeatureMap;

/// Why an uplift step failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum UpliftError {
    /// A view's feature map has another channel count than the others.
    #[error("view {view}: feature map has {found} channels, the first view had {expected}")]
    Dimension {
        /// The view's name.
        view: String,
        /// Channels of the first map.
        expected: usize,
        /// Channels of this map.
        found: usize,
    },
    /// More Gaussians than 32-bit tile lists address.
    #[error("{n} Gaussians exceed the rasterizer's limit of {max}")]
    TooManyGaussians {
        /// Gaussians given.
        n: usize,
        /// The limit.
        max: usize,
    },
    /// The Gaussian arrays are inconsistent.
    #[error(transparent)]
    Input(#[from] splatphys_render::InputError),
}

/// Settings of the uplift.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpliftSettings {
    /// Gaussians with view depth `z <= near_m` are culled, m. Default 0.01 (the renderer's 0.2 is
    /// for viewing; training cameras may sit closer to small objects).
    pub near_m: f32,
    /// A Gaussian whose summed weight over all views is below this is reported as unseen and
    /// gets a zero feature. Default 1e-3 (a thousandth of one fully covered pixel).
    pub min_weight: f32,
    /// Tiles rendered in parallel before their sums are folded in (bounds memory). Default 256.
    pub tiles_per_batch: usize,
}

impl Default for UpliftSettings {
    fn default() -> Self {
        Self {
            near_m: 0.01,
            min_weight: 1e-3,
            tiles_per_batch: 256,
        }
    }
}

/// One view projected and binned, ready to visit tile by tile.
pub struct ProjectedView {
    /// The camera.
    pub view: ViewParams,
    /// Screen-space splats, one per Gaussian.
    pub splats: Vec<Splat2D>,
    /// Gaussian indices per tile.
    pub bins: TileBins,
    /// Tiles across.
    pub grid_w: u32,
}

impl ProjectedView {
    /// Projects every Gaussian for `view` (colours are not needed: SH degree 0).
    ///
    /// # Errors
    /// [`UpliftError`] for inconsistent arrays or too many Gaussians.
    pub fn new(
        splats: &SplatView<'_>,
        view: &ViewParams,
        near_m: f32,
    ) -> Result<Self, UpliftError> {
        splats.validate()?;
        if splats.len() >= u32::MAX as usize {
            return Err(UpliftError::TooManyGaussians {
                n: splats.len(),
                max: u32::MAX as usize - 1,
            });
        }
        let projected: Vec<Splat2D> = (0..splats.len())
            .into_par_iter()
            .with_min_len(1024)
            .map(|i| project_one(splats, i, view, near_m, 0))
            .collect();
        let [w, h] = view.size_px;
        let grid_w = w.div_ceil(TILE_PX);
        let num_tiles = (grid_w * h.div_ceil(TILE_PX)) as usize;
        let bins = bin(&projected, grid_w, num_tiles);
        Ok(Self {
            view: *view,
            splats: projected,
            bins,
            grid_w,
        })
    }

    /// Number of tiles.
    pub fn num_tiles(&self) -> usize {
        self.bins.offsets.len() - 1
    }

    /// The pixels of tile `t`.
    pub fn tile_rect(&self, t: usize) -> TileRect {
        let [w, h] = self.view.size_px;
        TileRect::new(t as u32 % self.grid_w, t as u32 / self.grid_w, w, h)
    }

    /// Runs `per_tile` on every tile, `batch` tiles at a time in parallel, and hands the results
    /// to `fold` in tile order (so sums do not depend on the thread count).
    pub fn map_tiles<T: Send>(
        &self,
        batch: usize,
        per_tile: impl Fn(usize, &mut Vec<u64>) -> T + Sync,
        mut fold: impl FnMut(usize, T),
    ) {
        let n = self.num_tiles();
        let batch = batch.max(1);
        for start in (0..n).step_by(batch) {
            let end = (start + batch).min(n);
            let out: Vec<T> = (start..end)
                .into_par_iter()
                .map_init(Vec::new, |keys, t| per_tile(t, keys))
                .collect();
            for (t, v) in (start..end).zip(out) {
                fold(t, v);
            }
        }
    }

    /// The feature of every pixel of tile `t` (`[256][D]`, row-major in the tile; pixels outside
    /// the image are zero) sampled from `map`.
    pub fn tile_features(&self, t: usize, map: &FeatureMap) -> Vec<f32> {
        let d = map.dim;
        let r = self.tile_rect(t);
        let mut out = vec![0.0; TILE_PIXELS * d];
        for y in 0..r.rows() {
            for x in 0..r.cols() {
                let p = y * TILE_PX as usize + x;
                map.sample(
                    r.x0 + x as u32,
                    r.y0 + y as u32,
                    self.view.size_px,
                    &mut out[p * d..(p + 1) * d],
                );
            }
        }
        out
    }
}

/// Per-Gaussian sums of one tile: the Gaussians it blends, in blending order.
#[derive(Debug, Default)]
pub struct TileSums {
    /// Gaussian indices.
    pub ids: Vec<u32>,
    /// Σ_p wᵢ(p) per entry.
    pub weights: Vec<f32>,
    /// Σ_p wᵢ(p) v(p) per entry, `[ids][D]`.
    pub sums: Vec<f32>,
}

impl TileSums {
    /// Adds `w · v` (per lane) for Gaussian `id`; `values` is the tile's `[256][D]` per-pixel
    /// array and `first` the first pixel of the 4 lanes.
    pub fn add(&mut self, id: u32, dim: usize, first: usize, w: [f32; 4], values: &[f32]) {
        if self.ids.last() != Some(&id) {
            self.ids.push(id);
            self.weights.push(0.0);
            self.sums.resize(self.sums.len() + dim, 0.0);
        }
        let slot = self.ids.len() - 1;
        let acc = &mut self.sums[slot * dim..(slot + 1) * dim];
        for (lane, &wl) in w.iter().enumerate() {
            if wl > 0.0 {
                self.weights[slot] += wl;
                let v = &values[(first + lane) * dim..(first + lane + 1) * dim];
                for (a, &x) in acc.iter_mut().zip(v) {
                    *a += wl * x;
                }
            }
        }
    }
}

/// Running sums Σ_p wᵢ(p) F(p) and Σ_p wᵢ(p) over the views added so far.
#[derive(Debug, Clone, PartialEq)]
pub struct Accumulator {
    /// Feature channels D.
    pub dim: usize,
    /// `[N][D]` weighted feature sums.
    pub sums: Vec<f32>,
    /// `[N]` weight sums.
    pub weights: Vec<f32>,
}

/// What one view contributed.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ViewStats {
    /// (Gaussian, pixel) blends.
    pub blends: u64,
    /// Gaussians with a non-zero weight in this view.
    pub gaussians: u64,
}

/// The uplifted features.
#[derive(Debug, Clone, PartialEq)]
pub struct Uplifted {
    /// Feature channels D.
    pub dim: usize,
    /// `[N][D]` features (zero for unseen Gaussians).
    pub features: Vec<f32>,
    /// `[N]` summed blending weights over all views (pixels' worth of contribution).
    pub weights: Vec<f32>,
    /// Gaussians whose weight stayed below [`UpliftSettings::min_weight`], ascending.
    pub unseen: Vec<u32>,
}

impl Accumulator {
    /// Empty sums for `n` Gaussians and `dim` channels.
    pub fn new(n: usize, dim: usize) -> Self {
        Self {
            dim,
            sums: vec![0.0; n * dim],
            weights: vec![0.0; n],
        }
    }

    /// Adds one view: renders its blending weights and accumulates `map` (its D must match).
    ///
    /// # Errors
    /// [`UpliftError::Dimension`] when `map.dim` differs from the accumulator's.
    pub fn add_view(
        &mut self,
        name: &str,
        projected: &ProjectedView,
        map: &FeatureMap,
        settings: &UpliftSettings,
    ) -> Result<ViewStats, UpliftError> {
        if map.dim != self.dim {
            return Err(UpliftError::Dimension {
                view: name.to_string(),
                expected: self.dim,
                found: map.dim,
            });
        }
        let d = self.dim;
        let mut stats = ViewStats::default();
        projected.map_tiles(
            settings.tiles_per_batch,
            |t, keys| {
                let entries = projected.bins.tile(t);
                let mut sums = TileSums::default();
                if entries.is_empty() {
                    return (sums, 0);
                }
                let features = projected.tile_features(t, map);
                let mut blends = 0u64;
                blend_tile(
                    &projected.tile_rect(t),
                    entries,
                    &projected.splats,
                    keys,
                    |id, _, first, alpha, tr| {
                        let w = (alpha * tr).to_array();
                        blends += w.iter().filter(|&&x| x > 0.0).count() as u64;
                        sums.add(id, d, first, w, &features);
                    },
                );
                (sums, blends)
            },
            |_, (sums, blends)| {
                stats.blends += blends;
                stats.gaussians += sums.ids.len() as u64;
                for (slot, &id) in sums.ids.iter().enumerate() {
                    let i = id as usize;
                    self.weights[i] += sums.weights[slot];
                    let acc = &mut self.sums[i * d..(i + 1) * d];
                    for (a, &x) in acc.iter_mut().zip(&sums.sums[slot * d..(slot + 1) * d]) {
                        *a += x;
                    }
                }
            },
        );
        Ok(stats)
    }

    /// The weighted means; Gaussians with total weight below `min_weight` are listed as unseen
    /// and get zeros (never a division by a vanishing weight).
    pub fn finish(&self, min_weight: f32) -> Uplifted {
        let d = self.dim;
        let mut features = vec![0.0; self.sums.len()];
        let mut unseen = Vec::new();
        for (i, &w) in self.weights.iter().enumerate() {
            if w.is_finite() && w >= min_weight && w > 0.0 {
                for (f, &s) in features[i * d..(i + 1) * d]
                    .iter_mut()
                    .zip(&self.sums[i * d..(i + 1) * d])
                {
                    *f = s / w;
                }
            } else {
                unseen.push(i as u32);
            }
        }
        Uplifted {
            dim: d,
            features,
            weights: self.weights.clone(),
            unseen,
        }
    }
}

/// Renders per-Gaussian values `[N][D]` as a feature image `[H][W][D]` through the same blending
/// weights, R(p) = Σᵢ wᵢ(p) vᵢ (no background: uncovered pixels are zero). This is the
/// rendered-feature image of Feature Splatting and what [`crate::refine`] compares with F(p).
pub fn render_features(
    projected: &ProjectedView,
    values: &[f32],
    dim: usize,
    tiles_per_batch: usize,
) -> FeatureMap {
    let [w, h] = projected.view.size_px;
    let (w, h) = (w as usize, h as usize);
    let mut data = vec![0.0f32; w * h * dim];
    projected.map_tiles(
        tiles_per_batch,
        |t, keys| render_tile_features(projected, t, values, dim, keys),
        |t, tile| {
            let r = projected.tile_rect(t);
            for y in 0..r.rows() {
                let src = y * TILE_PX as usize * dim;
                let dst = ((r.y0 as usize + y) * w + r.x0 as usize) * dim;
                data[dst..dst + r.cols() * dim].copy_from_slice(&tile[src..src + r.cols() * dim]);
            }
        },
    );
    FeatureMap {
        height: h,
        width: w,
        dim,
        data,
    }
}

/// R(p) = Σᵢ wᵢ(p) vᵢ for the 256 pixels of tile `t`, `[256][D]`.
pub fn render_tile_features(
    projected: &ProjectedView,
    t: usize,
    values: &[f32],
    dim: usize,
    keys: &mut Vec<u64>,
) -> Vec<f32> {
    let mut out = vec![0.0f32; TILE_PIXELS * dim];
    let entries = projected.bins.tile(t);
    if entries.is_empty() {
        return out;
    }
    blend_tile(
        &projected.tile_rect(t),
        entries,
        &projected.splats,
        keys,
        |id, _, first, alpha, tr| {
            let v = &values[id as usize * dim..(id as usize + 1) * dim];
            for (lane, wl) in (alpha * tr).to_array().into_iter().enumerate() {
                if wl > 0.0 {
                    let p = first + lane;
                    for (o, &x) in out[p * dim..(p + 1) * dim].iter_mut().zip(v) {
                        *o += wl * x;
                    }
                }
            }
        },
    );
    out
}
