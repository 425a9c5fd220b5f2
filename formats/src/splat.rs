//! antimatter15 `.splat` (the WebGL viewer's format, github.com/antimatter15/splat): no header,
//! 32 bytes per Gaussian, little endian: position `3 x f32`, scale `3 x f32` (linear, not log),
//! colour `RGBA u8` (alpha = opacity), rotation `4 x u8` w x y z with q = (b - 128) / 128.
//!
//! Converted to the INRIA parameterisation: log scales, `f_dc = (c/255 - 0.5) / C0`
//! (C0 = 0.28209479, the degree-0 SH constant), opacity logit `ln(a / (1 - a))` clamped to
//! ±40 at a = 0 and a = 1 (as PlayCanvas does), SH degree 0.

use std::path::Path;

use super::{FormatError, read_bytes};
use crate::gaussians::GaussianCloud;

/// Bytes per Gaussian in a `.splat` file.
pub const SPLAT_RECORD_BYTES: usize = 32;

/// The degree-0 real SH constant 1 / (2 sqrt(pi)), as the reference decoders use it (f64).
pub const SH_C0: f64 = 0.282_094_791_773_878_14;

/// Opacity logit for an alpha in [0, 1], ±40 at the ends (PlayCanvas' convention).
pub fn alpha_to_logit(a: f64) -> f32 {
    if a <= 0.0 {
        -40.0
    } else if a >= 1.0 {
        40.0
    } else {
        (-(1.0 / a - 1.0).ln()) as f32
    }
}

/// Reads a `.splat` file.
///
/// # Errors
/// [`FormatError::Io`]; [`FormatError::Layout`] when the size is not a multiple of 32 bytes;
/// [`FormatError::NonFinite`] for NaN/infinite positions or scales; a non-positive scale is also
/// reported as non-finite (its log is).
pub fn read_splat(path: impl AsRef<Path>) -> Result<GaussianCloud, FormatError> {
    let path = path.as_ref();
    let bytes = read_bytes(path)?;
    parse_splat(path, &bytes)
}

/// Parses `.splat` bytes; `path` only names the file in errors.
///
/// # Errors
/// As [`read_splat`].
pub fn parse_splat(path: &Path, bytes: &[u8]) -> Result<GaussianCloud, FormatError> {
    if !bytes.len().is_multiple_of(SPLAT_RECORD_BYTES) {
        return Err(FormatError::Layout {
            path: path.to_path_buf(),
            element: "body".into(),
            problem: format!(
                "{} bytes is not a multiple of {SPLAT_RECORD_BYTES} (truncated or not a .splat file)",
                bytes.len()
            ),
        });
    }
    let n = bytes.len() / SPLAT_RECORD_BYTES;
    let mut cloud = GaussianCloud {
        positions: Vec::with_capacity(n),
        sh_dc: Vec::with_capacity(n),
        opacity_logit: Vec::with_capacity(n),
        log_scales: Vec::with_capacity(n),
        rotations_wxyz: Vec::with_capacity(n),
        ..GaussianCloud::default()
    };
    const NAMES: [&str; 6] = ["x", "y", "z", "scale_0", "scale_1", "scale_2"];
    for (row, rec) in bytes.chunks_exact(SPLAT_RECORD_BYTES).enumerate() {
        let mut f = [0f32; 6];
        for (k, v) in f.iter_mut().enumerate() {
            let b = [rec[4 * k], rec[4 * k + 1], rec[4 * k + 2], rec[4 * k + 3]];
            *v = f32::from_le_bytes(b);
            let bad = !v.is_finite() || (k >= 3 && *v <= 0.0);
            if bad {
                return Err(FormatError::NonFinite {
                    path: path.to_path_buf(),
                    element: "body".into(),
                    property: NAMES[k].into(),
                    row,
                    value: f64::from(*v),
                });
            }
        }
        cloud.positions.push([f[0], f[1], f[2]]);
        cloud.log_scales.push([f[3].ln(), f[4].ln(), f[5].ln()]);
        let c = |k: usize| ((f64::from(rec[24 + k]) / 255.0 - 0.5) / SH_C0) as f32;
        cloud.sh_dc.push([c(0), c(1), c(2)]);
        cloud
            .opacity_logit
            .push(alpha_to_logit(f64::from(rec[27]) / 255.0));
        let q = |k: usize| (f32::from(rec[28 + k]) - 128.0) / 128.0;
        cloud.rotations_wxyz.push([q(0), q(1), q(2), q(3)]);
    }
    Ok(cloud)
}
