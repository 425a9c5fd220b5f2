//! Per-Gaussian preprocessing (`preprocessCUDA` and `computeCov2D` of the 3DGS reference
//! rasterizer, Kerbl et al. 2023 sec. 4 and 6): view transform, near-plane cull, EWA projection
//! of the covariance Σ' = J W Σ Wᵀ Jᵀ (Zwicker et al. 2001, eq. 31; 3DGS eq. 5) with the
//! perspective Jacobian J at the (frustum-clamped) centre, a 0.3 px² low-pass on the diagonal,
//! the conic Σ'⁻¹, a 3σ radius from the larger eigenvalue, the covered 16×16 tiles, and the
//! view-dependent colour from SH with the view direction rotated into the Gaussian's frame (Rᵀd).
//!
//! One addition that does not change any pixel: the box where α = o·G can reach 1/255 (the
//! ellipse dᵀΣ'⁻¹d <= 2 ln(255 o)) is computed too, so the rasterizer touches only pixels the
//! reference would not skip, and tiles whose pixels all fall outside it are not binned.

use glam::{Mat3, Quat, Vec3};

use crate::camera::ViewParams;
use crate::sh::eval_sh;
use crate::splats::SplatView;

/// Tile edge, pixels (the reference's `BLOCK_X = BLOCK_Y = 16`).
pub const TILE_PX: u32 = 16;

/// Low-pass filter added to the diagonal of the 2D covariance, px² (3DGS `computeCov2D`).
pub const LOW_PASS_PX2: f32 = 0.3;

/// Minimum α a Gaussian must reach at a pixel to be blended there.
pub const ALPHA_MIN: f32 = 1.0 / 255.0;

/// One projected Gaussian (a screen-space splat). `visible == false` means it covers no tile.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Splat2D {
    /// Centre in pixels (pixel centres at integers).
    pub mean_px: [f32; 2],
    /// Conic Σ'⁻¹ as `a, b, c` of `[[a, b], [b, c]]`, 1/px².
    pub conic: [f32; 3],
    /// Opacity in [0, 1].
    pub opacity: f32,
    /// View-space depth z, m (> near plane).
    pub depth_m: f32,
    /// RGB colour after SH evaluation (>= 0).
    pub color: [f32; 3],
    /// 3σ radius, px (`ceil(3 sqrt(λmax))`).
    pub radius_px: f32,
    /// Covered tiles `x0, y0, x1, y1` (half-open): the reference's `getRect` intersected with
    /// the tiles of `alpha_box_px`.
    pub tiles: [u32; 4],
    /// Pixels where α can reach 1/255, `x0, y0, x1, y1` inclusive, clipped to the image.
    pub alpha_box_px: [i32; 4],
    /// False when culled (behind the near plane, not finite, too faint, or off screen).
    pub visible: bool,
}

/// Projects Gaussian `i` of `splats` for `view`, with `near_m` the near-plane depth and
/// `max_sh_degree` the highest SH degree evaluated. Never panics on non-finite input: such
/// Gaussians come back invisible.
pub fn project_one(
    splats: &SplatView<'_>,
    i: usize,
    view: &ViewParams,
    near_m: f32,
    max_sh_degree: u8,
) -> Splat2D {
    let hidden = Splat2D::default();
    let p = Vec3::from(splats.positions[i]);
    let opacity = splats.opacities[i];
    if !p.is_finite() || opacity.is_nan() || opacity < ALPHA_MIN {
        return hidden;
    }
    let opacity = opacity.min(1.0);
    let t = view.to_view(p);
    // `in_frustum`: the reference culls p_view.z <= 0.2.
    if t.z.is_nan() || t.z <= near_m {
        return hidden;
    }

    // computeCov2D: clamp the centre to 1.3x the frustum before building J.
    let [fx, fy] = view.focal_px;
    let lim_x = 1.3 * view.tan_half_fov[0];
    let lim_y = 1.3 * view.tan_half_fov[1];
    let tx = (t.x / t.z).clamp(-lim_x, lim_x) * t.z;
    let ty = (t.y / t.z).clamp(-lim_y, lim_y) * t.z;
    let tz2 = t.z * t.z;
    // Rows of J (the third row is zero).
    let j0 = Vec3::new(fx / t.z, 0.0, -(fx * tx) / tz2);
    let j1 = Vec3::new(0.0, fy / t.z, -(fy * ty) / tz2);
    let [xx, xy, xz, yy, yz, zz] = splats.covariances[i];
    let sigma = Mat3::from_cols(
        Vec3::new(xx, xy, xz),
        Vec3::new(xy, yy, yz),
        Vec3::new(xz, yz, zz),
    );
    // Rows of T = J W, then Σ' = T Σ Tᵀ.
    let w_t = view.rotation.transpose();
    let t0 = w_t * j0;
    let t1 = w_t * j1;
    let s_t0 = sigma * t0;
    let s_t1 = sigma * t1;
    let a = t0.dot(s_t0) + LOW_PASS_PX2;
    let b = t0.dot(s_t1);
    let c = t1.dot(s_t1) + LOW_PASS_PX2;

    // A valid (positive semi-definite) Σ gives a positive-definite Σ' after the low-pass; anything
    // else (non-finite or indefinite input) is not a Gaussian and is dropped.
    let det = a * c - b * b;
    if !(det > 0.0 && det.is_finite() && a > 0.0 && c > 0.0) {
        return hidden;
    }
    let det_inv = 1.0 / det;
    let conic = [c * det_inv, -b * det_inv, a * det_inv];
    let mid = 0.5 * (a + c);
    let root = (mid * mid - det).max(0.1).sqrt();
    let lambda1 = mid + root;
    let lambda2 = mid - root;
    let radius_px = (3.0 * lambda1.max(lambda2).sqrt()).ceil();
    let mean_px = view.to_pixel(t);
    if !(mean_px[0].is_finite() && mean_px[1].is_finite() && radius_px.is_finite()) {
        return hidden;
    }

    let [width, height] = view.size_px;
    let grid = [width.div_ceil(TILE_PX), height.div_ceil(TILE_PX)];
    let rect = tile_rect(mean_px, radius_px, grid);
    if (rect[2] - rect[0]) * (rect[3] - rect[1]) == 0 {
        return hidden;
    }

    // Where α = o·exp(power) >= 1/255: power >= -ln(255 o) <=> dᵀΣ'⁻¹d <= 2 ln(255 o). The half
    // extents of that ellipse are sqrt(s Σ'_xx), sqrt(s Σ'_yy); 1 % and one pixel of slack keep
    // every pixel the reference would blend.
    let s = 2.0 * (255.0 * opacity).ln() * 1.01;
    let half_x = (s * a).sqrt() + 1.0;
    let half_y = (s * c).sqrt() + 1.0;
    let alpha_box_px = [
        ((mean_px[0] - half_x).ceil().max(0.0)) as i32,
        ((mean_px[1] - half_y).ceil().max(0.0)) as i32,
        ((mean_px[0] + half_x).floor().min(width as f32 - 1.0)) as i32,
        ((mean_px[1] + half_y).floor().min(height as f32 - 1.0)) as i32,
    ];
    if alpha_box_px[0] > alpha_box_px[2] || alpha_box_px[1] > alpha_box_px[3] {
        return hidden;
    }
    let tiles = [
        rect[0].max(alpha_box_px[0] as u32 / TILE_PX),
        rect[1].max(alpha_box_px[1] as u32 / TILE_PX),
        rect[2].min(alpha_box_px[2] as u32 / TILE_PX + 1),
        rect[3].min(alpha_box_px[3] as u32 / TILE_PX + 1),
    ];
    if tiles[0] >= tiles[2] || tiles[1] >= tiles[3] {
        return hidden;
    }

    // computeColorFromSH: direction from the camera to the centre, rotated by Rᵀ.
    let degree = splats.sh_degree.min(max_sh_degree);
    let k = splats.coeffs_per_gaussian();
    let coeffs = &splats.sh[i * k..(i + 1) * k];
    let mut dir = (p - view.position).normalize_or_zero();
    if degree > 0
        && let Some(r) = splats.rotations.get(i)
    {
        let q = Quat::from_xyzw(r[1], r[2], r[3], r[0]);
        let n = q.length();
        if !(n.is_finite() && n > 1e-12) {
            return hidden;
        }
        dir = (q / n).inverse() * dir;
    }
    let used = &coeffs[..crate::sh::coeffs_for_degree(degree)];
    if !used.iter().flatten().all(|v| v.is_finite()) {
        return hidden;
    }
    let color = eval_sh(degree, coeffs, dir);

    Splat2D {
        mean_px,
        conic,
        opacity,
        depth_m: t.z,
        color,
        radius_px,
        tiles,
        alpha_box_px,
        visible: true,
    }
}

/// The reference's `getRect`: tiles `[x0, x1) × [y0, y1)` touched by the square of half-size
/// `radius_px` around `mean_px`, clamped to the `grid` (tiles across, tiles down).
pub fn tile_rect(mean_px: [f32; 2], radius_px: f32, grid: [u32; 2]) -> [u32; 4] {
    let tile = TILE_PX as f32;
    let lo = |p: f32, g: u32| (((p - radius_px) / tile) as i64).clamp(0, g as i64) as u32;
    let hi =
        |p: f32, g: u32| (((p + radius_px + tile - 1.0) / tile) as i64).clamp(0, g as i64) as u32;
    [
        lo(mean_px[0], grid[0]),
        lo(mean_px[1], grid[1]),
        hi(mean_px[0], grid[0]),
        hi(mean_px[1], grid[1]),
    ]
}
