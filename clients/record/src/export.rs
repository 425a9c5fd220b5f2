//! Chosen frames of a recording as 3DGS files a viewer opens (SuperSplat, Blender add-ons, the
//! INRIA viewer, a user's own renderer): INRIA PLY and Niantic SPZ.
//!
//! A `/frame` message carries each Gaussian's world centre, covariance and polar rotation; the
//! `/scene` message of the same generation carries its SH colour, opacity and object.
//! [`splatphys_formats::posed::cloud_from_posed`] turns the two into the INRIA parameterisation
//! (scales and a rotation from Σ, SH turned by the polar rotation, logit opacity). Files are
//! named `frame_<frame index, 6 digits>.<ext>` in the output folder and are in world metres,
//! z up (a viewer that expects y up shows them lying on their side).

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use splatphys_formats::posed::{PosedGaussian, cloud_from_posed};
use splatphys_ipc::wire::{
    BACKGROUND_OBJECT_ID, FrameGaussian, FrameHeader, SceneGaussian, SceneHeader,
};

use crate::channels::{FRAME, SCENE};
use crate::error::RecordError;
use crate::read::{RecordedMessage, split};

/// A file format frames are exported as.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, clap::ValueEnum)]
pub enum ExportFormat {
    /// INRIA 3DGS PLY (float32, SH degree of the scene, an `object_id` property).
    Ply,
    /// Niantic SPZ, version 3 (about 10× smaller than PLY; quantised; no object ids).
    Spz,
}

impl ExportFormat {
    /// File extension.
    pub fn extension(self) -> &'static str {
        match self {
            Self::Ply => "ply",
            Self::Spz => "spz",
        }
    }
}

/// Which frames to export, and how.
#[derive(Debug, Clone)]
pub struct ExportOptions {
    /// One frame in `every` by frame index (index % every == 0); at least 1.
    pub every: u64,
    /// Only frames whose simulation step lies in this half-open range.
    pub steps: Option<Range<u64>>,
    /// The formats to write (each selected frame once per format).
    pub formats: Vec<ExportFormat>,
}

impl Default for ExportOptions {
    fn default() -> Self {
        Self {
            every: 1,
            steps: None,
            formats: vec![ExportFormat::Ply],
        }
    }
}

/// What [`export_frames`] wrote.
#[derive(Debug, Clone, Default)]
pub struct ExportReport {
    /// Frames exported (each in every format asked for).
    pub frames: u64,
    /// The files written, in order.
    pub files: Vec<PathBuf>,
    /// Frames seen in the recording.
    pub frames_seen: u64,
}

/// The static part of one scene generation, as the export needs it.
struct SceneAttributes {
    sh_degree: u8,
    sh: Vec<[f32; 48]>,
    opacity: Vec<f32>,
    object_id: Vec<u32>,
}

/// Parses `--steps`: `A..B` (steps A to B−1), `A..` (from A on), `..B`, or one step `A`.
///
/// # Errors
/// A message naming the text when it is none of these.
pub fn parse_steps(text: &str) -> Result<Range<u64>, String> {
    let bad = || format!("{text:?} is not a step range: use A..B (B excluded), A.., ..B or A");
    let number = |s: &str, default: u64| -> Result<u64, String> {
        let s = s.trim();
        if s.is_empty() {
            Ok(default)
        } else {
            s.parse().map_err(|_| bad())
        }
    };
    match text.split_once("..") {
        Some((a, b)) => {
            let start = number(a, 0)?;
            let end = number(b, u64::MAX)?;
            if end <= start {
                return Err(format!(
                    "{text:?}: the range is empty (A..B keeps A to B−1)"
                ));
            }
            Ok(start..end)
        }
        None => {
            if text.trim().is_empty() {
                return Err(bad());
            }
            let step = number(text, 0)?;
            Ok(step..step.saturating_add(1))
        }
    }
}

/// Exports the chosen frames of a stream of recorded messages (a
/// [`Recording`](crate::read::Recording), file `path` for errors) into `out_dir` (created).
/// Memory: one scene's static attributes per generation (48 floats a Gaussian) and one frame.
///
/// # Errors
/// The stream's errors; [`RecordError::BadMessage`] for a frame whose size does not match, or
/// that comes before any scene of its generation, or whose Gaussian count differs from its
/// scene's; [`RecordError::Io`] for an unwritable output; [`RecordError::Format`] from the
/// writers.
pub fn export_frames(
    msgs: impl IntoIterator<Item = Result<RecordedMessage, RecordError>>,
    path: &Path,
    out_dir: &Path,
    opts: &ExportOptions,
    mut progress: impl FnMut(&ExportReport),
) -> Result<ExportReport, RecordError> {
    std::fs::create_dir_all(out_dir).map_err(|source| RecordError::Io {
        path: out_dir.display().to_string(),
        source,
    })?;
    let every = opts.every.max(1);
    let mut scenes: BTreeMap<u32, SceneAttributes> = BTreeMap::new();
    let mut report = ExportReport::default();
    for m in msgs {
        let m = m?;
        if m.topic == SCENE {
            let (h, gaussians): (SceneHeader, Vec<SceneGaussian>) = split(&m, path, "scene")?;
            scenes.insert(h.scene_generation, scene_attributes(&h, &gaussians));
        } else if m.topic == FRAME {
            report.frames_seen += 1;
            let header: FrameHeader = crate::read::frame_header(&m, path)?;
            let wanted = header.frame_index.is_multiple_of(every)
                && opts.steps.as_ref().is_none_or(|r| r.contains(&header.step));
            if !wanted {
                continue;
            }
            let bad = |what| RecordError::BadMessage {
                path: path.display().to_string(),
                topic: m.topic.clone(),
                sequence: m.sequence,
                len: m.data.len(),
                what,
            };
            let scene = scenes
                .get(&header.scene_generation)
                .ok_or_else(|| bad("frame (no /scene of its generation came before it)"))?;
            let (_, gaussians): (FrameHeader, Vec<FrameGaussian>) = split(&m, path, "frame")?;
            if gaussians.len() != scene.sh.len() {
                return Err(bad("frame (Gaussian count differs from its scene's)"));
            }
            let posed: Vec<PosedGaussian> = gaussians
                .iter()
                .enumerate()
                .map(|(i, g)| PosedGaussian {
                    position_m: g.position_m,
                    covariance_m2: g.covariance_m2,
                    rotation_wxyz: g.rotation_wxyz,
                    opacity: scene.opacity[i],
                    object_id: (scene.object_id[i] != BACKGROUND_OBJECT_ID)
                        .then_some(scene.object_id[i]),
                })
                .collect();
            for &format in &opts.formats {
                let cloud = cloud_from_posed(
                    &posed,
                    &scene.sh,
                    scene.sh_degree,
                    format == ExportFormat::Ply,
                );
                let file = out_dir.join(format!(
                    "frame_{:06}.{}",
                    header.frame_index,
                    format.extension()
                ));
                match format {
                    ExportFormat::Ply => {
                        let comments = vec![
                            format!(
                                "splatphys frame {} step {} time {:.6} s",
                                header.frame_index, header.step, header.time_s
                            ),
                            "world metres, z up; object_id -1 is the captured background".into(),
                        ];
                        splatphys_formats::ply::write_ply(&file, &cloud, &comments)?;
                    }
                    ExportFormat::Spz => splatphys_formats::spz::write_spz(&file, &cloud)?,
                }
                report.files.push(file);
            }
            report.frames += 1;
            progress(&report);
        }
    }
    Ok(report)
}

fn scene_attributes(h: &SceneHeader, gaussians: &[SceneGaussian]) -> SceneAttributes {
    SceneAttributes {
        sh_degree: h.sh_degree.min(3) as u8,
        sh: gaussians.iter().map(|g| g.sh).collect(),
        opacity: gaussians.iter().map(|g| g.opacity).collect(),
        object_id: gaussians.iter().map(|g| g.object_id).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_ranges_parse_as_documented() {
        assert_eq!(parse_steps("10..20"), Ok(10..20));
        assert_eq!(parse_steps("10.."), Ok(10..u64::MAX));
        assert_eq!(parse_steps("..5"), Ok(0..5));
        assert_eq!(parse_steps("7"), Ok(7..8));
        assert!(parse_steps("5..5").is_err());
        assert!(parse_steps("a..3").is_err());
        assert!(parse_steps("").is_err());
    }
}
