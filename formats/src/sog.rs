//! PlayCanvas SOG ("spatially ordered Gaussians", SuperSplat's publishing format): a
//! `meta.json` and lossless WebP images, as a folder, as one `.sog` ZIP bundle, or as the
//! streamed level-of-detail layout (`lod-meta.json` whose leaves point into chunk folders).
//!
//! Source: PlayCanvas's format description (developer.playcanvas.com, "SOG format" and
//! "Streamed SOG") and `splat-transform`'s reader (`read-sog.ts`, `read-sog-v1.ts`,
//! `read-lod.ts`, v3.2), which the tests take as the reference decoder. Per texel i (row-major
//! from the top left; every per-splat image has the same size):
//!
//! - centre: q = lo | hi << 8 from `means_l`/`means_u`, n = min + (max − min) q / 65535 per
//!   axis, x = sign(n) (e^|n| − 1) (the writer stores sign(x) ln(1 + |x|));
//! - rotation: alpha − 252 names the largest component of (w, x, y, z), rebuilt as
//!   √(1 − a² − b² − c²); the other three are (byte / 255 − 0.5) √2 in index order;
//! - scales: log scales, `codebook[byte]` (v2) or min + (max − min) byte / 255 (v1);
//! - colour DC: `codebook[byte]` (v2) or a min/max lerp (v1); opacity: alpha / 255 is linear
//!   opacity in v2 (stored as a logit here, ±40 at 0 and 1) and a lerped logit in v1;
//! - higher SH: a 16-bit palette label (R | G << 8) picks an entry of `shN_centroids`, 64
//!   entries a row, K texels each (K = 3, 8, 15 for 1–3 bands), each texel R, G, B indexing the
//!   codebook (v2) or lerped (v1): INRIA's channel-major `f_rest` order.
//!
//! SOG stores the values of the PLY it was made from, in the same frame: nothing is flipped.
//! Splats come out in texel order (the writer sorts them along a Morton curve; the original
//! order is not stored).

use std::collections::HashMap;
use std::io::Read;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::{FormatError, read_bytes};
use crate::gaussians::GaussianCloud;
use crate::splat::alpha_to_logit;

/// File name of a SOG's metadata.
pub const META_JSON: &str = "meta.json";
/// File name of a streamed level-of-detail SOG's index.
pub const LOD_META_JSON: &str = "lod-meta.json";

/// Where the files of one SOG come from: a folder, or the entries of a `.sog` ZIP.
enum Files {
    Folder(PathBuf),
    Zip {
        path: PathBuf,
        entries: HashMap<String, Vec<u8>>,
    },
}

impl Files {
    fn read(&self, name: &str) -> Result<Vec<u8>, FormatError> {
        match self {
            Self::Folder(dir) => read_bytes(&dir.join(name)),
            Self::Zip { path, entries } => {
                entries
                    .get(name)
                    .cloned()
                    .ok_or_else(|| FormatError::Layout {
                        path: path.clone(),
                        element: name.to_string(),
                        problem: "named in meta.json but not in the bundle".into(),
                    })
            }
        }
    }

    fn describe(&self, name: &str) -> PathBuf {
        match self {
            Self::Folder(dir) => dir.join(name),
            Self::Zip { path, .. } => path.join(name),
        }
    }
}

#[derive(Debug, Deserialize)]
struct Meta {
    version: Option<u32>,
    count: Option<usize>,
    means: MinMaxFiles,
    scales: Attribute,
    quats: Attribute,
    sh0: Attribute,
    #[serde(rename = "shN")]
    sh_n: Option<ShN>,
}

#[derive(Debug, Deserialize)]
struct MinMaxFiles {
    mins: Vec<f64>,
    maxs: Vec<f64>,
    files: Vec<String>,
    shape: Option<Vec<usize>>,
}

/// An attribute with a codebook (v2) or per-channel `mins`/`maxs` (v1).
#[derive(Debug, Deserialize)]
struct Attribute {
    #[serde(default)]
    codebook: Option<Vec<Option<f64>>>,
    mins: Option<Vec<f64>>,
    maxs: Option<Vec<f64>>,
    files: Vec<String>,
}

#[derive(Debug, Deserialize)]
struct ShN {
    bands: Option<usize>,
    #[serde(default)]
    codebook: Option<Vec<Option<f64>>>,
    mins: Option<serde_json::Value>,
    maxs: Option<serde_json::Value>,
    files: Vec<String>,
}

/// Reads a SOG given as its folder, its `meta.json`, a `.sog` bundle, or a streamed layout's
/// folder or `lod-meta.json` (level `lod`, 0 the finest and the default; `lod` is ignored for
/// a plain SOG).
///
/// # Errors
/// [`FormatError::Io`] for unreadable files; [`FormatError::Layout`] naming the file (inside
/// the bundle) for bad JSON, a missing key, a bad image, an image of the wrong size, an
/// unknown version or a level that does not exist.
pub fn read_sog(path: impl AsRef<Path>, lod: Option<usize>) -> Result<GaussianCloud, FormatError> {
    let path = path.as_ref();
    let index = if path.is_dir() {
        path.join(LOD_META_JSON)
    } else {
        path.to_path_buf()
    };
    if index.file_name().is_some_and(|n| n == LOD_META_JSON) && index.is_file() {
        return read_lod(&index, lod);
    }
    if !path.is_dir() && super::detect_format(path, &read_bytes(path)?) == super::FileFormat::SogLod
    {
        return read_lod(path, lod);
    }
    read_plain(path)
}

/// A SOG that is not a streamed layout: its folder, its `meta.json` or a `.sog` bundle.
fn read_plain(path: &Path) -> Result<GaussianCloud, FormatError> {
    if path.is_dir() {
        return read_one(&Files::Folder(path.to_path_buf()));
    }
    let bytes = read_bytes(path)?;
    if bytes.starts_with(b"PK") {
        return parse_bundle(path, &bytes);
    }
    let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let meta = parse_meta(path, &bytes)?;
    decode(&Files::Folder(dir), &meta)
}

/// Parses a `.sog` bundle's bytes: a ZIP with `meta.json` and the images at its root (stored or
/// deflated); `path` names it in errors.
///
/// # Errors
/// As [`read_sog`].
pub fn parse_bundle(path: &Path, bytes: &[u8]) -> Result<GaussianCloud, FormatError> {
    let layout = |problem: String| FormatError::Layout {
        path: path.to_path_buf(),
        element: "zip".into(),
        problem,
    };
    let mut archive = zip::ZipArchive::new(std::io::Cursor::new(bytes))
        .map_err(|e| layout(format!("not a readable .sog bundle: {e}")))?;
    let mut entries = HashMap::new();
    for i in 0..archive.len() {
        let mut entry = archive
            .by_index(i)
            .map_err(|e| layout(format!("entry {i}: {e}")))?;
        if entry.is_dir() {
            continue;
        }
        let name = entry
            .name()
            .map_err(|e| layout(format!("entry {i}: {e}")))?
            .trim_start_matches("./")
            .to_string();
        let mut data = Vec::with_capacity(usize::try_from(entry.size()).unwrap_or(0).min(1 << 30));
        entry
            .read_to_end(&mut data)
            .map_err(|e| layout(format!("entry {name}: {e}")))?;
        entries.insert(name, data);
    }
    let files = Files::Zip {
        path: path.to_path_buf(),
        entries,
    };
    read_one(&files)
}

fn read_one(files: &Files) -> Result<GaussianCloud, FormatError> {
    let meta_bytes = files.read(META_JSON)?;
    let meta = parse_meta(&files.describe(META_JSON), &meta_bytes)?;
    decode(files, &meta)
}

fn parse_meta(path: &Path, bytes: &[u8]) -> Result<Meta, FormatError> {
    serde_json::from_slice(bytes).map_err(|e| FormatError::Layout {
        path: path.to_path_buf(),
        element: META_JSON.into(),
        problem: format!("not a SOG meta.json: {e}"),
    })
}

/// One decoded RGBA8 image.
struct Image {
    width: usize,
    rgba: Vec<u8>,
}

impl Image {
    fn texel(&self, i: usize) -> [u8; 4] {
        let o = 4 * i;
        [
            self.rgba[o],
            self.rgba[o + 1],
            self.rgba[o + 2],
            self.rgba[o + 3],
        ]
    }

    fn texels(&self) -> usize {
        self.rgba.len() / 4
    }
}

fn load_image(files: &Files, name: &str) -> Result<Image, FormatError> {
    let bytes = files.read(name)?;
    let img =
        image::load_from_memory_with_format(&bytes, image::ImageFormat::WebP).map_err(|e| {
            FormatError::Layout {
                path: files.describe(name),
                element: name.into(),
                problem: format!("not a readable WebP image: {e}"),
            }
        })?;
    let rgba = img.to_rgba8();
    Ok(Image {
        width: rgba.width() as usize,
        rgba: rgba.into_raw(),
    })
}

/// A codebook of 256 values; a `null` first entry (written by some tool versions) is repaired
/// as PlayCanvas's engine does: cb[0] = cb[1] + (cb[1] − cb[255]) / 255.
fn codebook(path: &Path, what: &str, raw: &[Option<f64>]) -> Result<[f64; 256], FormatError> {
    let bad = |problem: String| FormatError::Layout {
        path: path.to_path_buf(),
        element: format!("{what}.codebook"),
        problem,
    };
    if raw.len() != 256 {
        return Err(bad(format!("{} entries, expected 256", raw.len())));
    }
    let mut cb = [0.0; 256];
    for (k, v) in raw.iter().enumerate().skip(1) {
        cb[k] = v
            .filter(|x| x.is_finite())
            .ok_or_else(|| bad(format!("entry {k} is null or not finite")))?;
    }
    cb[0] = match raw[0] {
        Some(v) if v.is_finite() => v,
        _ => cb[1] + (cb[1] - cb[255]) / 255.0,
    };
    Ok(cb)
}

/// How one channel byte becomes a value: a codebook (v2) or a min/max lerp (v1).
enum Dequant {
    Codebook(Box<[f64; 256]>),
    Lerp { min: f64, max: f64 },
}

impl Dequant {
    fn value(&self, byte: u8) -> f64 {
        match self {
            Self::Codebook(cb) => cb[byte as usize],
            Self::Lerp { min, max } => min + (max - min) * f64::from(byte) / 255.0,
        }
    }
}

/// The per-channel dequantisers of an attribute (`channels` of them).
fn dequantisers(
    path: &Path,
    what: &str,
    attr: &Attribute,
    v2: bool,
    channels: usize,
) -> Result<Vec<Dequant>, FormatError> {
    let missing = |key: &str| FormatError::Layout {
        path: path.to_path_buf(),
        element: META_JSON.into(),
        problem: format!("{what}.{key} missing or too short"),
    };
    if v2 {
        let raw = attr
            .codebook
            .as_deref()
            .ok_or_else(|| missing("codebook"))?;
        let cb = Box::new(codebook(path, what, raw)?);
        Ok((0..channels)
            .map(|_| Dequant::Codebook(cb.clone()))
            .collect())
    } else {
        let mins = attr
            .mins
            .as_deref()
            .filter(|m| m.len() >= channels)
            .ok_or_else(|| missing("mins"))?;
        let maxs = attr
            .maxs
            .as_deref()
            .filter(|m| m.len() >= channels)
            .ok_or_else(|| missing("maxs"))?;
        Ok((0..channels)
            .map(|c| Dequant::Lerp {
                min: mins[c],
                max: maxs[c],
            })
            .collect())
    }
}

fn file<'a>(
    path: &Path,
    what: &str,
    files: &'a [String],
    k: usize,
) -> Result<&'a str, FormatError> {
    files
        .get(k)
        .map(String::as_str)
        .ok_or_else(|| FormatError::Layout {
            path: path.to_path_buf(),
            element: META_JSON.into(),
            problem: format!(
                "{what}.files has {} names, expected at least {}",
                files.len(),
                k + 1
            ),
        })
}

fn decode(files: &Files, meta: &Meta) -> Result<GaussianCloud, FormatError> {
    let meta_path = files.describe(META_JSON);
    let layout = |element: &str, problem: String| FormatError::Layout {
        path: meta_path.clone(),
        element: element.to_string(),
        problem,
    };
    let v2 = match meta.version {
        None | Some(1) => false,
        Some(2) => true,
        Some(v) => {
            return Err(layout(
                META_JSON,
                format!("SOG version {v} not supported (1 or 2)"),
            ));
        }
    };
    let count = meta
        .count
        .or_else(|| meta.means.shape.as_ref().and_then(|s| s.first().copied()))
        .ok_or_else(|| layout(META_JSON, "no count (v2) or means.shape (v1)".into()))?;
    if meta.means.mins.len() < 3 || meta.means.maxs.len() < 3 {
        return Err(layout(META_JSON, "means.mins/maxs need 3 values".into()));
    }
    let means_l = load_image(files, file(&meta_path, "means", &meta.means.files, 0)?)?;
    let means_u = load_image(files, file(&meta_path, "means", &meta.means.files, 1)?)?;
    let quats = load_image(files, file(&meta_path, "quats", &meta.quats.files, 0)?)?;
    let scales = load_image(files, file(&meta_path, "scales", &meta.scales.files, 0)?)?;
    let sh0 = load_image(files, file(&meta_path, "sh0", &meta.sh0.files, 0)?)?;
    for (name, img) in [
        (&meta.means.files[0], &means_l),
        (&meta.means.files[1], &means_u),
        (&meta.quats.files[0], &quats),
        (&meta.scales.files[0], &scales),
        (&meta.sh0.files[0], &sh0),
    ] {
        if img.texels() < count {
            return Err(layout(
                name,
                format!("{} texels for {count} splats", img.texels()),
            ));
        }
    }
    let scale_q = dequantisers(&meta_path, "scales", &meta.scales, v2, 3)?;
    let sh0_q = dequantisers(&meta_path, "sh0", &meta.sh0, v2, if v2 { 3 } else { 4 })?;
    let higher = match &meta.sh_n {
        Some(sh_n) => Some(HigherSh::load(files, &meta_path, sh_n, v2)?),
        None => None,
    };
    let rest_per_channel = higher.as_ref().map_or(0, |h| h.coeffs);
    let mut cloud = GaussianCloud::with_capacity(count, 3 * rest_per_channel);
    for i in 0..count {
        let (lo, hi) = (means_l.texel(i), means_u.texel(i));
        let mut p = [0f32; 3];
        for c in 0..3 {
            let q = f64::from(u16::from(lo[c]) | (u16::from(hi[c]) << 8));
            let (min, max) = (meta.means.mins[c], meta.means.maxs[c]);
            let n = min + (max - min) * q / 65535.0;
            p[c] = (n.signum() * (n.abs().exp() - 1.0)) as f32;
        }
        if !p.iter().all(|v| v.is_finite()) {
            return Err(FormatError::NonFinite {
                path: meta_path.clone(),
                element: "means".into(),
                property: "x y z".into(),
                row: i,
                value: f64::from(
                    p.iter()
                        .copied()
                        .find(|v| !v.is_finite())
                        .unwrap_or(f32::NAN),
                ),
            });
        }
        cloud.positions.push(p);
        cloud.rotations_wxyz.push(unpack_quat(quats.texel(i)));
        let s = scales.texel(i);
        cloud
            .log_scales
            .push([0, 1, 2].map(|c| scale_q[c].value(s[c]) as f32));
        let t = sh0.texel(i);
        cloud
            .sh_dc
            .push([0, 1, 2].map(|c| sh0_q[c].value(t[c]) as f32));
        cloud.opacity_logit.push(if v2 {
            alpha_to_logit(f64::from(t[3]) / 255.0)
        } else {
            sh0_q[3].value(t[3]) as f32
        });
        if let Some(h) = &higher {
            h.push(i, &mut cloud.sh_rest);
        }
    }
    Ok(cloud)
}

/// The rotation (w, x, y, z) of one `quats` texel (see the module docs); a tag outside 252..=255
/// (padding, or a damaged file) gives the identity as splat-transform does.
fn unpack_quat(t: [u8; 4]) -> [f32; 4] {
    let Some(largest) = t[3].checked_sub(252).filter(|k| *k < 4) else {
        return [1.0, 0.0, 0.0, 0.0];
    };
    let v = |b: u8| (f64::from(b) / 255.0 - 0.5) * std::f64::consts::SQRT_2;
    let (a, b, c) = (v(t[0]), v(t[1]), v(t[2]));
    let d = (1.0 - a * a - b * b - c * c).max(0.0).sqrt();
    let q = match largest {
        0 => [d, a, b, c],
        1 => [a, d, b, c],
        2 => [a, b, d, c],
        _ => [a, b, c, d],
    };
    q.map(|x| x as f32)
}

/// The palette of higher SH coefficients: labels per splat, K coefficients per entry.
struct HigherSh {
    coeffs: usize,
    labels: Image,
    centroids: Image,
    dequant: Dequant,
}

impl HigherSh {
    fn load(files: &Files, meta_path: &Path, sh_n: &ShN, v2: bool) -> Result<Self, FormatError> {
        let bad = |problem: String| FormatError::Layout {
            path: meta_path.to_path_buf(),
            element: "shN".into(),
            problem,
        };
        let centroids = load_image(files, file(meta_path, "shN", &sh_n.files, 0)?)?;
        let labels = load_image(files, file(meta_path, "shN", &sh_n.files, 1)?)?;
        let bands = match sh_n.bands {
            Some(b) => b,
            // v1 has no `bands`: the centroid width is 64 entries of K texels.
            None => match centroids.width {
                192 => 1,
                512 => 2,
                960 => 3,
                w => {
                    return Err(bad(format!(
                        "centroid image {w} px wide: not 64 × 3, 8 or 15"
                    )));
                }
            },
        };
        let coeffs = match bands {
            1 => 3,
            2 => 8,
            3 => 15,
            b => return Err(bad(format!("{b} bands (1 to 3 supported)"))),
        };
        if centroids.width != 64 * coeffs {
            return Err(bad(format!(
                "centroid image {} px wide, expected 64 × {coeffs} for {bands} bands",
                centroids.width
            )));
        }
        let dequant = if v2 {
            let raw = sh_n
                .codebook
                .as_deref()
                .ok_or_else(|| bad("no codebook".into()))?;
            Dequant::Codebook(Box::new(codebook(meta_path, "shN", raw)?))
        } else {
            let scalar = |v: &Option<serde_json::Value>, key: &str| {
                let v = v.as_ref().ok_or_else(|| bad(format!("no {key}")))?;
                v.as_f64()
                    .or_else(|| {
                        v.as_array()
                            .and_then(|a| a.first())
                            .and_then(|x| x.as_f64())
                    })
                    .ok_or_else(|| bad(format!("{key} is not a number")))
            };
            Dequant::Lerp {
                min: scalar(&sh_n.mins, "mins")?,
                max: scalar(&sh_n.maxs, "maxs")?,
            }
        };
        Ok(Self {
            coeffs,
            labels,
            centroids,
            dequant,
        })
    }

    /// Appends splat `i`'s `3 K` channel-major coefficients; zeros when its label points past
    /// the palette stored (as splat-transform does).
    fn push(&self, i: usize, rest: &mut Vec<f32>) {
        let k = self.coeffs;
        let start = rest.len();
        rest.resize(start + 3 * k, 0.0);
        if i >= self.labels.texels() {
            return;
        }
        let l = self.labels.texel(i);
        let label = usize::from(l[0]) | (usize::from(l[1]) << 8);
        let (u0, v) = ((label % 64) * k, label / 64);
        let row = v * self.centroids.width;
        if row + u0 + k > self.centroids.texels() {
            return;
        }
        for j in 0..k {
            let px = self.centroids.texel(row + u0 + j);
            for c in 0..3 {
                rest[start + c * k + j] = self.dequant.value(px[c]) as f32;
            }
        }
    }
}

#[derive(Debug, Deserialize)]
struct LodIndex {
    #[serde(rename = "lodLevels")]
    lod_levels: Option<usize>,
    counts: Option<Vec<usize>>,
    filenames: Vec<String>,
    tree: LodNode,
}

#[derive(Debug, Deserialize)]
struct LodNode {
    #[serde(default)]
    children: Vec<LodNode>,
    #[serde(default)]
    lods: HashMap<String, LodRun>,
}

#[derive(Debug, Deserialize)]
struct LodRun {
    file: usize,
}

/// Level `lod` (default 0, the finest) of a streamed SOG: every chunk a leaf points to at that
/// level, decoded whole, concatenated in file-index order (as splat-transform reads it).
fn read_lod(index_path: &Path, lod: Option<usize>) -> Result<GaussianCloud, FormatError> {
    let bytes = read_bytes(index_path)?;
    let bad = |problem: String| FormatError::Layout {
        path: index_path.to_path_buf(),
        element: LOD_META_JSON.into(),
        problem,
    };
    let index: LodIndex = serde_json::from_slice(&bytes)
        .map_err(|e| bad(format!("not a streamed SOG index: {e}")))?;
    let level = lod.unwrap_or(0);
    let levels = index.lod_levels.or(index.counts.as_ref().map(Vec::len));
    if let Some(n) = levels
        && level >= n
    {
        return Err(bad(format!(
            "level {level} asked for; the file has levels 0 to {}",
            n - 1
        )));
    }
    let key = level.to_string();
    let mut chunks = Vec::new();
    let mut stack = vec![&index.tree];
    while let Some(node) = stack.pop() {
        stack.extend(node.children.iter());
        if let Some(run) = node.lods.get(&key) {
            chunks.push(run.file);
        }
    }
    chunks.sort_unstable();
    chunks.dedup();
    if chunks.is_empty() {
        return Err(bad(format!("no chunk holds level {level}")));
    }
    let dir = index_path.parent().unwrap_or(Path::new("."));
    let mut cloud: Option<GaussianCloud> = None;
    for f in chunks {
        let name = index.filenames.get(f).ok_or_else(|| {
            bad(format!(
                "a leaf names file {f}; filenames has {}",
                index.filenames.len()
            ))
        })?;
        let chunk_meta = dir.join(name);
        let chunk = read_plain(&chunk_meta)?;
        match &mut cloud {
            None => cloud = Some(chunk),
            Some(c) => c.append(chunk),
        }
    }
    let cloud = cloud.unwrap_or_default();
    if let Some(expected) = index.counts.as_ref().and_then(|c| c.get(level))
        && *expected != cloud.len()
    {
        return Err(bad(format!(
            "level {level} should hold {expected} splats, its chunks hold {}",
            cloud.len()
        )));
    }
    Ok(cloud)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quaternion_tags_name_the_largest_component() {
        // 128 ≈ 0 after (b/255 − 0.5)√2; the rebuilt component is then ≈ 1.
        for (tag, slot) in [(252u8, 0usize), (253, 1), (254, 2), (255, 3)] {
            let q = unpack_quat([128, 128, 128, tag]);
            assert!((q[slot] - 1.0).abs() < 1e-3, "{tag}: {q:?}");
        }
        assert_eq!(unpack_quat([9, 9, 9, 0]), [1.0, 0.0, 0.0, 0.0]);
    }
}
