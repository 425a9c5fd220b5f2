//! Per-tile rasterization (`renderCUDA` of the 3DGS reference rasterizer; Kerbl et al. 2023
//! eq. 3 and sec. 6): the tile's Gaussians are sorted front to back by view depth (ties by
//! Gaussian index, so the order is total and deterministic), then every pixel blends
//! C = Σ cᵢ αᵢ Tᵢ, Tᵢ = Π_{j<i} (1 − αⱼ) with αᵢ = min(0.99, oᵢ exp(powerᵢ)),
//! powerᵢ = −½ dᵀ Σ'⁻¹ d (d = centre − pixel). A Gaussian is skipped at a pixel when power > 0 or
//! α < 1/255; a pixel stops, without blending the Gaussian that would take it there, as soon as
//! T would drop below 1e-4. The background is added with the remaining T.
//!
//! The loops run Gaussian-outer, pixel-inner, and per tile row only over the chord of the ellipse
//! where α can reach 1/255 (plus a pixel of slack), narrowed to the pixels still blending; each
//! pixel still sees the reference's sequence of operations, so the result is the reference's
//! pixel-outer loop. The blending runs 4 lanes at a time (`wide::f32x4`, branch-free selects), and
//! exp is a portable polynomial ([`exp_neg`], within about 2e-7 relative of libm), so every
//! platform gives the same bits.

use wide::{f32x4, i32x4};

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
    let mut color_r = [0.0f32; TILE_PIXELS];
    let mut color_g = [0.0f32; TILE_PIXELS];
    let mut color_b = [0.0f32; TILE_PIXELS];
    let tile = TileRect::new(tile_x, tile_y, width, height);
    let transmittance = blend_tile(&tile, entries, splats, keys, |_, s, first, alpha, t| {
        let range = first..first + LANES;
        let [cr, cg, cb] = s.color.map(f32x4::splat);
        let sum = load(&color_r[range.clone()]) + cr * alpha * t;
        store(&mut color_r[range.clone()], sum);
        let sum = load(&color_g[range.clone()]) + cg * alpha * t;
        store(&mut color_g[range.clone()], sum);
        let sum = load(&color_b[range.clone()]) + cb * alpha * t;
        store(&mut color_b[range], sum);
    });

    let mut out = Box::new([[0.0f32; 3]; TILE_PIXELS]);
    for py in 0..tile.rows() {
        for px in 0..tile.cols() {
            let p = py * TILE_PX as usize + px;
            let t = transmittance[p];
            out[p] = [
                color_r[p] + t * background[0],
                color_g[p] + t * background[1],
                color_b[p] + t * background[2],
            ];
        }
    }
    out
}

/// The pixels of one tile: tile `(tile_x, tile_y)` of a `width × height` image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TileRect {
    /// First pixel column.
    pub x0: u32,
    /// First pixel row.
    pub y0: u32,
    /// One past the last column (clipped to the image).
    pub x_end: u32,
    /// One past the last row (clipped to the image).
    pub y_end: u32,
}

impl TileRect {
    /// Tile `(tile_x, tile_y)` of a `width × height` image.
    pub fn new(tile_x: u32, tile_y: u32, width: u32, height: u32) -> Self {
        let x0 = tile_x * TILE_PX;
        let y0 = tile_y * TILE_PX;
        Self {
            x0,
            y0,
            x_end: (x0 + TILE_PX).min(width),
            y_end: (y0 + TILE_PX).min(height),
        }
    }

    /// Columns inside the image.
    pub fn cols(&self) -> usize {
        self.x_end.saturating_sub(self.x0) as usize
    }

    /// Rows inside the image.
    pub fn rows(&self) -> usize {
        self.y_end.saturating_sub(self.y0) as usize
    }
}

/// Runs the blending of one tile and reports every blend to `sink` instead of summing colours:
/// the tile's splats (`entries`, indices into `splats`) are depth-sorted and visited front to
/// back exactly as [`render_tile`] does, and for each splat and each group of 4 consecutive
/// pixels of a tile row that it touches, `sink(index, splat, first, alpha, t)` receives the
/// splat's index, the splat, the tile-relative index of the group's first pixel (row-major, 16
/// per row), αᵢ per lane (zero in lanes that do not blend) and the transmittance Tᵢ before the
/// blend. The blending weight of Gaussian i at a pixel is `alpha · t` (3DGS eq. 3). Returns the
/// final transmittance per pixel (1 outside the image). `keys` is scratch space.
pub fn blend_tile(
    tile: &TileRect,
    entries: &[u32],
    splats: &[Splat2D],
    keys: &mut Vec<u64>,
    mut sink: impl FnMut(u32, &Splat2D, usize, f32x4, f32x4),
) -> [f32; TILE_PIXELS] {
    // Depth sort. Depths are > near > 0, so their IEEE bits order like the values; the index in
    // the low half breaks ties the way a stable sort of index-ordered entries would.
    keys.clear();
    keys.extend(
        entries
            .iter()
            .map(|&i| (u64::from(splats[i as usize].depth_m.to_bits()) << 32) | u64::from(i)),
    );
    keys.sort_unstable();

    let TileRect {
        x0,
        y0,
        x_end,
        y_end,
    } = *tile;
    let mut alive = tile.cols() * tile.rows();
    let mut transmittance = [1.0f32; TILE_PIXELS];
    // 1.0 while a pixel still blends, 0.0 once it has stopped (pixels outside the image are
    // never inside a splat's α box, so they stay 1.0 untouched).
    let mut live = [1.0f32; TILE_PIXELS];
    // Bit i of row_live[r] is set while pixel (i, r) of the tile still blends.
    let mut row_live = [0u32; TILE_PX as usize];
    for bits in row_live.iter_mut().take(tile.rows()) {
        *bits = (1u32 << tile.cols()) - 1;
    }

    for &key in keys.iter() {
        let index = (key & 0xffff_ffff) as u32;
        let s = &splats[index as usize];
        let [bx0, by0, bx1, by1] = s.alpha_box_px;
        let py0 = by0.max(y0 as i32);
        let py1 = (by1 + 1).min(y_end as i32);
        let bx0 = bx0.max(x0 as i32);
        let bx1 = (bx1 + 1).min(x_end as i32);
        if bx1 <= bx0 || py1 <= py0 {
            continue;
        }
        let [ca, cb, cc] = s.conic;
        let [mx, my] = s.mean_px;
        // α < 1/255 <=> power < ln(1 / (255 o)); the 1e-3 slack leaves the exact test to the
        // blending code for pixels near the threshold.
        let power_min = (ALPHA_MIN / s.opacity).ln() - 1e-3;
        // Per row, the pixels with power >= power_min lie in one interval of dx (the chord of the
        // ellipse ca dx² + 2 cb dx dy + cc dy² <= -2 power_min); one pixel of slack on each side.
        let chord = -2.0 * power_min;
        for py in py0..py1 {
            let dy = my - py as f32;
            let disc = cb * cb * dy * dy - ca * (cc * dy * dy - chord);
            if disc.is_nan() || disc < 0.0 {
                continue;
            }
            let root = disc.sqrt();
            let dx_lo = (-cb * dy - root) / ca;
            let dx_hi = (-cb * dy + root) / ca;
            // dx = mx - px, so px runs from mx - dx_hi to mx - dx_lo.
            let px0 = ((mx - dx_hi - 1.0).floor() as i32).max(bx0);
            let px1 = ((mx - dx_lo + 1.0).ceil() as i32 + 1).min(bx1);
            if px1 <= px0 {
                continue;
            }
            // Narrow the run to the pixels of this row that still blend.
            let r = (py as u32 - y0) as usize;
            let (c0, c1) = ((px0 as u32 - x0), (px1 as u32 - x0));
            let bits = row_live[r] & (((1u32 << c1) - 1) & !((1u32 << c0) - 1));
            if bits == 0 {
                continue;
            }
            let px0 = (x0 + bits.trailing_zeros()) as i32;
            let px1 = (x0 + 32 - bits.leading_zeros()) as i32;
            let row = r * TILE_PX as usize;
            let c0 = px0 as u32 - x0;
            let c1 = px1 as u32 - x0;
            let stopped = blend_row(
                s,
                dy,
                mx - x0 as f32,
                [c0, c1],
                &mut transmittance[row..row + TILE_PX as usize],
                &mut live[row..row + TILE_PX as usize],
                |first, alpha, t| sink(index, s, row + first, alpha, t),
            ) as usize;
            if stopped > 0 {
                alive -= stopped;
                for (i, &l) in live[row..row + TILE_PX as usize].iter().enumerate() {
                    if l == 0.0 {
                        row_live[r] &= !(1u32 << i);
                    }
                }
            }
        }
        if alive == 0 {
            break;
        }
    }
    transmittance
}

/// Lanes per group in [`blend_row`] (one SSE register of f32; 16 is a multiple).
const LANES: usize = 4;

/// Blends splat `s` into the pixels `span[0]..span[1]` of one 16-pixel tile row (`dy` = centre
/// − row, `dx_first` = centre − the row's first column), 4 lanes at a time with SIMD selects;
/// lanes outside the span or already stopped are left unchanged. Each group's α (zero where a
/// lane does not blend) and transmittance before the blend go to `sink(first column, α, T)`.
/// Returns how many pixels stopped.
#[inline]
fn blend_row(
    s: &Splat2D,
    dy: f32,
    dx_first: f32,
    span: [u32; 2],
    transmittance: &mut [f32],
    live: &mut [f32],
    mut sink: impl FnMut(usize, f32x4, f32x4),
) -> u32 {
    let [ca, cb, cc] = s.conic;
    let o = f32x4::splat(s.opacity);
    let (lo, hi) = (f32x4::splat(span[0] as f32), f32x4::splat(span[1] as f32));
    let cc_dy2 = f32x4::splat(cc * dy * dy);
    let cb_dy = f32x4::splat(cb * dy);
    let ca = f32x4::splat(ca);
    let zero = f32x4::ZERO;
    let mut stopped = 0;
    let first = span[0] as usize / LANES;
    let last = (span[1] as usize).div_ceil(LANES);
    for group in first..last {
        let range = group * LANES..(group + 1) * LANES;
        let base = (group * LANES) as f32;
        let lane = f32x4::new([base, base + 1.0, base + 2.0, base + 3.0]);
        let dx = f32x4::splat(dx_first) - lane;
        // Same expression as the reference: −½(a dx² + c dy²) − b dx dy.
        let power = f32x4::splat(-0.5) * (ca * dx * dx + cc_dy2) - cb_dy * dx;
        let g = o * exp_neg_x4(power);
        let alpha = g
            .simd_lt(f32x4::splat(ALPHA_MAX))
            .select(g, f32x4::splat(ALPHA_MAX));
        let t = load(&transmittance[range.clone()]);
        let l = load(&live[range.clone()]);
        let test_t = t * (f32x4::ONE - alpha);
        let counts = lane.simd_ge(lo)
            & lane.simd_lt(hi)
            & l.simd_gt(zero)
            & power.simd_le(zero)
            & alpha.simd_ge(f32x4::splat(ALPHA_MIN));
        let low = test_t.simd_lt(f32x4::splat(T_MIN));
        let stop = counts & low;
        let blend = counts & !low;
        let w = blend.select(alpha, zero);
        if blend.any() {
            sink(range.start, w, t);
        }
        store(&mut transmittance[range.clone()], blend.select(test_t, t));
        store(&mut live[range], stop.select(zero, l));
        stopped += stop.to_bitmask().count_ones();
    }
    stopped
}

fn load(v: &[f32]) -> f32x4 {
    f32x4::new([v[0], v[1], v[2], v[3]])
}

fn store(v: &mut [f32], x: f32x4) {
    v[..LANES].copy_from_slice(&x.to_array());
}

/// [`exp_neg`] on 4 lanes (the same operations, so the same bits).
#[inline(always)]
fn exp_neg_x4(x: f32x4) -> f32x4 {
    let lo = f32x4::splat(-87.0);
    let x = x.simd_lt(lo).select(lo, x);
    let x = x.simd_gt(f32x4::ZERO).select(f32x4::ZERO, x);
    let round = f32x4::splat(EXP_ROUND);
    let shifted = x * f32x4::splat(std::f32::consts::LOG2_E) + round;
    let n = shifted - round;
    let n_int: i32x4 =
        bytemuck::cast::<f32x4, i32x4>(shifted) - i32x4::splat(EXP_ROUND.to_bits() as i32);
    let r = (x - n * f32x4::splat(EXP_LN2_HI)) - n * f32x4::splat(EXP_LN2_LO);
    let c = |v: f32| f32x4::splat(v);
    let p = c(1.0)
        + r * (c(1.0)
            + r * (c(0.5)
                + r * (c(1.0 / 6.0)
                    + r * (c(1.0 / 24.0) + r * (c(1.0 / 120.0) + r * c(1.0 / 720.0))))));
    let scale: f32x4 = bytemuck::cast((n_int + i32x4::splat(127)) << 23);
    p * scale
}

const EXP_ROUND: f32 = 12_582_912.0; // 1.5 · 2^23: adding it rounds to an integer
const EXP_LN2_HI: f32 = 0.693_359_4;
const EXP_LN2_LO: f32 = -2.121_944_4e-4;

/// e^x for x <= 0 (larger x are clamped to 0, x below −87 give 0 or a denormal-free tiny
/// value), without libm so that it inlines and vectorises and gives the same bits on every
/// platform: x = n ln 2 + r with |r| <= ln 2 / 2 (Cody-Waite split of ln 2), e^r by a degree-6
/// Taylor polynomial (relative error < 2e-7 on that range, about the f32 rounding), times 2^n
/// built in the exponent bits.
#[inline(always)]
pub fn exp_neg(x: f32) -> f32 {
    const LOG2_E: f32 = std::f32::consts::LOG2_E;
    const LN2_HI: f32 = EXP_LN2_HI;
    const LN2_LO: f32 = EXP_LN2_LO;
    const ROUND: f32 = EXP_ROUND;
    // Selects rather than clamp/min/max: they vectorise without NaN fix-ups (NaN input gives
    // NaN out through `r`).
    let x = if x < -87.0 { -87.0 } else { x };
    let x = if x > 0.0 { 0.0 } else { x };
    let shifted = x * LOG2_E + ROUND;
    let n = shifted - ROUND;
    // n is an integer in [-126, 0]; it sits in the low mantissa bits of `shifted`.
    let n_int = (shifted.to_bits() as i32).wrapping_sub(ROUND.to_bits() as i32);
    let r = (x - n * LN2_HI) - n * LN2_LO;
    let p = 1.0
        + r * (1.0
            + r * (0.5
                + r * (1.0 / 6.0 + r * (1.0 / 24.0 + r * (1.0 / 120.0 + r * (1.0 / 720.0))))));
    let scale = f32::from_bits((n_int.wrapping_add(127) as u32) << 23);
    p * scale
}
