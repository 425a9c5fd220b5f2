//! Rotation of the polar decomposition A = R S by Newton's iteration X ← (X + X⁻ᵀ) / 2 (Higham
//! 1986, "Computing the polar decomposition — with applications", eq. 3.1), for the stress of
//! corotated materials at every particle and substep.
//!
//! For det A > 0 the iterates keep A's singular vectors and map each singular value σ to
//! (σ + 1/σ) / 2, so they stay proper (det > 0) and converge quadratically to R = U Vᵀ: near R, a
//! step's error is about half the square of the previous step's. An elastic F is close to a
//! rotation, so two or three steps reach f32 rounding, against the several Jacobi sweeps of
//! [`super::svd3`]. Inverted (det A <= 0), near-singular or non-converging A falls back to
//! [`super::polar()`], whose sign-fixed SVD gives a proper rotation for any A.

use glam::Mat3A;
use wide::f32x4;

use super::mat3x4::{Mat3x4, cross, dot};

/// Newton steps tried before falling back to the SVD: enough for singular values within about
/// [0.25, 4], where elastic deformation gradients live.
const MAX_STEPS: usize = 6;

/// A step no larger than this (max-norm) ends the iteration: the next error would be about
/// STEP_TOL² / 2 ≈ 5e-8, f32 rounding at unit scale.
const STEP_TOL: f32 = 3e-4;

/// R of A = R S: a proper rotation (det +1) for any A, equal to [`super::polar()`]'s R within f32
/// rounding (checked against it by the `svd_proptest` tests). A non-finite A gives a non-finite R.
/// The step test is absolute: the iterates approach R, whose columns have unit length.
#[inline]
pub fn polar_rotation(a: Mat3A) -> Mat3A {
    let mut x = a;
    for _ in 0..MAX_STEPS {
        let (c0, c1, c2) = (x.x_axis, x.y_axis, x.z_axis);
        // X⁻ᵀ = cof(X) / det X, with the cofactor columns as cross products of X's columns.
        let (k0, k1, k2) = (c1.cross(c2), c2.cross(c0), c0.cross(c1));
        let det = c0.dot(k0);
        // Inverted, singular or not finite: the SVD handles it.
        if !det.is_finite() || det <= f32::MIN_POSITIVE {
            break;
        }
        let h = 0.5 / det;
        let next = Mat3A::from_cols(c0 * 0.5 + k0 * h, c1 * 0.5 + k1 * h, c2 * 0.5 + k2 * h);
        let step = (next.x_axis - c0)
            .abs()
            .max((next.y_axis - c1).abs())
            .max((next.z_axis - c2).abs())
            .max_element();
        x = next;
        if step <= STEP_TOL {
            return x;
        }
    }
    super::polar(a).r
}

/// [`polar_rotation`] of four matrices at once, one per lane: each lane performs exactly the
/// scalar iteration (same operations, same order, same stopping rule), so lane l equals
/// `polar_rotation(a.lane(l))` bit for bit. A lane stops when its own step is small enough;
/// lanes that are inverted, singular or not converged after the scalar form's step limit take
/// its SVD fallback.
pub fn polar_rotation_x4(a: &Mat3x4) -> Mat3x4 {
    let mut x = *a;
    // Per-lane state as bit masks (bit l = lane l): converged, and sent to the SVD.
    let (mut done, mut failed) = (0u32, 0u32);
    let half = f32x4::splat(0.5);
    for _ in 0..MAX_STEPS {
        let [c0, c1, c2] = x.cols;
        let (k0, k1, k2) = (cross(c1, c2), cross(c2, c0), cross(c0, c1));
        let det = dot(c0, k0);
        let good = det.is_finite().to_bitmask()
            & !det.simd_le(f32x4::splat(f32::MIN_POSITIVE)).to_bitmask();
        let bad = !good;
        failed |= bad & !done & 0xF;
        let active = !(done | failed) & 0xF;
        if active == 0 {
            break;
        }
        let h = half / det;
        let (c, k) = ([c0, c1, c2], [k0, k1, k2]);
        let next = Mat3x4 {
            cols: std::array::from_fn(|j| std::array::from_fn(|i| c[j][i] * half + k[j][i] * h)),
        };
        let mut step = f32x4::ZERO;
        for (n, c) in next.cols.iter().zip([c0, c1, c2]) {
            for i in 0..3 {
                step = step.fast_max((n[i] - c[i]).abs());
            }
        }
        let keep = lane_mask(active);
        x.cols = std::array::from_fn(|j| {
            std::array::from_fn(|i| keep.bitselect(next.cols[j][i], x.cols[j][i]))
        });
        done |= active & step.simd_le(f32x4::splat(STEP_TOL)).to_bitmask();
    }
    for l in 0..4 {
        if done & (1 << l) == 0 {
            let r = super::polar(a.lane(l)).r;
            for (j, col) in x.cols.iter_mut().enumerate() {
                for (i, v) in col.iter_mut().enumerate() {
                    let mut lanes = v.to_array();
                    lanes[l] = r.col(j)[i];
                    *v = f32x4::new(lanes);
                }
            }
        }
    }
    x
}

/// All bits set in the lanes whose bit is set in `bits`, zero in the others.
#[inline]
fn lane_mask(bits: u32) -> f32x4 {
    f32x4::new(std::array::from_fn(|l| {
        f32::from_bits(if bits & (1 << l) != 0 { u32::MAX } else { 0 })
    }))
}
