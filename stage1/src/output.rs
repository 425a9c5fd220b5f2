//! Writing uplifted features: as PLY properties `feat_0..feat_{D-1}` plus `uplift_weight` (the
//! summed blending weight, so a user can filter weakly seen Gaussians) beside the scene's own
//! properties, or as a sidecar `.npy` `[N][D]` float32 whose rows follow the PLY's vertices;
//! and `.npy` matrices such as the PCA basis `[k][D]`.

use std::io::Write;
use std::path::{Path, PathBuf};

use npyz::WriterBuilder;
use splatphys_core::formats::ply::write_ply;
use splatphys_core::gaussians::GaussianCloud;

use crate::uplift::Uplifted;

/// The PLY property holding the summed blending weight.
pub const WEIGHT_PROPERTY: &str = "uplift_weight";

/// Why writing failed.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The file could not be written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The PLY writer refused the cloud.
    #[error(transparent)]
    Ply(#[from] splatphys_core::formats::FormatError),
}

/// Replaces any `feat_*` and [`WEIGHT_PROPERTY`] properties of `cloud` by the uplifted ones.
pub fn attach_features(cloud: &mut GaussianCloud, uplifted: &Uplifted) {
    cloud
        .extra
        .retain(|(name, _)| !(name.starts_with("feat_") || name == WEIGHT_PROPERTY));
    let d = uplifted.dim;
    for c in 0..d {
        let column = uplifted
            .features
            .chunks_exact(d)
            .map(|f| f[c])
            .collect::<Vec<f32>>();
        cloud.extra.push((format!("feat_{c}"), column));
    }
    cloud
        .extra
        .push((WEIGHT_PROPERTY.to_string(), uplifted.weights.clone()));
}

/// Writes `cloud` with the uplifted features attached to `path` (binary PLY).
///
/// # Errors
/// [`OutputError`] when the file cannot be written.
pub fn write_feature_ply(
    path: &Path,
    cloud: &GaussianCloud,
    uplifted: &Uplifted,
    comments: &[String],
) -> Result<(), OutputError> {
    let mut out = cloud.clone();
    attach_features(&mut out, uplifted);
    write_ply(path, &out, comments)?;
    Ok(())
}

/// Writes a row-major float32 matrix `[rows][cols]` as `.npy`.
///
/// # Errors
/// [`OutputError::Io`] when the file cannot be written.
pub fn write_npy_matrix(path: &Path, values: &[f32], cols: usize) -> Result<(), OutputError> {
    let io = |source: std::io::Error| OutputError::Io {
        path: path.to_path_buf(),
        source,
    };
    let rows = values.len().checked_div(cols).unwrap_or(0);
    let file = std::fs::File::create(path).map_err(io)?;
    let mut buf = std::io::BufWriter::new(file);
    let mut w = npyz::WriteOptions::new()
        .default_dtype()
        .shape(&[rows as u64, cols as u64])
        .writer(&mut buf)
        .begin_nd()
        .map_err(io)?;
    w.extend(values.iter().copied()).map_err(io)?;
    w.finish().map_err(io)?;
    buf.flush().map_err(io)
}
