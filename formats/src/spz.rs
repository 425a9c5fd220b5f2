//! Niantic SPZ (Scaniverse's format; github.com/nianticlabs/spz, `load-spz.cc`): quantised
//! Gaussians, about a tenth of a PLY's size.
//!
//! File versions 1–3 are one gzip stream holding a 16-byte header (magic `NGSP`, version,
//! count, SH degree, fractional bits, flags, reserved) and the attributes one after another;
//! version 4 is a 32-byte plain header, a table of `(compressed, uncompressed)` u64 sizes and
//! one zstd frame per attribute. Attributes, in order (N Gaussians, D = 3, 8, 15 or 24 SH
//! coefficients per channel for degrees 1–4):
//!
//! - centres: v1 3 × f16; v2+ 3 × 24-bit two's complement, value / 2^fractional_bits;
//! - alpha: u8, opacity = b / 255 (stored here as its logit, ±40 at 0 and 1);
//! - colour: 3 × u8, f_dc = (b / 255 − 0.5) / 0.15;
//! - scales: 3 × u8, log scale = b / 16 − 10;
//! - rotation: v1/v2 3 × u8 x, y, z = b / 127.5 − 1 and w = √(1 − x² − y² − z²); v3/v4 one
//!   u32, "smallest three": bits 31–30 the index of the largest of (x, y, z, w), then the other
//!   three in index order, 10 bits each (sign, 9-bit magnitude of |q| / √½ · 511);
//! - SH: `[D][3]` u8 per Gaussian, coefficient-major with RGB inner, value (b − 128) / 128.
//!
//! The convention is that SPZ stores RUB (x right, y up, z back, OpenGL) and PLY RDF (y down,
//! z forward): the two differ by a half turn about x. [`read_spz`] turns RUB into RDF, so an
//! SPZ and the PLY it came from load alike; [`SpzFrame::AsStored`] keeps the stored values (for
//! files written without that flip, as `splat-transform` does). SH degree 4 is read and
//! truncated to 3.

use std::io::{Read, Write};
use std::path::Path;

use glam::DMat3;

use super::{FormatError, read_bytes};
use crate::gaussians::GaussianCloud;
use crate::splat::alpha_to_logit;

/// `NGSP`, the magic number of every SPZ header (little-endian u32).
pub const SPZ_MAGIC: u32 = 0x5053_474e;
/// The version [`write_spz`] writes: 3 (gzip, smallest-three rotations), which every SPZ reader
/// reads (version 4 needs a 2026 reader).
pub const SPZ_WRITE_VERSION: u32 = 3;
/// The gzip magic bytes that start an SPZ of versions 1–3.
pub const GZIP_MAGIC: [u8; 2] = [0x1f, 0x8b];
/// The largest count a reader accepts (the reference library's bound for version ≤ 3).
pub const MAX_POINTS: usize = 1 << 31;
const COLOR_SCALE: f64 = 0.15;

/// Which frame an SPZ's values are in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum SpzFrame {
    /// RUB, the format's convention: turned into PLY's RDF on reading (a half turn about x).
    #[default]
    Rub,
    /// Whatever the writer put there: values kept as stored.
    AsStored,
}

/// Reads an SPZ file of any version (1–4), in PLY's frame (see [`SpzFrame::Rub`]).
///
/// # Errors
/// [`FormatError::Io`]; [`FormatError::Layout`] for a bad gzip/zstd stream, magic, version,
/// count, SH degree or a body shorter than the header promises.
pub fn read_spz(path: impl AsRef<Path>) -> Result<GaussianCloud, FormatError> {
    let path = path.as_ref();
    parse_spz(path, &read_bytes(path)?, SpzFrame::Rub)
}

fn layout(path: &Path, element: &str, problem: String) -> FormatError {
    FormatError::Layout {
        path: path.to_path_buf(),
        element: element.to_string(),
        problem,
    }
}

/// The fixed part of every version's header.
#[derive(Debug, Clone, Copy)]
struct Header {
    version: u32,
    count: usize,
    sh_degree: u8,
    fractional_bits: u8,
}

fn u32_at(b: &[u8], o: usize) -> u32 {
    u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
}

fn parse_header(path: &Path, b: &[u8]) -> Result<Header, FormatError> {
    if b.len() < 16 || u32_at(b, 0) != SPZ_MAGIC {
        return Err(layout(
            path,
            "header",
            "no NGSP magic: not an SPZ file".into(),
        ));
    }
    let h = Header {
        version: u32_at(b, 4),
        count: u32_at(b, 8) as usize,
        sh_degree: b[12],
        fractional_bits: b[13],
    };
    if !(1..=4).contains(&h.version) {
        return Err(layout(
            path,
            "header",
            format!("version {} not supported (1 to 4)", h.version),
        ));
    }
    if h.sh_degree > 4 {
        return Err(layout(
            path,
            "header",
            format!("SH degree {} (0 to 4)", h.sh_degree),
        ));
    }
    if h.count == 0 || h.count > MAX_POINTS {
        return Err(layout(path, "header", format!("{} Gaussians", h.count)));
    }
    if h.fractional_bits > 24 {
        return Err(layout(
            path,
            "header",
            format!("{} fractional bits", h.fractional_bits),
        ));
    }
    Ok(h)
}

const fn sh_dim(degree: u8) -> usize {
    match degree {
        0 => 0,
        1 => 3,
        2 => 8,
        3 => 15,
        _ => 24,
    }
}

/// Parses SPZ `bytes` (`path` only names the file in errors) in the frame `frame` asks for.
///
/// # Errors
/// As [`read_spz`].
pub fn parse_spz(path: &Path, bytes: &[u8], frame: SpzFrame) -> Result<GaussianCloud, FormatError> {
    parse_spz_degree(path, bytes, frame).map(|(cloud, _)| cloud)
}

/// [`parse_spz`], also returning the SH degree the file stores (4 is read and cut to 3).
///
/// # Errors
/// As [`read_spz`].
pub fn parse_spz_degree(
    path: &Path,
    bytes: &[u8],
    frame: SpzFrame,
) -> Result<(GaussianCloud, u8), FormatError> {
    let (header, streams) = if bytes.starts_with(&GZIP_MAGIC) {
        // Header first, then no more than the header's sizes: a gzip bomb cannot run away.
        let gz_err =
            |e: std::io::Error| layout(path, "gzip", format!("not a readable gzip stream: {e}"));
        let mut gz = flate2::read::GzDecoder::new(bytes);
        let mut head = [0u8; 16];
        gz.read_exact(&mut head).map_err(gz_err)?;
        let header = parse_header(path, &head)?;
        if header.version == 4 {
            return Err(layout(
                path,
                "header",
                "version 4 inside gzip (version 4 is not gzipped)".into(),
            ));
        }
        let need: usize = sizes(&header).iter().sum();
        let mut body = Vec::new();
        gz.take(need as u64)
            .read_to_end(&mut body)
            .map_err(gz_err)?;
        (header, split_legacy(path, &header, &body)?)
    } else {
        let header = parse_header(path, bytes)?;
        if header.version != 4 {
            return Err(layout(
                path,
                "header",
                format!(
                    "version {} without gzip (only version 4 is stored plain)",
                    header.version
                ),
            ));
        }
        (header, split_v4(path, &header, bytes)?)
    };
    let mut cloud = decode(path, &header, &streams)?;
    if frame == SpzFrame::Rub {
        half_turn_about_x(&mut cloud);
    }
    Ok((cloud, header.sh_degree))
}

/// The six attribute arrays of a file (positions, alphas, colours, scales, rotations, SH).
struct Streams {
    arrays: [Vec<u8>; 6],
}

fn sizes(h: &Header) -> [usize; 6] {
    let n = h.count;
    let position = if h.version == 1 { 6 } else { 9 };
    let rotation = if h.version >= 3 { 4 } else { 3 };
    [
        position * n,
        n,
        3 * n,
        3 * n,
        rotation * n,
        3 * sh_dim(h.sh_degree) * n,
    ]
}

fn split_legacy(path: &Path, h: &Header, body: &[u8]) -> Result<Streams, FormatError> {
    let sizes = sizes(h);
    let need: usize = sizes.iter().sum();
    if body.len() < need {
        return Err(FormatError::Truncated {
            path: path.to_path_buf(),
            element: "body".into(),
            needed_bytes: need as u64,
            available_bytes: body.len() as u64,
        });
    }
    let mut at = 0;
    let arrays = sizes.map(|s| {
        let a = body[at..at + s].to_vec();
        at += s;
        a
    });
    Ok(Streams { arrays })
}

fn split_v4(path: &Path, h: &Header, bytes: &[u8]) -> Result<Streams, FormatError> {
    if bytes.len() < 32 {
        return Err(layout(
            path,
            "header",
            "shorter than the 32-byte version 4 header".into(),
        ));
    }
    let streams = usize::from(bytes[15]);
    let toc = u32_at(bytes, 16) as usize;
    let expected = sizes(h);
    let present: Vec<usize> = (0..6).filter(|&k| expected[k] > 0).collect();
    if streams != present.len() {
        return Err(layout(
            path,
            "header",
            format!("{streams} streams, expected {}", present.len()),
        ));
    }
    let toc_end = toc
        .checked_add(16 * streams)
        .filter(|&e| toc >= 32 && e <= bytes.len())
        .ok_or_else(|| {
            layout(
                path,
                "toc",
                format!("table of contents at byte {toc} lies outside the file"),
            )
        })?;
    let mut at = toc_end;
    let mut arrays: [Vec<u8>; 6] = Default::default();
    for (s, &k) in present.iter().enumerate() {
        let entry = toc + 16 * s;
        let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().unwrap_or([0; 8]));
        let (compressed, uncompressed) = (u64_at(entry), u64_at(entry + 8));
        if uncompressed != expected[k] as u64 {
            return Err(layout(
                path,
                STREAM_NAMES[k],
                format!(
                    "{uncompressed} bytes uncompressed, expected {}",
                    expected[k]
                ),
            ));
        }
        let end = usize::try_from(compressed)
            .ok()
            .and_then(|c| at.checked_add(c))
            .filter(|&e| e <= bytes.len())
            .ok_or_else(|| {
                layout(
                    path,
                    STREAM_NAMES[k],
                    format!("{compressed} compressed bytes run past the end"),
                )
            })?;
        let mut out = Vec::new();
        zstd::stream::read::Decoder::new(&bytes[at..end])
            .and_then(|d| d.take(expected[k] as u64 + 1).read_to_end(&mut out))
            .map_err(|e| {
                layout(
                    path,
                    STREAM_NAMES[k],
                    format!("not a readable zstd frame: {e}"),
                )
            })?;
        if out.len() != expected[k] {
            return Err(layout(
                path,
                STREAM_NAMES[k],
                format!("{} bytes after zstd, expected {}", out.len(), expected[k]),
            ));
        }
        arrays[k] = out;
        at = end;
    }
    Ok(Streams { arrays })
}

const STREAM_NAMES: [&str; 6] = ["positions", "alphas", "colors", "scales", "rotations", "sh"];

fn decode(path: &Path, h: &Header, s: &Streams) -> Result<GaussianCloud, FormatError> {
    let n = h.count;
    let dim = sh_dim(h.sh_degree);
    let keep = dim.min(15);
    let mut cloud = GaussianCloud::with_capacity(n, 3 * keep);
    let [pos, alpha, color, scale, rot, sh] = &s.arrays;
    let unit = 1.0 / f64::from(1u32 << h.fractional_bits);
    for i in 0..n {
        let p = if h.version == 1 {
            [0, 1, 2].map(|c| {
                let o = 6 * i + 2 * c;
                half::f16::from_le_bytes([pos[o], pos[o + 1]]).to_f32()
            })
        } else {
            [0, 1, 2].map(|c| {
                let o = 9 * i + 3 * c;
                let v = i32::from_le_bytes([pos[o], pos[o + 1], pos[o + 2], 0]);
                let v = (v << 8) >> 8; // sign-extend 24 bits
                (f64::from(v) * unit) as f32
            })
        };
        // f16 can hold infinities and NaN; a reader must not pass them on.
        if let Some(bad) = p.iter().find(|v| !v.is_finite()) {
            return Err(FormatError::NonFinite {
                path: path.to_path_buf(),
                element: "positions".into(),
                property: "x y z".into(),
                row: i,
                value: f64::from(*bad),
            });
        }
        cloud.positions.push(p);
        cloud
            .opacity_logit
            .push(alpha_to_logit(f64::from(alpha[i]) / 255.0));
        cloud.sh_dc.push(
            [0, 1, 2].map(|c| ((f64::from(color[3 * i + c]) / 255.0 - 0.5) / COLOR_SCALE) as f32),
        );
        cloud
            .log_scales
            .push([0, 1, 2].map(|c| f32::from(scale[3 * i + c]) / 16.0 - 10.0));
        let xyzw = if h.version >= 3 {
            smallest_three(u32::from_le_bytes([
                rot[4 * i],
                rot[4 * i + 1],
                rot[4 * i + 2],
                rot[4 * i + 3],
            ]))
        } else {
            let [x, y, z] = [0, 1, 2].map(|c| f64::from(rot[3 * i + c]) / 127.5 - 1.0);
            [x, y, z, (1.0 - x * x - y * y - z * z).max(0.0).sqrt()]
        };
        cloud
            .rotations_wxyz
            .push([xyzw[3], xyzw[0], xyzw[1], xyzw[2]].map(|v| v as f32));
        for c in 0..3 {
            for k in 0..keep {
                let b = sh[(i * dim + k) * 3 + c];
                cloud.sh_rest.push((f32::from(b) - 128.0) / 128.0);
            }
        }
    }
    Ok(cloud)
}

/// Unpacks a "smallest three" rotation into (x, y, z, w).
fn smallest_three(mut packed: u32) -> [f64; 4] {
    let largest = (packed >> 30) as usize;
    let mut q = [0.0f64; 4];
    let mut sum = 0.0;
    for i in (0..4).rev() {
        if i == largest {
            continue;
        }
        let magnitude = f64::from(packed & 511);
        let negative = (packed >> 9) & 1 == 1;
        packed >>= 10;
        let v = std::f64::consts::FRAC_1_SQRT_2 * magnitude / 511.0;
        q[i] = if negative { -v } else { v };
        sum += q[i] * q[i];
    }
    q[largest] = (1.0 - sum).max(0.0).sqrt();
    q
}

/// Packs a unit quaternion (x, y, z, w) as "smallest three" (the largest component made
/// positive by negating the whole quaternion, the same rotation).
fn pack_smallest_three(q: [f64; 4]) -> u32 {
    let mut largest = 0;
    for i in 1..4 {
        if q[i].abs() > q[largest].abs() {
            largest = i;
        }
    }
    let negate = q[largest] < 0.0;
    let mut packed = largest as u32;
    for (i, &v) in q.iter().enumerate() {
        if i == largest {
            continue;
        }
        let magnitude = (511.0 * v.abs() / std::f64::consts::FRAC_1_SQRT_2 + 0.5).min(511.0) as u32;
        let sign = u32::from((v < 0.0) != negate);
        packed = (packed << 10) | (sign << 9) | magnitude;
    }
    packed
}

/// Turns a cloud by a half turn about x, (x, y, z) → (x, −y, −z): RUB ↔ RDF. Rotations and SH
/// coefficients turn with it.
fn half_turn_about_x(cloud: &mut GaussianCloud) {
    cloud.rotate(DMat3::from_diagonal(glam::DVec3::new(1.0, -1.0, -1.0)));
}

fn to_u8(x: f64) -> u8 {
    x.round().clamp(0.0, 255.0) as u8
}

/// Writes `cloud` as an SPZ file (version [`SPZ_WRITE_VERSION`]), turning it from world (z up)
/// into the format's RUB frame (y up): world (x, y, z) is stored as (x, z, −y), so viewers that
/// follow the SPZ convention show it upright. SH above degree 3 does not occur; extra
/// properties are dropped (SPZ has no place for them).
///
/// # Errors
/// [`FormatError::InconsistentCloud`] for fields of mismatched length; [`FormatError::Layout`]
/// for an empty cloud or one too large for the format; [`FormatError::Io`].
pub fn write_spz(path: impl AsRef<Path>, cloud: &GaussianCloud) -> Result<(), FormatError> {
    let path = path.as_ref();
    let bytes = to_spz_bytes(path, cloud)?;
    std::fs::write(path, bytes).map_err(|source| FormatError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// The bytes [`write_spz`] writes for a cloud in world coordinates (z up).
///
/// # Errors
/// As [`write_spz`].
pub fn to_spz_bytes(path: &Path, cloud: &GaussianCloud) -> Result<Vec<u8>, FormatError> {
    crate::ply::check_cloud(path, cloud)?;
    let n = cloud.len();
    if n == 0 || n > u32::MAX as usize {
        return Err(layout(
            path,
            "body",
            format!("{n} Gaussians: SPZ holds 1 to 2^32 − 1"),
        ));
    }
    let mut c = cloud.clone();
    // World z up → RUB y up: (x, y, z) → (x, z, −y), a quarter turn about x.
    c.rotate(DMat3::from_cols(
        glam::DVec3::new(1.0, 0.0, 0.0),
        glam::DVec3::new(0.0, 0.0, -1.0),
        glam::DVec3::new(0.0, 1.0, 0.0),
    ));
    // 12 fractional bits (0.24 mm) unless a coordinate needs the range.
    let extent = c
        .positions
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(f64::from(v.abs())));
    let mut fractional_bits = 12u8;
    while fractional_bits > 0
        && extent * f64::from(1u32 << fractional_bits) >= f64::from(1 << 23) - 1.0
    {
        fractional_bits -= 1;
    }
    let degree = c.sh_degree.min(3);
    let dim = sh_dim(degree);
    let rest_k = c.sh_rest_len / 3;
    let mut body = Vec::with_capacity(16 + n * (9 + 1 + 3 + 3 + 4 + 3 * dim));
    body.extend_from_slice(&SPZ_MAGIC.to_le_bytes());
    body.extend_from_slice(&SPZ_WRITE_VERSION.to_le_bytes());
    body.extend_from_slice(&(n as u32).to_le_bytes());
    body.extend_from_slice(&[degree, fractional_bits, 0, 0]);
    let scale = f64::from(1u32 << fractional_bits);
    let limit = f64::from((1 << 23) - 1);
    for p in &c.positions {
        for v in p {
            let fixed = (f64::from(*v) * scale).round().clamp(-limit, limit) as i32;
            body.extend_from_slice(&fixed.to_le_bytes()[..3]);
        }
    }
    for i in 0..n {
        body.push(to_u8(f64::from(c.opacity(i)) * 255.0));
    }
    for dc in &c.sh_dc {
        for v in dc {
            body.push(to_u8(f64::from(*v) * COLOR_SCALE * 255.0 + 127.5));
        }
    }
    for s in &c.log_scales {
        for v in s {
            body.push(to_u8((f64::from(*v) + 10.0) * 16.0));
        }
    }
    for i in 0..n {
        let q = c.rotation(i);
        let packed = pack_smallest_three([q.x, q.y, q.z, q.w].map(f64::from));
        body.extend_from_slice(&packed.to_le_bytes());
    }
    for i in 0..n {
        let rest = &c.sh_rest[i * c.sh_rest_len..(i + 1) * c.sh_rest_len];
        for k in 0..dim {
            for ch in 0..3 {
                let v = if k < rest_k {
                    f64::from(rest[ch * rest_k + k])
                } else {
                    0.0
                };
                body.push(to_u8(v * 128.0 + 128.0));
            }
        }
    }
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(&body)
        .and_then(|()| gz.finish())
        .map_err(|source| FormatError::Io {
            path: path.to_path_buf(),
            source,
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smallest_three_round_trips_within_its_quantisation() {
        let qs = [
            [0.0, 0.0, 0.0, 1.0],
            [0.1, -0.2, 0.3, 0.9],
            [-0.7, 0.1, 0.1, 0.7],
            [0.5, 0.5, -0.5, -0.5],
        ];
        for q in qs {
            let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
            let q = q.map(|v| v / n);
            let back = smallest_three(pack_smallest_three(q));
            let dot: f64 = q.iter().zip(back).map(|(a, b)| a * b).sum();
            // Same rotation up to sign; 9 bits over ±√½ is about 1.4e-3 per component.
            assert!(dot.abs() > 1.0 - 1e-5, "{q:?} -> {back:?}");
        }
        // The reference's identity: bytes 00 00 00 C0 (w largest, index 3).
        assert_eq!(pack_smallest_three([0.0, 0.0, 0.0, 1.0]), 0xC000_0000);
    }
}
