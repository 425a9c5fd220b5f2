//! Per-tile rasterization (`renderCUDA` of the 3DGS reference rasterizer; Kerbl et al. 2023
//! eq. 3 and sec. 6): the tile's Gaussians are sorted front to back by view depth (ties by
//! Gaussian index, so the order is total and deterministic), then every pixel blends
//! C = Σ cᵢ αᵢ Tᵢ, Tᵢ = Π_{j<i} (1 − αⱼ) with αᵢ = min(0.99, oᵢ exp(powerᵢ)),
//! powerᵢ = −½ dᵀ Σ'⁻¹ d (d = centre − pixel). A Gaussian is skipped at a pixel when power > 0 or
//! α < 1/255; a pixel stops, without blending the Gaussian that would take it there, as soon as
//! T would drop below 1e-4. The background is added with the remaining T.
//!
//! The loops run Gaussian-outer, pixel-inner over the part of the tile where α can reach 1/255
//! ([`Splat2D::alpha_box_px`]); each pixel still sees exactly the reference's sequence of
//! operations, so the result is the same as the reference's pixel-outer loop.

use crate::project::{ALPHA_MIN, Splat2D, TILE_PX};

/// Pixels per tile.
pub const TILE_PIXELS: usize = (TILE_PX * TILE_PX) as usize;

/// Transmittance below which a pixel stops.
pub const T_MIN: f32 = 1e-4;

/// Largest α of one Gaussian at one pixel.
pub const ALPHA_MAX: f32 = 0.99;

/// Final colours of one tile, row-major within the tile (16 per row); pixels outside the image
/// are left at zero.
pub type TilePixels = [[f32; 3]; TILE_PIXELS];

/// Renders tile `(tile_x, tile_y)` of a `width × height` image from the splats listed in
/// `entries` (indices into `splats`); `keys` is scratch space reused between tiles.
#[allow(clippy::too_many_arguments)]
pub fn render_tile(
    tile_x: u32,
    tile_y: u32,
    width: u32,
    height: u32,
    entries: &[u32],
    splats: &[Splat2D],
    background: [f32; 3],
    keys: &mut Vec<u64>,
) -> Box<TilePixels> {
    // Depth sort. Depths are > near > 0, so their IEEE bits order like the values; the index in
    // the low half breaks ties the way a stable sort of index-ordered entries would.
    keys.clear();
    keys.extend(
        entries
            .iter()
            .map(|&i| (u64::from(splats[i as usize].depth_m.to_bits()) << 32) | u64::from(i)),
    );
    keys.sort_unstable();

    let x0 = tile_x * TILE_PX;
    let y0 = tile_y * TILE_PX;
    let x_end = (x0 + TILE_PX).min(width);
    let y_end = (y0 + TILE_PX).min(height);
    let mut alive = ((x_end - x0) * (y_end - y0)) as usize;

    let mut transmittance = [1.0f32; TILE_PIXELS];
    let mut color = [[0.0f32; 3]; TILE_PIXELS];
    let mut done = [false; TILE_PIXELS];

    for &key in keys.iter() {
        let s = &splats[(key & 0xffff_ffff) as usize];
        let [bx0, by0, bx1, by1] = s.alpha_box_px;
        let px0 = (bx0.max(x0 as i32)) as u32;
        let py0 = (by0.max(y0 as i32)) as u32;
        let px1 = (bx1 + 1).min(x_end as i32);
        let py1 = (by1 + 1).min(y_end as i32);
        if px1 <= px0 as i32 || py1 <= py0 as i32 {
            continue;
        }
        let [ca, cb, cc] = s.conic;
        // α < 1/255 <=> power < ln(1 / (255 o)); the 1e-3 slack leaves the exact test to the
        // blending code for pixels near the threshold.
        let power_min = (ALPHA_MIN / s.opacity).ln() - 1e-3;
        for py in py0..py1 as u32 {
            let dy = s.mean_px[1] - py as f32;
            let row = ((py - y0) * TILE_PX) as usize;
            for px in px0..px1 as u32 {
                let p = row + (px - x0) as usize;
                if done[p] {
                    continue;
                }
                let dx = s.mean_px[0] - px as f32;
                let power = -0.5 * (ca * dx * dx + cc * dy * dy) - cb * dx * dy;
                if power > 0.0 || power < power_min {
                    continue;
                }
                let alpha = ALPHA_MAX.min(s.opacity * power.exp());
                if alpha < ALPHA_MIN {
                    continue;
                }
                let test_t = transmittance[p] * (1.0 - alpha);
                if test_t < T_MIN {
                    done[p] = true;
                    alive -= 1;
                    continue;
                }
                let t = transmittance[p];
                for ch in 0..3 {
                    color[p][ch] += s.color[ch] * alpha * t;
                }
                transmittance[p] = test_t;
            }
        }
        if alive == 0 {
            break;
        }
    }

    let mut out = Box::new([[0.0f32; 3]; TILE_PIXELS]);
    for py in 0..(y_end - y0) as usize {
        for px in 0..(x_end - x0) as usize {
            let p = py * TILE_PX as usize + px;
            for ch in 0..3 {
                out[p][ch] = color[p][ch] + transmittance[p] * background[ch];
            }
        }
    }
    out
}
