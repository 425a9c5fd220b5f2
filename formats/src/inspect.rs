//! A summary of a 3DGS file for `splatphys inspect`: count, SH degree, bounds, scale and opacity
//! statistics, extra properties, quaternion health, and a guess of the up axis.
//!
//! Up-axis heuristic (no standard exists; 3DGS trainers inherit COLMAP's arbitrary frame): the
//! candidate axis is the clearly thinnest one (a flat object lying on its base) or else the
//! clearly longest one (a standing object), else the thinnest; its sign points away from the end
//! whose 10 % slab of Gaussians is spread wider across the other two axes (a base, a stand, feet
//! are wider than a top). It is a guess and is reported as one.

use std::fmt;
use std::path::{Path, PathBuf};
use std::time::Instant;

use super::{FileFormat, FormatError, ReadOptions, read_gaussians_with};
use crate::gaussians::GaussianCloud;

/// Percentiles of one quantity.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Stats {
    /// Minimum.
    pub min: f32,
    /// 5th percentile.
    pub p5: f32,
    /// Median.
    pub median: f32,
    /// 95th percentile.
    pub p95: f32,
    /// Maximum.
    pub max: f32,
}

impl Stats {
    /// Percentiles of `values` (NaNs sorted last); all zero when empty.
    pub fn of(mut values: Vec<f32>) -> Self {
        if values.is_empty() {
            return Self::default();
        }
        values.sort_unstable_by(|a, b| a.total_cmp(b));
        let at = |q: f64| values[((values.len() - 1) as f64 * q).round() as usize];
        Self {
            min: values[0],
            p5: at(0.05),
            median: at(0.5),
            p95: at(0.95),
            max: values[values.len() - 1],
        }
    }
}

/// The up-axis guess: a signed axis of the file frame and why.
#[derive(Debug, Clone, PartialEq)]
pub struct UpAxisGuess {
    /// Unit axis in the file frame, e.g. `[0, -1, 0]`.
    pub axis: [f32; 3],
    /// Human-readable label, e.g. `-y`.
    pub label: String,
    /// The reasoning, one sentence.
    pub reason: String,
}

/// What `splatphys inspect FILE` prints.
#[derive(Debug, Clone, PartialEq)]
pub struct InspectReport {
    /// The file.
    pub path: PathBuf,
    /// The format detected.
    pub format: FileFormat,
    /// File size, bytes.
    pub file_bytes: u64,
    /// Wall time to read and decode, seconds.
    pub load_s: f64,
    /// Number of Gaussians.
    pub count: usize,
    /// SH degree 0..=3.
    pub sh_degree: u8,
    /// Whether the file has `nx ny nz`.
    pub has_normals: bool,
    /// Axis-aligned bounds of the centres, file units: `[min, max]`.
    pub bounds: [[f32; 3]; 2],
    /// Per-axis log-scale statistics (natural log of the standard deviation, file units).
    pub log_scale: [Stats; 3],
    /// Opacity statistics after the sigmoid, in [0, 1].
    pub opacity: Stats,
    /// Fraction of Gaussians with opacity > 0.5.
    pub opaque_fraction: f32,
    /// Number of quaternions whose length differs from 1 by more than 1e-3.
    pub unnormalised_rotations: usize,
    /// Names of the extra per-vertex properties kept.
    pub extra_properties: Vec<String>,
    /// The up-axis guess.
    pub up: UpAxisGuess,
    /// The format's version as the file states it (`version 4` for an SPZ 4, `version 2.0` for
    /// glTF), when it has one.
    pub version: Option<String>,
}

/// Reads `path` and summarises it.
///
/// # Errors
/// Any [`FormatError`] from reading the file.
pub fn inspect(path: impl AsRef<Path>) -> Result<InspectReport, FormatError> {
    let path = path.as_ref();
    let start = Instant::now();
    let (cloud, format) = read_gaussians_with(path, &ReadOptions::default())?;
    let load_s = start.elapsed().as_secs_f64();
    let mut r = report(path, format, size_on_disk(path), load_s, &cloud);
    r.version = format_version(path, format);
    Ok(r)
}

/// The version a file states: an SPZ header's, a SOG `meta.json`'s or streamed index's
/// (`version` absent: 1), a glTF asset's; `None` for formats without one or when it cannot be
/// read again.
pub fn format_version(path: &Path, format: FileFormat) -> Option<String> {
    use std::io::Read;
    let json_version = |bytes: &[u8], key: &str| -> Option<String> {
        let v: serde_json::Value = serde_json::from_slice(bytes).ok()?;
        let found = match key {
            "asset" => v["asset"]["version"].as_str().map(str::to_string),
            _ => v["version"].as_u64().map(|n| n.to_string()),
        };
        Some(found.unwrap_or_else(|| "1".into()))
    };
    match format {
        FileFormat::Spz => {
            let bytes = std::fs::read(path).ok()?;
            let mut head = [0u8; 8];
            if bytes.starts_with(b"NGSP") {
                head.copy_from_slice(bytes.get(..8)?);
            } else {
                flate2::read::GzDecoder::new(&bytes[..])
                    .read_exact(&mut head)
                    .ok()?;
            }
            Some(format!(
                "version {}",
                u32::from_le_bytes([head[4], head[5], head[6], head[7]])
            ))
        }
        FileFormat::Sog => {
            let meta = if path.is_dir() {
                path.join(crate::sog::META_JSON)
            } else {
                path.to_path_buf()
            };
            json_version(&std::fs::read(meta).ok()?, "version").map(|v| format!("version {v}"))
        }
        FileFormat::SogBundle => {
            let mut zip = zip::ZipArchive::new(std::fs::File::open(path).ok()?).ok()?;
            let mut text = Vec::new();
            zip.by_name(crate::sog::META_JSON)
                .ok()?
                .read_to_end(&mut text)
                .ok()?;
            json_version(&text, "version").map(|v| format!("version {v}"))
        }
        FileFormat::SogLod => {
            let index = if path.is_dir() {
                path.join(crate::sog::LOD_META_JSON)
            } else {
                path.to_path_buf()
            };
            json_version(&std::fs::read(index).ok()?, "version").map(|v| format!("version {v}"))
        }
        FileFormat::Gltf => {
            let bytes = std::fs::read(path).ok()?;
            let json = if bytes.starts_with(crate::gltf::GLB_MAGIC) {
                let len = u32::from_le_bytes(bytes.get(12..16)?.try_into().ok()?) as usize;
                bytes.get(20..20 + len)?.to_vec()
            } else {
                bytes
            };
            json_version(&json, "asset").map(|v| format!("version {v}"))
        }
        _ => None,
    }
}

/// Bytes of a file, or of every file under a folder (a SOG, a streamed SOG).
fn size_on_disk(path: &Path) -> u64 {
    match std::fs::metadata(path) {
        Ok(m) if m.is_dir() => std::fs::read_dir(path)
            .map(|d| {
                d.filter_map(Result::ok)
                    .map(|e| size_on_disk(&e.path()))
                    .sum()
            })
            .unwrap_or(0),
        Ok(m) => m.len(),
        Err(_) => 0,
    }
}

/// Summarises an already-loaded cloud.
pub fn report(
    path: &Path,
    format: FileFormat,
    file_bytes: u64,
    load_s: f64,
    cloud: &GaussianCloud,
) -> InspectReport {
    let bounds = bounds(cloud);
    let log_scale = [0, 1, 2].map(|k| Stats::of(cloud.log_scales.iter().map(|s| s[k]).collect()));
    let opac: Vec<f32> = (0..cloud.len()).map(|i| cloud.opacity(i)).collect();
    let opaque_fraction = if opac.is_empty() {
        0.0
    } else {
        opac.iter().filter(|&&o| o > 0.5).count() as f32 / opac.len() as f32
    };
    let unnormalised_rotations = cloud
        .rotations_wxyz
        .iter()
        .filter(|q| {
            let n = q.iter().map(|v| v * v).sum::<f32>().sqrt();
            (n - 1.0).abs() > 1e-3
        })
        .count();
    InspectReport {
        path: path.to_path_buf(),
        format,
        file_bytes,
        load_s,
        count: cloud.len(),
        sh_degree: cloud.sh_degree,
        has_normals: cloud.normals.is_some(),
        bounds,
        log_scale,
        opacity: Stats::of(opac),
        opaque_fraction,
        unnormalised_rotations,
        extra_properties: cloud.extra.iter().map(|(n, _)| n.clone()).collect(),
        up: guess_up_axis(cloud, &bounds),
        version: None,
    }
}

/// Axis-aligned bounds `[min, max]` of the centres; zeros when empty.
pub fn bounds(cloud: &GaussianCloud) -> [[f32; 3]; 2] {
    if cloud.is_empty() {
        return [[0.0; 3]; 2];
    }
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in &cloud.positions {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    [lo, hi]
}

const AXES: [&str; 3] = ["x", "y", "z"];

/// Robust extent of coordinate `k`: p2..p98 range (ignores floaters).
fn robust_range(cloud: &GaussianCloud, k: usize) -> (f32, f32) {
    let s = Stats::of(cloud.positions.iter().map(|p| p[k]).collect());
    let mut v: Vec<f32> = cloud.positions.iter().map(|p| p[k]).collect();
    v.sort_unstable_by(|a, b| a.total_cmp(b));
    if v.is_empty() {
        return (s.min, s.max);
    }
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    (at(0.02), at(0.98))
}

/// See the module docs for the rule.
pub fn guess_up_axis(cloud: &GaussianCloud, _bounds: &[[f32; 3]; 2]) -> UpAxisGuess {
    if cloud.len() < 10 {
        return UpAxisGuess {
            axis: [0.0, 0.0, 1.0],
            label: "+z".into(),
            reason: "too few Gaussians to judge; assuming the world convention".into(),
        };
    }
    let ranges = [0, 1, 2].map(|k| robust_range(cloud, k));
    let ext = ranges.map(|(a, b)| (b - a).max(1e-12));
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| ext[a].total_cmp(&ext[b]));
    let (thin, mid, long) = (order[0], order[1], order[2]);
    let (axis, why) = if ext[thin] < 0.6 * ext[mid] {
        (
            thin,
            format!(
                "{} is the thinnest extent (flat object on its base)",
                AXES[thin]
            ),
        )
    } else if ext[long] > 1.5 * ext[mid] {
        (
            long,
            format!("{} is the longest extent (standing object)", AXES[long]),
        )
    } else {
        (
            thin,
            format!("no clear shape; {} is the thinnest extent", AXES[thin]),
        )
    };
    // Spread of the other two coordinates within the end slabs.
    let (lo, hi) = ranges[axis];
    let slab = 0.1 * (hi - lo);
    let others: Vec<usize> = (0..3).filter(|&k| k != axis).collect();
    let spread = |in_slab: &dyn Fn(f32) -> bool| -> f32 {
        let sel: Vec<&[f32; 3]> = cloud
            .positions
            .iter()
            .filter(|p| in_slab(p[axis]))
            .collect();
        if sel.len() < 3 {
            return 0.0;
        }
        others
            .iter()
            .map(|&k| {
                let m = sel.iter().map(|p| p[k]).sum::<f32>() / sel.len() as f32;
                (sel.iter().map(|p| (p[k] - m).powi(2)).sum::<f32>() / sel.len() as f32).sqrt()
            })
            .sum()
    };
    let low_spread = spread(&|v| v >= lo && v <= lo + slab);
    let high_spread = spread(&|v| v <= hi && v >= hi - slab);
    let sign = if low_spread >= high_spread { 1.0 } else { -1.0 };
    let mut a = [0.0f32; 3];
    a[axis] = sign;
    let label = format!("{}{}", if sign > 0.0 { "+" } else { "-" }, AXES[axis]);
    UpAxisGuess {
        axis: a,
        reason: format!(
            "{why}; the {} end is wider ({:.3} vs {:.3}), so it is taken as the bottom",
            if sign > 0.0 { "low" } else { "high" },
            low_spread.max(high_spread),
            low_spread.min(high_spread)
        ),
        label,
    }
}

impl fmt::Display for InspectReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [lo, hi] = self.bounds;
        writeln!(f, "file        {}", self.path.display())?;
        writeln!(
            f,
            "format      {}{} ({} bytes, read in {:.3} s)",
            self.format,
            self.version
                .as_ref()
                .map_or(String::new(), |v| format!(", {v}")),
            self.file_bytes,
            self.load_s
        )?;
        writeln!(f, "gaussians   {}", self.count)?;
        writeln!(
            f,
            "sh degree   {}{}",
            self.sh_degree,
            if self.has_normals {
                " (normals present)"
            } else {
                ""
            }
        )?;
        writeln!(
            f,
            "bounds      x [{:.4}, {:.4}]  y [{:.4}, {:.4}]  z [{:.4}, {:.4}]  (file units)",
            lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]
        )?;
        writeln!(
            f,
            "extent      {:.4} x {:.4} x {:.4}",
            hi[0] - lo[0],
            hi[1] - lo[1],
            hi[2] - lo[2]
        )?;
        writeln!(
            f,
            "log scale   axis   min      p5       median   p95      max"
        )?;
        for (k, s) in self.log_scale.iter().enumerate() {
            writeln!(
                f,
                "            {}      {:<8.3} {:<8.3} {:<8.3} {:<8.3} {:<8.3}",
                AXES[k], s.min, s.p5, s.median, s.p95, s.max
            )?;
        }
        let o = &self.opacity;
        writeln!(
            f,
            "opacity     min {:.3}  p5 {:.3}  median {:.3}  p95 {:.3}  max {:.3}  ({:.1}% > 0.5)",
            o.min,
            o.p5,
            o.median,
            o.p95,
            o.max,
            100.0 * self.opaque_fraction
        )?;
        writeln!(
            f,
            "rotations   {} of {} not unit length (normalised on use)",
            self.unnormalised_rotations, self.count
        )?;
        if self.extra_properties.is_empty() {
            writeln!(f, "extra       none")?;
        } else {
            writeln!(
                f,
                "extra       {} properties: {}",
                self.extra_properties.len(),
                self.extra_properties.join(" ")
            )?;
        }
        write!(f, "up (guess)  {}: {}", self.up.label, self.up.reason)
    }
}
