//! Four 3×3 matrices side by side, one per SIMD lane (structure of arrays), so that per-particle
//! matrix work runs on four particles per instruction. Every operation performs, lane by lane,
//! the same IEEE operations in the same order as glam's `Mat3A` and `Vec3A` (cross products,
//! dot products summed (x + y) + z, matrix products summed column by column), so a lane's result
//! is bit-identical to the scalar computation on that lane's matrix.

use glam::{Mat3A, Vec3A};
use wide::f32x4;

/// Three components, each holding four lanes.
pub type Vec3x4 = [f32x4; 3];

/// Four 3×3 matrices: `cols[j][i]` holds entry (row i, column j) of each lane's matrix.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mat3x4 {
    /// Columns, each a [`Vec3x4`].
    pub cols: [Vec3x4; 3],
}

impl Mat3x4 {
    /// Packs four matrices, `m[l]` into lane l.
    #[inline]
    pub fn from_lanes(m: &[Mat3A; 4]) -> Self {
        let col = |j: usize| -> Vec3x4 {
            std::array::from_fn(|i| f32x4::new(std::array::from_fn(|l| m[l].col(j)[i])))
        };
        Self {
            cols: [col(0), col(1), col(2)],
        }
    }

    /// Unpacks lane `l` (0..4).
    #[inline]
    pub fn lane(&self, l: usize) -> Mat3A {
        let col = |j: usize| {
            let c = &self.cols[j];
            Vec3A::new(c[0].as_array()[l], c[1].as_array()[l], c[2].as_array()[l])
        };
        Mat3A::from_cols(col(0), col(1), col(2))
    }

    /// The determinant of each lane, as glam computes it: z · (x × y).
    #[inline]
    pub fn determinant(&self) -> f32x4 {
        dot(self.cols[2], cross(self.cols[0], self.cols[1]))
    }

    /// Lane-wise `self - rhs`.
    #[inline]
    pub fn sub(&self, rhs: &Self) -> Self {
        Self {
            cols: std::array::from_fn(|j| {
                std::array::from_fn(|i| self.cols[j][i] - rhs.cols[j][i])
            }),
        }
    }

    /// Lane-wise `self * rhsᵀ`, summed as glam's `Mat3A * Mat3A` sums: column c of the product
    /// is ((a₀ b₀ + a₁ b₁) + a₂ b₂) over the columns a of `self` and the entries b of column c
    /// of rhsᵀ (row c of `rhs`).
    #[inline]
    pub fn mul_transpose(&self, rhs: &Self) -> Self {
        let a = &self.cols;
        let b = &rhs.cols;
        Self {
            cols: std::array::from_fn(|c| {
                std::array::from_fn(|i| a[0][i] * b[0][c] + a[1][i] * b[1][c] + a[2][i] * b[2][c])
            }),
        }
    }

    /// Lane-wise `self * s`.
    #[inline]
    pub fn scale(&self, s: f32x4) -> Self {
        Self {
            cols: std::array::from_fn(|j| std::array::from_fn(|i| self.cols[j][i] * s)),
        }
    }

    /// Lane-wise `self + diag(d, d, d)`. Like glam's `+ Mat3A::from_diagonal`, the entries off
    /// the diagonal get + 0.
    #[inline]
    pub fn add_diagonal(&self, d: f32x4) -> Self {
        let zero = f32x4::ZERO;
        Self {
            cols: std::array::from_fn(|j| {
                std::array::from_fn(|i| self.cols[j][i] + if i == j { d } else { zero })
            }),
        }
    }
}

/// Lane-wise cross product a × b, in glam's operation order.
#[inline]
pub fn cross(a: Vec3x4, b: Vec3x4) -> Vec3x4 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Lane-wise dot product (a.x b.x + a.y b.y) + a.z b.z, in glam's operation order.
#[inline]
pub fn dot(a: Vec3x4, b: Vec3x4) -> f32x4 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mats() -> [Mat3A; 4] {
        std::array::from_fn(|l| {
            Mat3A::from_cols_array(&std::array::from_fn(|k| {
                ((l * 9 + k) as f32 * 0.37).sin() + if k % 4 == 0 { 1.0 } else { 0.0 }
            }))
        })
    }

    #[test]
    fn lanes_round_trip_and_match_glam_bit_for_bit() {
        let m = mats();
        let x4 = Mat3x4::from_lanes(&m);
        let det = x4.determinant().to_array();
        let prod = x4
            .sub(&Mat3x4::from_lanes(&mats().map(|a| a * 0.5)))
            .mul_transpose(&x4);
        let shifted = x4.scale(f32x4::splat(3.0)).add_diagonal(f32x4::splat(0.25));
        for l in 0..4 {
            assert_eq!(x4.lane(l), m[l]);
            assert_eq!(det[l].to_bits(), m[l].determinant().to_bits());
            let expect = (m[l] - m[l] * 0.5) * m[l].transpose();
            assert_eq!(prod.lane(l).to_cols_array(), expect.to_cols_array());
            let expect = m[l] * 3.0 + Mat3A::from_diagonal(glam::Vec3::splat(0.25));
            assert_eq!(shifted.lane(l).to_cols_array(), expect.to_cols_array());
        }
    }
}
