//! Robust 3×3 singular value decomposition and polar decomposition, in f32.
//!
//! Method: one-sided Jacobi (Hestenes 1958; Demmel and Veselić 1992 show its high relative
//! accuracy) orthogonalises the columns of B = A·V; they are sorted by decreasing norm and U is
//! their Gram-Schmidt basis completed by a cross product. Both U and V are proper rotations
//! (det = +1); when det A < 0 the sign goes to the smallest singular value (the "sign-fixed" SVD of
//! Irving et al. 2004, which invertible-FEM and MPM plasticity expect). Near-singular and rank
//! deficient matrices are handled: a vanishing column gets an arbitrary orthogonal direction,
//! never a NaN.

use glam::{Mat3A, Vec3A};

/// A = U · diag(sigma) · Vᵀ with U, V proper rotations and σ0 >= σ1 >= |σ2|,
/// σ0, σ1 >= 0, sign(σ2) = sign(det A).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Svd3 {
    /// Left rotation U (det +1).
    pub u: Mat3A,
    /// Singular values, sorted, last one signed.
    pub sigma: Vec3A,
    /// Right rotation V (det +1).
    pub v: Mat3A,
}

/// A = R · S with R a proper rotation and S symmetric (S = V Σ Vᵀ).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Polar {
    /// Rotation R = U Vᵀ (det +1).
    pub r: Mat3A,
    /// Symmetric stretch S = V Σ Vᵀ.
    pub s: Mat3A,
}

/// Column `j` of `a`.
#[inline]
fn col(a: &Mat3A, j: usize) -> Vec3A {
    a.col(j)
}

/// Any unit vector orthogonal to unit `u`.
#[inline]
fn any_orthogonal(u: Vec3A) -> Vec3A {
    u.any_orthonormal_vector()
}

/// Sign-fixed SVD of a 3×3 matrix. Never panics; a non-finite input gives a non-finite output
/// (callers check state for NaN).
///
/// One-sided Jacobi (Hestenes): plane rotations applied to the columns of B = A V make them
/// mutually orthogonal, computing each rotation from the current columns rather than from a
/// once-formed AᵀA, which keeps small singular values accurate in f32. Then σ_j = |b_j| sorted,
/// U from Gram-Schmidt of the sorted columns completed by a cross product so that det U = +1;
/// the last singular value is u₃·b₃ and so carries the sign of det A.
pub fn svd3(a: Mat3A) -> Svd3 {
    let mut b = [col(&a, 0), col(&a, 1), col(&a, 2)];
    let mut v = [Vec3A::X, Vec3A::Y, Vec3A::Z];
    for _sweep in 0..10 {
        let mut rotated = false;
        for (p, q) in [(0usize, 1usize), (0, 2), (1, 2)] {
            let alpha = b[p].length_squared();
            let beta = b[q].length_squared();
            let gamma = b[p].dot(b[q]);
            // 1e-6 relative: f32 rounding alone leaves |γ| ~1e-7 √(αβ), so a tighter bound only
            // spends sweeps pushing noise (measured 7-14 % of an MPM substep).
            if gamma == 0.0 || gamma.abs() <= 1e-6 * (alpha * beta).sqrt() {
                continue;
            }
            rotated = true;
            let zeta = (beta - alpha) / (2.0 * gamma);
            let t = zeta.signum() / (zeta.abs() + (1.0 + zeta * zeta).sqrt());
            let c = 1.0 / (1.0 + t * t).sqrt();
            let s = c * t;
            let (bp, bq) = (b[p], b[q]);
            b[p] = bp * c - bq * s;
            b[q] = bp * s + bq * c;
            let (vp, vq) = (v[p], v[q]);
            v[p] = vp * c - vq * s;
            v[q] = vp * s + vq * c;
        }
        if !rotated {
            break;
        }
    }
    // Sort by decreasing column norm; each swap negates one column so det V stays +1.
    let swap = |b: &mut [Vec3A; 3], v: &mut [Vec3A; 3], p: usize, q: usize| {
        let t = b[p];
        b[p] = b[q];
        b[q] = -t;
        let t = v[p];
        v[p] = v[q];
        v[q] = -t;
    };
    if b[0].length_squared() < b[1].length_squared() {
        swap(&mut b, &mut v, 0, 1);
    }
    if b[0].length_squared() < b[2].length_squared() {
        swap(&mut b, &mut v, 0, 2);
    }
    if b[1].length_squared() < b[2].length_squared() {
        swap(&mut b, &mut v, 1, 2);
    }
    // U by Gram-Schmidt with completion: proper rotation even for rank-deficient A.
    let s0 = b[0].length();
    let u0 = if s0 > f32::MIN_POSITIVE {
        b[0] / s0
    } else {
        Vec3A::X
    };
    let r1 = b[1] - u0 * u0.dot(b[1]);
    let n1 = r1.length();
    let mut u1 = if n1 > 1e-30 && n1 > 1e-6 * s0 {
        r1 / n1
    } else {
        any_orthogonal(u0)
    };
    if u1.dot(b[1]) < 0.0 {
        // Only possible on the arbitrary fallback direction: flip it (and u2 follows).
        u1 = -u1;
    }
    let u2 = u0.cross(u1);
    let sigma = Vec3A::new(s0, u1.dot(b[1]), u2.dot(b[2]));
    Svd3 {
        u: Mat3A::from_cols(u0, u1, u2),
        sigma,
        v: Mat3A::from_cols(v[0], v[1], v[2]),
    }
}

/// Polar decomposition A = R S from [`svd3`]: R = U Vᵀ (a proper rotation even for inverted A),
/// S = V Σ Vᵀ.
pub fn polar(a: Mat3A) -> Polar {
    let Svd3 { u, sigma, v } = svd3(a);
    let r = u * v.transpose();
    let s = v * Mat3A::from_diagonal(sigma.into()) * v.transpose();
    Polar { r, s }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Mat3A, b: Mat3A, tol: f32) -> bool {
        (a - b).to_cols_array().iter().all(|d| d.abs() <= tol)
    }

    #[test]
    fn identity_decomposes_to_identity() {
        let s = svd3(Mat3A::IDENTITY);
        assert_eq!(s.sigma, Vec3A::ONE);
        assert!(close(s.u * s.v.transpose(), Mat3A::IDENTITY, 1e-6));
    }

    #[test]
    fn reflection_puts_sign_on_smallest_value() {
        let a = Mat3A::from_diagonal(glam::Vec3::new(2.0, -1.0, 0.5));
        let s = svd3(a);
        assert!((s.sigma.x - 2.0).abs() < 1e-6);
        assert!((s.sigma.y - 1.0).abs() < 1e-6);
        assert!((s.sigma.z + 0.5).abs() < 1e-6);
        assert!((s.u.determinant() - 1.0).abs() < 1e-5);
        assert!((s.v.determinant() - 1.0).abs() < 1e-5);
        let back = s.u * Mat3A::from_diagonal(s.sigma.into()) * s.v.transpose();
        assert!(close(back, a, 1e-5));
    }

    #[test]
    fn zero_matrix_gives_zero_singular_values() {
        let s = svd3(Mat3A::ZERO);
        assert_eq!(s.sigma, Vec3A::ZERO);
        assert!(s.u.is_finite() && s.v.is_finite());
    }
}
