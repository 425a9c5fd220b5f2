//! Stage 1 of the paper ("Semantic Aware Physics-Based Object Interaction in 3DGS"): which
//! Gaussians form which object. Selections produce index lists into a point set; the scene
//! builder composes them (source ∩ box ∩ opacity, then automatic or semantic) and gives every
//! Gaussian not claimed by an object to the static background.
//!
//! - [`geometric`]: boxes, spheres, opacity thresholds;
//! - [`auto`]: RANSAC support plane + Euclidean clustering of what stands on it;
//! - [`semantic`]: Feature Splatting's text-query rule on per-Gaussian features;
//! - [`cluster`]: the kd-tree (kiddo) clustering both of those use.

pub mod auto;
pub mod cluster;
pub mod geometric;
pub mod semantic;

/// Why a selection failed.
#[derive(Debug, thiserror::Error)]
pub enum SelectionError {
    /// `auto = k` asked for a cluster that does not exist.
    #[error("auto = {k}: only {found} objects found standing on the support plane")]
    NoSuchCluster {
        /// The index asked for (0 = largest).
        k: usize,
        /// Clusters found.
        found: usize,
    },
    /// Feature rows and Gaussians disagree, or embeddings have the wrong dimension.
    #[error("{what}: expected {expected}, found {found}")]
    Shape {
        /// Which array.
        what: String,
        /// Expected size.
        expected: usize,
        /// Found size.
        found: usize,
    },
    /// A phrase named by the query is not in the embeddings file.
    #[error("embeddings file {file}: no phrase {phrase:?} (has {available:?})")]
    MissingPhrase {
        /// The embeddings file.
        file: String,
        /// The phrase looked for.
        phrase: String,
        /// Phrases the file has.
        available: Vec<String>,
    },
    /// A features or embeddings file could not be read or parsed.
    #[error("{file}: {message}")]
    File {
        /// The file.
        file: String,
        /// What went wrong.
        message: String,
    },
    /// Nothing was selected.
    #[error("selection is empty: {why}")]
    Empty {
        /// Which step left nothing.
        why: String,
    },
}
