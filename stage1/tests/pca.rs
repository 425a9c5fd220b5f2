//! PCA reduction: on features that live in a k-dimensional subspace the basis keeps all of the
//! second moment, is orthonormal, and the semantic scores of reduced features against lifted
//! embeddings equal the scores of the full features against the full embeddings.

use splatphys_core::selection::semantic::{
    QueryEmbeddings, pad_reduced_features, positive_probability,
};
use splatphys_stage1::FeatureMap;
use splatphys_stage1::pca::SecondMoment;

const D: usize = 6;

/// Deterministic pseudo-random values in [-1, 1).
fn noise(seed: &mut u64) -> f32 {
    *seed = seed
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(1_442_695_040_888_963_407);
    (*seed >> 40) as f32 / (1u64 << 23) as f32 - 1.0
}

#[test]
fn reduced_features_score_like_full_ones() {
    // Two directions spanning the features.
    let a = [1.0f32, 2.0, 0.0, -1.0, 0.5, 0.0];
    let b = [0.0f32, 1.0, 1.0, 1.0, -2.0, 0.5];
    let mut seed = 7;
    let pixels: Vec<f32> = (0..500)
        .flat_map(|_| {
            let (s, t) = (noise(&mut seed), noise(&mut seed));
            (0..D).map(move |i| s * a[i] + t * b[i])
        })
        .collect();
    let map = FeatureMap {
        height: 20,
        width: 25,
        dim: D,
        data: pixels.clone(),
    };
    let mut m = SecondMoment::new(D);
    assert!(m.add(&map, 1));
    let (basis, kept) = m.basis(2);
    assert_eq!(basis.len(), 2 * D);
    assert!((kept - 1.0).abs() < 1e-6, "kept {kept}");
    for i in 0..2 {
        for j in 0..2 {
            let dot: f32 = (0..D).map(|c| basis[i * D + c] * basis[j * D + c]).sum();
            let want = if i == j { 1.0 } else { 0.0 };
            assert!((dot - want).abs() < 1e-5, "B Bᵀ[{i}][{j}] = {dot}");
        }
    }

    let mut reduced = map.clone();
    reduced.project(&basis, 2);
    assert_eq!(reduced.dim, 2);
    let q = QueryEmbeddings {
        positive: vec![1.0, 0.5, -0.2, 0.3, 0.9, -1.0],
        canonical: vec![vec![0.2; D], vec![-0.1, 0.4, 0.4, 0.0, 0.3, 0.2]],
        negatives: vec![vec![0.0, 1.0, 1.0, 1.0, -2.0, 0.7]],
    };
    let full = positive_probability(&pixels, D, &q, 0.05).unwrap();
    let lifted = q.reduced("basis.npy", &basis, D).unwrap();
    let (padded, k1) = pad_reduced_features(&reduced.data, 2);
    assert_eq!(k1, 3);
    let small = positive_probability(&padded, k1, &lifted, 0.05).unwrap();
    for (i, (x, y)) in full.iter().zip(&small).enumerate() {
        assert!((x - y).abs() < 1e-4, "pixel {i}: {x} vs {y}");
    }
    let err = q
        .reduced("basis.npy", &basis[..5], D)
        .unwrap_err()
        .to_string();
    assert!(err.contains("basis.npy"), "{err}");
}
