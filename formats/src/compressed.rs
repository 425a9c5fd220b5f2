//! SuperSplat / PlayCanvas compressed PLY (PlayCanvas engine,
//! `src/scene/gsplat/gsplat-compressed-data.js`): a `chunk` element with per-256-Gaussian
//! ranges `min_x min_y min_z max_x max_y max_z min_scale_x.. max_scale_z` (and optionally
//! `min_r min_g min_b max_r max_g max_b`), a `vertex` element of `uint packed_position
//! packed_rotation packed_scale packed_color`, and an optional `sh` element of `uchar f_rest_*`.
//!
//! Decoding, computed in f64 and stored as f32 like the reference:
//! - position and log scale: 11/10/11-bit unorms (bits 21.., 11.., 0..) lerped in the chunk range;
//! - rotation: 2-bit index of the largest component of (w, x, y, z), then the other three in
//!   that order as 10-bit values `(u - 0.5) * sqrt(2)`; the largest is `sqrt(1 - a² - b² - c²)`;
//! - colour: 8-bit RGBA (bits 24, 16, 8, 0), lerped in the chunk colour range when present;
//!   `f_dc = (c - 0.5) / C0`; opacity logit `-ln(1/a - 1)`, ±40 at a = 0, 1;
//! - SH: `f_rest_j = v * 8/255 - 4`.

use std::path::Path;

use super::splat::{SH_C0, alpha_to_logit};
use super::{FormatError, read_bytes};
use crate::gaussians::GaussianCloud;
use crate::ply::parse_raw;

/// Gaussians per chunk.
pub const CHUNK_SIZE: usize = 256;

const CHUNK_PROPS: [&str; 12] = [
    "min_x",
    "min_y",
    "min_z",
    "max_x",
    "max_y",
    "max_z",
    "min_scale_x",
    "min_scale_y",
    "min_scale_z",
    "max_scale_x",
    "max_scale_y",
    "max_scale_z",
];
const COLOR_PROPS: [&str; 6] = ["min_r", "min_g", "min_b", "max_r", "max_g", "max_b"];
const VERTEX_PROPS: [&str; 4] = [
    "packed_position",
    "packed_rotation",
    "packed_scale",
    "packed_color",
];

/// Reads a compressed PLY file.
///
/// # Errors
/// As [`crate::ply::read_ply`], plus [`FormatError::Layout`] when the chunk count is
/// not `ceil(vertices / 256)` or the `sh` element's count differs from the vertex count.
pub fn read_compressed_ply(path: impl AsRef<Path>) -> Result<GaussianCloud, FormatError> {
    let path = path.as_ref();
    let bytes = read_bytes(path)?;
    parse_compressed_ply(path, &bytes)
}

fn unorm(value: u32, bits: u32) -> f64 {
    let t = (1u32 << bits) - 1;
    f64::from(value & t) / f64::from(t)
}

fn unpack_111011(v: u32) -> [f64; 3] {
    [unorm(v >> 21, 11), unorm(v >> 11, 10), unorm(v, 11)]
}

fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a * (1.0 - t) + b * t
}

/// Decodes a 2+10+10+10 packed quaternion into `[w, x, y, z]`.
pub fn unpack_rotation(v: u32) -> [f32; 4] {
    let norm = 1.0 / (std::f64::consts::SQRT_2 * 0.5);
    let a = (unorm(v >> 20, 10) - 0.5) * norm;
    let b = (unorm(v >> 10, 10) - 0.5) * norm;
    let c = (unorm(v, 10) - 0.5) * norm;
    let m = (1.0 - (a * a + b * b + c * c)).max(0.0).sqrt();
    let q = match v >> 30 {
        0 => [m, a, b, c],
        1 => [a, m, b, c],
        2 => [a, b, m, c],
        _ => [a, b, c, m],
    };
    q.map(|x| x as f32)
}

/// Parses compressed PLY `bytes`; `path` only names the file in errors.
///
/// # Errors
/// As [`read_compressed_ply`].
pub fn parse_compressed_ply(path: &Path, bytes: &[u8]) -> Result<GaussianCloud, FormatError> {
    let raw = parse_raw(path, bytes, &["chunk", "vertex", "sh"])?;
    let chunk = raw.element(path, "chunk")?;
    let vertex = raw.element(path, "vertex")?;
    let mut cc = [0usize; 12];
    for (slot, name) in cc.iter_mut().zip(CHUNK_PROPS) {
        *slot = chunk.require(path, name)?;
    }
    let color_cols: Option<Vec<usize>> = COLOR_PROPS.iter().map(|n| chunk.col(n)).collect();
    let mut vc = [0usize; 4];
    for (slot, name) in vc.iter_mut().zip(VERTEX_PROPS) {
        *slot = vertex.require(path, name)?;
    }
    let n = vertex.rows.len();
    if chunk.rows.len() != n.div_ceil(CHUNK_SIZE) {
        return Err(FormatError::Layout {
            path: path.to_path_buf(),
            element: "chunk".into(),
            problem: format!(
                "{} chunks for {n} vertices (expected {})",
                chunk.rows.len(),
                n.div_ceil(CHUNK_SIZE)
            ),
        });
    }
    for (row_idx, row) in chunk.rows.iter().enumerate() {
        if let Some(c) = row.iter().position(|x| !x.is_finite()) {
            return Err(FormatError::NonFinite {
                path: path.to_path_buf(),
                element: "chunk".into(),
                property: chunk.props[c].0.clone(),
                row: row_idx,
                value: row[c],
            });
        }
    }
    let sh = raw.elements.iter().find(|e| e.name == "sh");
    let mut sh_cols = Vec::new();
    if let Some(sh) = sh {
        if sh.rows.len() != n {
            return Err(FormatError::Layout {
                path: path.to_path_buf(),
                element: "sh".into(),
                problem: format!("{} rows for {n} vertices", sh.rows.len()),
            });
        }
        let count = sh
            .props
            .iter()
            .filter(|(p, _)| p.starts_with("f_rest_"))
            .count();
        if ![0, 9, 24, 45].contains(&count) {
            return Err(FormatError::BadShCount {
                path: path.to_path_buf(),
                count,
            });
        }
        for j in 0..count {
            sh_cols.push(sh.require(path, &format!("f_rest_{j}"))?);
        }
    }
    let n_rest = sh_cols.len();
    let mut cloud = GaussianCloud::with_capacity(n, n_rest);
    for (i, row) in vertex.rows.iter().enumerate() {
        let ch = &chunk.rows[i / CHUNK_SIZE];
        let c = |k: usize| ch[cc[k]];
        // Packed values are u32 by the format; a wider or signed type is truncated to 32 bits.
        let packed = |k: usize| row[vc[k]] as i64 as u32;
        let p = unpack_111011(packed(0));
        cloud.positions.push([
            lerp(c(0), c(3), p[0]) as f32,
            lerp(c(1), c(4), p[1]) as f32,
            lerp(c(2), c(5), p[2]) as f32,
        ]);
        cloud.rotations_wxyz.push(unpack_rotation(packed(1)));
        let s = unpack_111011(packed(2));
        cloud.log_scales.push([
            lerp(c(6), c(9), s[0]) as f32,
            lerp(c(7), c(10), s[1]) as f32,
            lerp(c(8), c(11), s[2]) as f32,
        ]);
        let col = packed(3);
        let mut rgba = [
            unorm(col >> 24, 8),
            unorm(col >> 16, 8),
            unorm(col >> 8, 8),
            unorm(col, 8),
        ];
        if let Some(cols) = &color_cols {
            for k in 0..3 {
                rgba[k] = lerp(ch[cols[k]], ch[cols[k + 3]], rgba[k]);
            }
        }
        cloud.sh_dc.push([
            ((rgba[0] - 0.5) / SH_C0) as f32,
            ((rgba[1] - 0.5) / SH_C0) as f32,
            ((rgba[2] - 0.5) / SH_C0) as f32,
        ]);
        cloud.opacity_logit.push(alpha_to_logit(rgba[3]));
        if let Some(sh) = sh {
            let srow = &sh.rows[i];
            cloud.sh_rest.extend(
                sh_cols
                    .iter()
                    .map(|&k| (srow[k] * (8.0 / 255.0) - 4.0) as f32),
            );
        }
    }
    cloud.sh_degree = crate::ply::effective_sh_degree(&cloud.sh_rest, n_rest);
    if let Some(i) = cloud
        .positions
        .iter()
        .position(|p| p.iter().any(|x| !x.is_finite()))
    {
        return Err(FormatError::NonFinite {
            path: path.to_path_buf(),
            element: "vertex".into(),
            property: "packed_position".into(),
            row: i,
            value: f64::NAN,
        });
    }
    Ok(cloud)
}
