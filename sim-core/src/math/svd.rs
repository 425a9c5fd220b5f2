//! Robust 3×3 singular value decomposition and polar decomposition, in f32.
//!
//! Method (McAdams et al. 2011, "Computing the Singular Value Decomposition of 3×3 matrices with
//! minimal branching and elementary floating point operations"): cyclic Jacobi on the symmetric
//! matrix AᵀA gives V; the columns of B = A·V are sorted by decreasing norm; a Givens QR of B gives
//! U and the upper-triangular R whose diagonal is Σ. Both U and V are proper rotations
//! (det = +1); when det A < 0 the sign goes to the smallest singular value (the "sign-fixed" SVD of
//! Irving et al. 2004, which invertible-FEM and MPM plasticity expect). Near-singular and rank
//! deficient matrices are handled: a zero column gives an identity Givens rotation, never a NaN.

use glam::{Mat3A, Vec3A};

/// A = U · diag(sigma) · Vᵀ with U, V proper rotations and sigma[0] >= sigma[1] >= |sigma[2]|,
/// sigma[0], sigma[1] >= 0, sign(sigma[2]) = sign(det A).
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

/// Row-major 3×3 working matrix.
type M = [[f32; 3]; 3];

fn to_rows(a: Mat3A) -> M {
    let c = a.to_cols_array_2d();
    [
        [c[0][0], c[1][0], c[2][0]],
        [c[0][1], c[1][1], c[2][1]],
        [c[0][2], c[1][2], c[2][2]],
    ]
}

fn from_rows(m: &M) -> Mat3A {
    Mat3A::from_cols_array_2d(&[
        [m[0][0], m[1][0], m[2][0]],
        [m[0][1], m[1][1], m[2][1]],
        [m[0][2], m[1][2], m[2][2]],
    ])
}

/// One Jacobi rotation zeroing s[p][q] of the symmetric matrix `s`, accumulated into `v`.
fn jacobi_rotate(s: &mut M, v: &mut M, p: usize, q: usize) {
    let spq = s[p][q];
    if spq == 0.0 {
        return;
    }
    let theta = (s[q][q] - s[p][p]) / (2.0 * spq);
    let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
    // For huge theta, t underflows to ~0: the rotation is the identity, which is fine.
    let c = 1.0 / (t * t + 1.0).sqrt();
    let sn = t * c;
    for k in 0..3 {
        let skp = s[k][p];
        let skq = s[k][q];
        s[k][p] = c * skp - sn * skq;
        s[k][q] = sn * skp + c * skq;
    }
    for k in 0..3 {
        let spk = s[p][k];
        let sqk = s[q][k];
        s[p][k] = c * spk - sn * sqk;
        s[q][k] = sn * spk + c * sqk;
    }
    for row in v.iter_mut() {
        let vkp = row[p];
        let vkq = row[q];
        row[p] = c * vkp - sn * vkq;
        row[q] = sn * vkp + c * vkq;
    }
}

/// Givens rotation acting on rows `i`, `j` of `b` that zeroes b[j][col] and leaves b[i][col] >= 0;
/// the transpose is accumulated into `u` (so that A = U·R at the end).
fn givens_zero(b: &mut M, u: &mut M, i: usize, j: usize, col: usize) {
    let a = b[i][col];
    let c_ = b[j][col];
    let r = (a * a + c_ * c_).sqrt();
    if r <= f32::MIN_POSITIVE {
        return;
    }
    let c = a / r;
    let s = c_ / r;
    for k in 0..3 {
        let bi = b[i][k];
        let bj = b[j][k];
        b[i][k] = c * bi + s * bj;
        b[j][k] = -s * bi + c * bj;
    }
    for row in u.iter_mut() {
        let ui = row[i];
        let uj = row[j];
        row[i] = c * ui + s * uj;
        row[j] = -s * ui + c * uj;
    }
}

/// Sign-fixed SVD of a 3×3 matrix. Never panics; a non-finite input gives a non-finite output
/// (callers check state for NaN).
pub fn svd3(a: Mat3A) -> Svd3 {
    let am = to_rows(a);
    // S = AᵀA.
    let mut s = [[0.0f32; 3]; 3];
    for (i, row) in s.iter_mut().enumerate() {
        for (j, e) in row.iter_mut().enumerate() {
            *e = am[0][i] * am[0][j] + am[1][i] * am[1][j] + am[2][i] * am[2][j];
        }
    }
    let mut v: M = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let scale = s[0][0].abs() + s[1][1].abs() + s[2][2].abs();
    for _sweep in 0..12 {
        let off = s[0][1].abs() + s[0][2].abs() + s[1][2].abs();
        if off <= 1e-9 * scale || off == 0.0 || !off.is_finite() {
            break;
        }
        jacobi_rotate(&mut s, &mut v, 0, 1);
        jacobi_rotate(&mut s, &mut v, 0, 2);
        jacobi_rotate(&mut s, &mut v, 1, 2);
    }
    // V as found by Jacobi is a product of rotations: det +1.
    // B = A V.
    let mut b = [[0.0f32; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            b[i][j] = am[i][0] * v[0][j] + am[i][1] * v[1][j] + am[i][2] * v[2][j];
        }
    }
    // Sort columns of B (and V) by decreasing norm; each swap negates one column to keep det +1.
    let norm2 = |b: &M, j: usize| b[0][j] * b[0][j] + b[1][j] * b[1][j] + b[2][j] * b[2][j];
    let swap = |b: &mut M, v: &mut M, p: usize, q: usize| {
        for k in 0..3 {
            let t = b[k][p];
            b[k][p] = b[k][q];
            b[k][q] = -t;
            let t = v[k][p];
            v[k][p] = v[k][q];
            v[k][q] = -t;
        }
    };
    if norm2(&b, 0) < norm2(&b, 1) {
        swap(&mut b, &mut v, 0, 1);
    }
    if norm2(&b, 0) < norm2(&b, 2) {
        swap(&mut b, &mut v, 0, 2);
    }
    if norm2(&b, 1) < norm2(&b, 2) {
        swap(&mut b, &mut v, 1, 2);
    }
    // QR by Givens: U accumulates the rotations, B becomes R.
    let mut u: M = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    givens_zero(&mut b, &mut u, 0, 1, 0);
    givens_zero(&mut b, &mut u, 0, 2, 0);
    givens_zero(&mut b, &mut u, 1, 2, 1);
    // R's diagonal: r00, r11 >= 0 by construction of the Givens rotations; r22 carries det's sign.
    // A rank-deficient first column can leave r11 < 0 only if the column was zero: fix it by
    // flipping the row sign in R and the column sign in U, together with the last one so det U
    // stays +1.
    let mut sigma = [b[0][0], b[1][1], b[2][2]];
    for k in 0..2 {
        if sigma[k] < 0.0 {
            sigma[k] = -sigma[k];
            sigma[2] = -sigma[2];
            for row in u.iter_mut() {
                row[k] = -row[k];
                row[2] = -row[2];
            }
        }
    }
    Svd3 { u: from_rows(&u), sigma: Vec3A::from(sigma), v: from_rows(&v) }
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
