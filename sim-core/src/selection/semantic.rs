//! Semantic selection by text query, Feature Splatting's rule (Qiu et al. 2024, §3.3, after
//! LERF's relevancy score): each Gaussian's feature f is compared with phrase embeddings e by
//! cosine similarity divided by a temperature τ (0.05), a softmax runs over the canonical
//! phrases ("object", "things"), optional negatives and the positive query, and the positive's
//! probability is kept; Gaussians above a threshold (0.6) are candidates. Clean-up: DBSCAN keeps
//! the largest cluster, then kNN infill adds Gaussians most of whose k nearest neighbours are
//! selected. No language model runs here: embeddings come from a file (JSON `{phrase: [D floats]}`
//! or `.npy` `[P][D]` with rows positive, "object", "things", negatives...).

use std::collections::BTreeMap;
use std::num::NonZero;
use std::path::Path;

use kiddo::SquaredEuclidean;

use super::SelectionError;
use super::cluster::{build_tree, clusters_from_labels, dbscan};

/// The canonical phrases of Feature Splatting / LERF.
pub const CANONICAL: [&str; 2] = ["object", "things"];

/// Parameters of [`select`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SemanticParams {
    /// Softmax temperature τ. Default 0.05.
    pub temperature: f32,
    /// Positive-probability threshold. Default 0.6.
    pub threshold: f32,
    /// DBSCAN radius, m. Default 0.02.
    pub eps_m: f32,
    /// DBSCAN min samples (the point included). Default 5.
    pub min_samples: usize,
    /// kNN infill neighbour count (0 disables). Default 8.
    pub knn: usize,
}

impl Default for SemanticParams {
    fn default() -> Self {
        Self {
            temperature: 0.05,
            threshold: 0.6,
            eps_m: 0.02,
            min_samples: 5,
            knn: 8,
        }
    }
}

/// Phrase embeddings: the positive, the canonical phrases and the negatives, each `[D]`.
#[derive(Debug, Clone, PartialEq)]
pub struct QueryEmbeddings {
    /// The query phrase's embedding.
    pub positive: Vec<f32>,
    /// Canonical phrases' embeddings.
    pub canonical: Vec<Vec<f32>>,
    /// Negative phrases' embeddings.
    pub negatives: Vec<Vec<f32>>,
}

impl QueryEmbeddings {
    /// Picks `query`, [`CANONICAL`] and `negatives` (all other phrases when `None`) from a
    /// phrase → embedding map.
    ///
    /// # Errors
    /// [`SelectionError::MissingPhrase`] when a named phrase is absent.
    pub fn from_map(
        file: &str,
        map: &BTreeMap<String, Vec<f32>>,
        query: &str,
        negatives: Option<&[String]>,
    ) -> Result<Self, SelectionError> {
        let get = |p: &str| {
            map.get(p)
                .cloned()
                .ok_or_else(|| SelectionError::MissingPhrase {
                    file: file.to_string(),
                    phrase: p.to_string(),
                    available: map.keys().cloned().collect(),
                })
        };
        let positive = get(query)?;
        let canonical = CANONICAL
            .iter()
            .map(|c| get(c))
            .collect::<Result<Vec<_>, _>>()?;
        let negatives = match negatives {
            Some(list) => list.iter().map(|p| get(p)).collect::<Result<Vec<_>, _>>()?,
            None => map
                .iter()
                .filter(|(k, _)| k.as_str() != query && !CANONICAL.contains(&k.as_str()))
                .map(|(_, v)| v.clone())
                .collect(),
        };
        Ok(Self {
            positive,
            canonical,
            negatives,
        })
    }

    /// Reads embeddings from JSON (`{phrase: [floats]}`) or `.npy` (`[P][D]`, rows: positive,
    /// "object", "things", then negatives).
    ///
    /// # Errors
    /// [`SelectionError::File`] for unreadable files, [`SelectionError::MissingPhrase`].
    pub fn load(
        path: &Path,
        query: &str,
        negatives: Option<&[String]>,
    ) -> Result<Self, SelectionError> {
        let file = path.display().to_string();
        let ferr = |message: String| SelectionError::File {
            file: file.clone(),
            message,
        };
        if path.extension().is_some_and(|e| e == "npy") {
            let (rows, dim) = read_npy_matrix(path)?;
            if rows.len() < 3 * dim || dim == 0 {
                return Err(ferr(format!(
                    "need at least 3 rows (positive, object, things), got {}",
                    rows.len() / dim.max(1)
                )));
            }
            let row = |r: usize| rows[r * dim..(r + 1) * dim].to_vec();
            let n = rows.len() / dim;
            return Ok(Self {
                positive: row(0),
                canonical: vec![row(1), row(2)],
                negatives: (3..n).map(row).collect(),
            });
        }
        let text = std::fs::read_to_string(path).map_err(|e| ferr(e.to_string()))?;
        let map: BTreeMap<String, Vec<f32>> =
            serde_json::from_str(&text).map_err(|e| ferr(e.to_string()))?;
        Self::from_map(&file, &map, query, negatives)
    }
}

impl QueryEmbeddings {
    /// The embeddings for features reduced by a PCA basis `[k][D]` (row-major, `basis.len() =
    /// k · full_dim`): each D-dimensional e becomes `[B e, sqrt(|e|² − |B e|²)]` (k + 1 values).
    /// With features f' = B f padded by a zero ([`pad_reduced_features`]), cos(f'', e'') =
    /// f'·(B e) / (|f'| |e|), which is exactly the cosine between the full embedding and the
    /// reduced feature lifted back, Bᵀ f' (B has orthonormal rows), so the softmax sees the same
    /// scores as without the reduction for features inside the subspace.
    ///
    /// # Errors
    /// [`SelectionError::Shape`] when an embedding is not D long or the basis is not `[k][D]`.
    pub fn reduced(
        &self,
        file: &str,
        basis: &[f32],
        full_dim: usize,
    ) -> Result<Self, SelectionError> {
        if full_dim == 0 || basis.is_empty() || !basis.len().is_multiple_of(full_dim) {
            return Err(SelectionError::Shape {
                what: format!("{file}: PCA basis [k][D]"),
                expected: full_dim,
                found: basis.len(),
            });
        }
        let lift = |e: &Vec<f32>| -> Result<Vec<f32>, SelectionError> {
            if e.len() != full_dim {
                return Err(SelectionError::Shape {
                    what: format!("embedding dimension against {file}"),
                    expected: full_dim,
                    found: e.len(),
                });
            }
            let mut out: Vec<f32> = basis
                .chunks_exact(full_dim)
                .map(|b| b.iter().zip(e).map(|(x, y)| x * y).sum())
                .collect();
            let full: f32 = e.iter().map(|v| v * v).sum();
            let kept: f32 = out.iter().map(|v| v * v).sum();
            out.push((full - kept).max(0.0).sqrt());
            Ok(out)
        };
        Ok(Self {
            positive: lift(&self.positive)?,
            canonical: self.canonical.iter().map(lift).collect::<Result<_, _>>()?,
            negatives: self.negatives.iter().map(lift).collect::<Result<_, _>>()?,
        })
    }
}

/// Appends a zero channel to reduced features `[N][k]` (see [`QueryEmbeddings::reduced`]);
/// returns the padded features and k + 1.
pub fn pad_reduced_features(features: &[f32], k: usize) -> (Vec<f32>, usize) {
    let mut out = Vec::with_capacity(features.len() / k.max(1) * (k + 1));
    for f in features.chunks_exact(k.max(1)) {
        out.extend_from_slice(f);
        out.push(0.0);
    }
    (out, k + 1)
}

/// Reads a 2-D `.npy` of float32 or float16 as `(row-major values, columns)`.
///
/// # Errors
/// [`SelectionError::File`] for unreadable files, other dtypes or shapes.
pub fn read_npy_matrix(path: &Path) -> Result<(Vec<f32>, usize), SelectionError> {
    let ferr = |message: String| SelectionError::File {
        file: path.display().to_string(),
        message,
    };
    let npy = crate::formats::npy::read_npy_f32(path).map_err(ferr)?;
    if npy.shape.len() != 2 {
        return Err(ferr(format!(
            "expected a 2-D array [rows][D], shape {:?}",
            npy.shape
        )));
    }
    Ok((npy.values, npy.shape[1]))
}

fn cosine(a: &[f32], b: &[f32]) -> f32 {
    let (mut ab, mut aa, mut bb) = (0f32, 0f32, 0f32);
    for (x, y) in a.iter().zip(b) {
        ab += x * y;
        aa += x * x;
        bb += y * y;
    }
    let d = (aa * bb).sqrt();
    if d > 0.0 { ab / d } else { 0.0 }
}

/// Positive probability `[N]` for row-major features `[N][D]`.
///
/// # Errors
/// [`SelectionError::Shape`] when a dimension disagrees.
pub fn positive_probability(
    features: &[f32],
    dim: usize,
    q: &QueryEmbeddings,
    temperature: f32,
) -> Result<Vec<f32>, SelectionError> {
    let shape = |what: &str, expected, found| SelectionError::Shape {
        what: what.to_string(),
        expected,
        found,
    };
    if dim == 0 || !features.len().is_multiple_of(dim) {
        return Err(shape(
            "features length (multiple of D)",
            dim,
            features.len(),
        ));
    }
    for e in std::iter::once(&q.positive)
        .chain(&q.canonical)
        .chain(&q.negatives)
    {
        if e.len() != dim {
            return Err(shape("embedding dimension", dim, e.len()));
        }
    }
    let t = temperature.max(1e-6);
    Ok(features
        .chunks_exact(dim)
        .map(|f| {
            let pos = cosine(f, &q.positive) / t;
            let others: Vec<f32> = q
                .canonical
                .iter()
                .chain(&q.negatives)
                .map(|e| cosine(f, e) / t)
                .collect();
            let m = others.iter().copied().fold(pos, f32::max);
            let num = (pos - m).exp();
            num / (num + others.iter().map(|o| (o - m).exp()).sum::<f32>())
        })
        .collect())
}

/// Selected indices (ascending) into `points` `[N][3]` given probabilities `[N]`: threshold,
/// largest DBSCAN cluster, kNN infill (see the module docs).
///
/// # Errors
/// [`SelectionError::Empty`] when nothing passes the threshold or no cluster forms.
pub fn select(
    points: &[[f32; 3]],
    prob: &[f32],
    params: &SemanticParams,
) -> Result<Vec<usize>, SelectionError> {
    let passed: Vec<usize> = (0..points.len())
        .filter(|&i| prob.get(i).is_some_and(|&p| p > params.threshold))
        .collect();
    if passed.is_empty() {
        return Err(SelectionError::Empty {
            why: format!("no Gaussian above probability {}", params.threshold),
        });
    }
    let sub: Vec<[f32; 3]> = passed.iter().map(|&i| points[i]).collect();
    let clusters = clusters_from_labels(&dbscan(&sub, params.eps_m, params.min_samples), 1);
    let Some(largest) = clusters.first() else {
        return Err(SelectionError::Empty {
            why: "no DBSCAN cluster among the Gaussians above threshold".into(),
        });
    };
    let mut selected = vec![false; points.len()];
    for &j in largest {
        selected[passed[j]] = true;
    }
    if let Some(k) = NonZero::new(params.knn) {
        let tree = build_tree(points);
        let base = selected.clone();
        for i in 0..points.len() {
            if base[i] {
                continue;
            }
            let nn = tree
                .nearest_n::<SquaredEuclidean>(&points[i], NonZero::new(k.get() + 1).unwrap_or(k));
            let (hits, total) = nn
                .iter()
                .filter(|n| n.item as usize != i)
                .fold((0, 0), |(h, t), n| {
                    (h + usize::from(base[n.item as usize]), t + 1)
                });
            if total > 0 && 2 * hits > total {
                selected[i] = true;
            }
        }
    }
    Ok((0..points.len()).filter(|&i| selected[i]).collect())
}
