//! Reduction of feature channels by principal component analysis, uncentred: the basis is the
//! top-k eigenvectors of the second-moment matrix M = Σ_p F(p) F(p)ᵀ of feature-map pixels, so
//! the reduction f' = B f is an orthogonal projection onto the subspace that carries most of the
//! features' energy and dot products with text embeddings survive it (f·e = f'·(B e) for f in
//! the subspace; see `splatphys_core::selection::semantic::QueryEmbeddings::reduced` for how the
//! selection compares reduced features with full embeddings). Feature Splatting distils 32
//! channels (Qiu et al. 2024, §3.2).
//!
//! The uplift is linear in F, so reducing every map before the uplift gives the same result as
//! reducing the uplifted features, at a fraction of the cost.

use nalgebra::{DMatrix, SymmetricEigen};

use crate::feature_map::FeatureMap;

/// Running second-moment matrix over sampled pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct SecondMoment {
    dim: usize,
    /// Upper triangle used; `[D][D]`.
    m: Vec<f64>,
    /// Pixels added.
    pub samples: u64,
}

impl SecondMoment {
    /// Empty sums for `dim` channels.
    pub fn new(dim: usize) -> Self {
        Self {
            dim,
            m: vec![0.0; dim * dim],
            samples: 0,
        }
    }

    /// Channels D.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Adds every `stride`-th pixel of `map` (`map.dim` must equal `self.dim()`; other maps are
    /// ignored and `false` is returned).
    pub fn add(&mut self, map: &FeatureMap, stride: usize) -> bool {
        if map.dim != self.dim {
            return false;
        }
        let d = self.dim;
        for f in map.data.chunks_exact(d).step_by(stride.max(1)) {
            for i in 0..d {
                let fi = f64::from(f[i]);
                if fi == 0.0 {
                    continue;
                }
                let row = &mut self.m[i * d..(i + 1) * d];
                for j in i..d {
                    row[j] += fi * f64::from(f[j]);
                }
            }
            self.samples += 1;
        }
        true
    }

    /// The top-`k` principal directions as rows `[k][D]` (k capped at D), largest eigenvalue
    /// first, each signed so that its largest-magnitude component is positive (deterministic),
    /// and the fraction of the second moment they keep (Σ top-k eigenvalues / trace).
    pub fn basis(&self, k: usize) -> (Vec<f32>, f64) {
        let d = self.dim;
        let k = k.min(d);
        let full = DMatrix::from_fn(d, d, |i, j| {
            let (a, b) = if i <= j { (i, j) } else { (j, i) };
            self.m[a * d + b]
        });
        let eig = SymmetricEigen::new(full);
        let mut order: Vec<usize> = (0..d).collect();
        order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
        let trace: f64 = eig.eigenvalues.iter().map(|v| v.max(0.0)).sum();
        let kept: f64 = order[..k]
            .iter()
            .map(|&c| eig.eigenvalues[c].max(0.0))
            .sum();
        let mut basis = Vec::with_capacity(k * d);
        for &c in &order[..k] {
            let v = eig.eigenvectors.column(c);
            let big = v
                .iter()
                .copied()
                .fold(0.0f64, |m, x| if x.abs() > m.abs() { x } else { m });
            let sign = if big < 0.0 { -1.0 } else { 1.0 };
            basis.extend(v.iter().map(|x| (sign * x) as f32));
        }
        (basis, if trace > 0.0 { kept / trace } else { 0.0 })
    }
}
