//! One frame of 3DGS EWA splatting (Kerbl et al. 2023, sec. 6): project every Gaussian
//! ([`crate::project`]), bin into 16×16 tiles ([`crate::tiles`]), then depth-sort and blend each
//! tile ([`crate::raster`]), tiles in parallel with rayon work stealing. Every step is either
//! per-Gaussian, per-tile, or combined in a fixed order, so the image is bit-identical for any
//! thread count.

use crate::camera::{Camera, CameraError};
use crate::image::{ImageF32, ImageRgb8};
use crate::project::{Splat2D, TILE_PX, project_one};
use crate::raster::{TilePixels, render_tile};
use crate::splats::{InputError, SplatView};
use crate::tiles::bin;

/// Why a frame could not be rendered.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RenderError {
    /// Bad Gaussian arrays.
    #[error(transparent)]
    Input(#[from] InputError),
    /// Unusable camera (including a zero-size image).
    #[error(transparent)]
    Camera(#[from] CameraError),
    /// Near plane not a positive finite depth.
    #[error("near plane {near_m} m must be positive and finite")]
    NearPlane {
        /// The value given, m.
        near_m: f32,
    },
    /// An image too large to allocate sensibly.
    #[error("image {width_px}x{height_px} px exceeds the limit of {max_pixels} pixels")]
    ImageTooLarge {
        /// Width, pixels.
        width_px: u32,
        /// Height, pixels.
        height_px: u32,
        /// The limit, pixels.
        max_pixels: u64,
    },
    /// More Gaussians than the 32-bit indices of the tile lists can address.
    #[error("{n} Gaussians exceed the renderer's limit of {max}")]
    TooManyGaussians {
        /// Number of Gaussians given.
        n: usize,
        /// The limit.
        max: usize,
    },
}

/// Largest image rendered, pixels (16384 × 16384).
pub const MAX_PIXELS: u64 = 1 << 28;

/// Settings that are not part of the camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    /// Background RGB in [0, 1]; default black.
    pub background: [f32; 3],
    /// Gaussians whose centre has view depth `z <= near_m` are culled, m; default 0.2 (3DGS).
    pub near_m: f32,
    /// Highest SH degree evaluated (the data's degree is used when lower); default 3.
    pub max_sh_degree: u8,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            background: [0.0; 3],
            near_m: 0.2,
            max_sh_degree: 3,
        }
    }
}

/// Renders one frame to a float image (`camera.width_px × camera.height_px`).
///
/// Non-finite Gaussians are skipped.
///
/// # Errors
/// [`RenderError`] for inconsistent arrays, an unusable camera (zero-size image, degenerate
/// orientation, bad field of view) or a bad near plane.
pub fn render(
    splats: &SplatView<'_>,
    camera: &Camera,
    settings: &RenderSettings,
) -> Result<ImageF32, RenderError> {
    splats.validate()?;
    let view = camera.view_params()?;
    if !(settings.near_m > 0.0 && settings.near_m.is_finite()) {
        return Err(RenderError::NearPlane {
            near_m: settings.near_m,
        });
    }
    let n = splats.len();
    if n >= u32::MAX as usize {
        return Err(RenderError::TooManyGaussians {
            n,
            max: u32::MAX as usize - 1,
        });
    }
    let (width, height) = (camera.width_px, camera.height_px);
    if u64::from(width) * u64::from(height) > MAX_PIXELS {
        return Err(RenderError::ImageTooLarge {
            width_px: width,
            height_px: height,
            max_pixels: MAX_PIXELS,
        });
    }
    let grid_w = width.div_ceil(TILE_PX);
    let grid_h = height.div_ceil(TILE_PX);
    let num_tiles = (grid_w * grid_h) as usize;

    let project = |i: usize| project_one(splats, i, &view, settings.near_m, settings.max_sh_degree);
    #[cfg(feature = "parallel")]
    let projected: Vec<Splat2D> = {
        use rayon::prelude::*;
        (0..n)
            .into_par_iter()
            .with_min_len(1024)
            .map(project)
            .collect()
    };
    #[cfg(not(feature = "parallel"))]
    let projected: Vec<Splat2D> = (0..n).map(project).collect();

    let bins = bin(&projected, grid_w, num_tiles);
    let background = settings.background;
    let tile = |keys: &mut Vec<u64>, t: usize| -> Box<TilePixels> {
        let (tx, ty) = (t as u32 % grid_w, t as u32 / grid_w);
        render_tile(
            tx,
            ty,
            width,
            height,
            bins.tile(t),
            &projected,
            background,
            keys,
        )
    };
    #[cfg(feature = "parallel")]
    let tiles: Vec<Box<TilePixels>> = {
        use rayon::prelude::*;
        (0..num_tiles)
            .into_par_iter()
            .map_init(Vec::new, tile)
            .collect()
    };
    #[cfg(not(feature = "parallel"))]
    let tiles: Vec<Box<TilePixels>> = {
        let mut keys = Vec::new();
        (0..num_tiles).map(|t| tile(&mut keys, t)).collect()
    };

    let mut pixels = vec![[0.0f32; 3]; width as usize * height as usize];
    for (t, tile_pixels) in tiles.iter().enumerate() {
        let (tx, ty) = (t as u32 % grid_w, t as u32 / grid_w);
        let (x0, y0) = (tx * TILE_PX, ty * TILE_PX);
        let cols = (TILE_PX.min(width - x0)) as usize;
        for row in 0..TILE_PX.min(height - y0) {
            let dst = (y0 + row) as usize * width as usize + x0 as usize;
            let src = (row * TILE_PX) as usize;
            pixels[dst..dst + cols].copy_from_slice(&tile_pixels[src..src + cols]);
        }
    }
    Ok(ImageF32 {
        width,
        height,
        pixels,
    })
}

/// [`render`] followed by [`ImageF32::to_rgb8`].
///
/// # Errors
/// See [`render`].
pub fn render_rgb8(
    splats: &SplatView<'_>,
    camera: &Camera,
    settings: &RenderSettings,
) -> Result<ImageRgb8, RenderError> {
    Ok(render(splats, camera, settings)?.to_rgb8())
}
