//! The normal impulses of one contact patch solved as a block: one exact step on the patch's
//! k×k effective-mass matrix K instead of k one-point steps.
//!
//! Sequential impulses on a patch (one point after another) never reach a state where every
//! point of a resting face is satisfied at once: each point's impulse tilts the body a little,
//! the next point answers, and the face keeps a small spin that friction below the COM turns
//! into a lean. A column of boxes then rocks slowly however many iterations it gets. Box2D solves
//! its two-point manifolds as a block for this reason (Catto, `b2SolveVelocityConstraints`, the
//! 2×2 LCP by enumeration); a patch here has up to 8 points, so enumeration is out.
//!
//! Instead: with the residual r = v_target − v_n over the patch's points, the step
//! Δλ = K⁺ r (K⁺ the pseudo-inverse) makes every point's normal velocity reach its target in one
//! move, with the smallest change of impulses (the load split among more than three points on a
//! face is indeterminate: K has rank 3 for a flat face between rigid bodies, and the part of λ
//! in K's null space is left as it was). The caller takes the step only when every accumulated
//! impulse stays ≥ 0, that is, when all the points stay in contact: then, when a motion of the
//! bodies meets all the targets, the patch is at a solution of its own complementarity problem.
//! Otherwise it falls back to point-by-point steps with clamping, which find the points that
//! lift off.
//!
//! K_ij is the normal velocity at point i from a unit normal impulse at point j, summed over
//! both bodies: 1/m n_i·n_j + (r_i × n_i)·I⁻¹(r_j × n_j).

use nalgebra::{DMatrix, SMatrix, SymmetricEigen};

/// Most points a block holds: the manifold's largest size.
pub const MAX_BLOCK: usize = super::manifold::MAX_POINTS;

/// Eigenvalues of K below this fraction of its largest are its null space: a flat face's K has
/// exactly 3 non-zero eigenvalues (translation along n and the two tilts) and the rest at
/// round-off (1e-16 of the largest).
pub const NULL_TOLERANCE: f64 = 1e-9;

/// A block needs every other eigenvalue of K within this fraction of its largest. A box on a box
/// measures 1 : 0.97 : 0.71. Points that lie close together on a large body (a few points of a
/// level set on captured ground under a robot) make an eigenvalue small but not zero: inverting
/// it trades large impulses between the points for a tiny change of velocity, and dropping it
/// leaves that direction unsolved while the block stands in for the point steps. Such patches
/// keep the point-by-point steps; with them, the captured robot of `scenes/playbot_drop.toml`
/// comes to rest, and with a block it rocked on its rock.
pub const CONDITION: f64 = 1e-2;

type Square = SMatrix<f64, MAX_BLOCK, MAX_BLOCK>;

/// The pseudo-inverse of one patch's effective-mass matrix.
#[derive(Debug, Clone, PartialEq)]
pub struct NormalBlock {
    len: usize,
    k_pinv: Square,
}

impl NormalBlock {
    /// From the effective-mass matrix `k` of `len` points (row-major, `len × len`, symmetric
    /// positive semi-definite, 1/kg). `None` for fewer than 2 or more than [`MAX_BLOCK`]
    /// points, a matrix that is zero or not finite, or one that is ill-conditioned (an
    /// eigenvalue between [`NULL_TOLERANCE`] and [`CONDITION`] of the largest).
    pub fn new(k: &[f64], len: usize) -> Option<Self> {
        if !(2..=MAX_BLOCK).contains(&len) || k.len() != len * len {
            return None;
        }
        if k.iter().any(|v| !v.is_finite()) {
            return None;
        }
        // The decomposition of the len × len matrix itself (a padded 8 × 8 one costs several
        // times as much for the usual 4 points).
        let m = DMatrix::from_fn(len, len, |i, j| 0.5 * (k[i * len + j] + k[j * len + i]));
        let eigen = SymmetricEigen::new(m);
        let largest = eigen.eigenvalues.amax();
        if !(largest > 0.0 && largest.is_finite()) {
            return None;
        }
        let mut inverse = eigen.eigenvalues;
        for e in inverse.iter_mut() {
            if *e <= NULL_TOLERANCE * largest {
                *e = 0.0;
            } else if *e < CONDITION * largest {
                return None;
            } else {
                *e = 1.0 / *e;
            }
        }
        let v = &eigen.eigenvectors;
        let pinv = v * DMatrix::from_diagonal(&inverse) * v.transpose();
        let mut k_pinv = Square::zeros();
        k_pinv.view_mut((0, 0), (len, len)).copy_from(&pinv);
        Some(Self { len, k_pinv })
    }

    /// The impulse step Δλ = K⁺ `residual` (N s), one entry per point: the smallest step that
    /// meets the targets when a motion of the bodies can meet them all, and the least-squares
    /// step when it cannot (speculative targets at gaps that differ a little).
    pub fn step(&self, residual: &[f64]) -> [f64; MAX_BLOCK] {
        let n = self.len;
        let mut out = [0.0; MAX_BLOCK];
        for (i, o) in out.iter_mut().enumerate().take(n) {
            *o = (0..n).map(|j| self.k_pinv[(i, j)] * residual[j]).sum();
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// K = J Jᵀ for a rank-deficient J (4 points, rank 3: a flat face's normal rows, the tilt
    /// columns scaled as a 10 cm box's arm times √I⁻¹).
    fn flat_face() -> (Vec<f64>, usize) {
        let rows = [
            [1.0, 1.2, 1.2],
            [1.0, -1.2, 1.2],
            [1.0, -1.2, -1.2],
            [1.0, 1.2, -1.2],
        ];
        let mut k = vec![0.0; 16];
        for i in 0..4 {
            for j in 0..4 {
                k[i * 4 + j] = (0..3).map(|c| rows[i][c] * rows[j][c]).sum();
            }
        }
        (k, 4)
    }

    #[test]
    fn a_step_meets_every_target_reachable_and_changes_nothing_else() {
        let (k, n) = flat_face();
        let block = NormalBlock::new(&k, n).expect("block");
        // A residual in K's range (an affine field over the face) is met exactly.
        let residual = [0.3, 0.1, -0.2, 0.0];
        let step = block.step(&residual);
        for i in 0..n {
            let reached: f64 = (0..n).map(|j| k[i * n + j] * step[j]).sum();
            assert!((reached - residual[i]).abs() < 1e-9, "point {i}: {reached}");
        }
        // The step has no part in K's null space (1, -1, 1, -1): the smallest change.
        let null: f64 = step[..n]
            .iter()
            .zip([1.0, -1.0, 1.0, -1.0])
            .map(|(s, v)| s * v)
            .sum();
        assert!(null.abs() < 1e-9, "{null}");
        // A residual in the null space alone (no rigid motion of the face meets it) is no step.
        let step = block.step(&[1.0, -1.0, 1.0, -1.0]);
        assert!(step.iter().all(|s| s.abs() < 1e-9), "{step:?}");
    }

    #[test]
    fn too_few_or_too_many_points_or_bad_numbers_make_no_block() {
        assert!(NormalBlock::new(&[1.0], 1).is_none());
        assert!(NormalBlock::new(&vec![1.0; 81], 9).is_none());
        assert!(NormalBlock::new(&[0.0; 4], 2).is_none());
        assert!(NormalBlock::new(&[1.0, f64::NAN, f64::NAN, 1.0], 2).is_none());
        // Two points whose rows nearly coincide (eigenvalues 2 and 1e-4): ill-conditioned.
        assert!(NormalBlock::new(&[1.0, 0.9999, 0.9999, 1.0], 2).is_none());
        // Exactly dependent rows are a null space, not ill-conditioning.
        assert!(NormalBlock::new(&[1.0, 1.0, 1.0, 1.0], 2).is_some());
    }
}
