//! The whole uplift of one scene: find each training view's feature map, optionally reduce the
//! channels by PCA ([`crate::pca`]), accumulate the weighted means ([`crate::uplift`]) and
//! optionally refine them ([`crate::refine`]). Feature maps are read one view at a time, so
//! memory is the per-Gaussian sums plus one map.

use std::path::{Path, PathBuf};

use splatphys_render::SplatView;

use crate::cameras::{TrainingView, downscaled};
use crate::feature_map::{FeatureMap, FeatureMapError};
use crate::pca::SecondMoment;
use crate::refine::{add_view_gradient, apply_step};
use crate::uplift::{Accumulator, ProjectedView, UpliftError, UpliftSettings, Uplifted};

/// Why the uplift stopped.
#[derive(Debug, thiserror::Error)]
pub enum Stage1Error {
    /// A feature map could not be used.
    #[error(transparent)]
    FeatureMap(#[from] FeatureMapError),
    /// The uplift itself failed.
    #[error(transparent)]
    Uplift(#[from] UpliftError),
    /// No view had a feature map.
    #[error(
        "none of the {views} views has a feature map in {dir} (expected <image stem>.npy, e.g. {example})"
    )]
    NoFeatureMaps {
        /// Views in the camera file.
        views: usize,
        /// The folder searched.
        dir: PathBuf,
        /// The first file name looked for.
        example: String,
    },
}

/// What to do.
#[derive(Debug, Clone, PartialEq)]
pub struct Job {
    /// Folder with `<image stem>.npy` per view.
    pub features_dir: PathBuf,
    /// Render each view this many times smaller per axis (1 = the camera's resolution).
    pub downscale: f32,
    /// Reduce to this many channels by PCA before the uplift.
    pub pca: Option<usize>,
    /// Pixels sampled for the PCA, at most (spread over all views).
    pub pca_samples: usize,
    /// Cosine-loss refinement iterations (0 = none).
    pub refine_iterations: usize,
    /// Refinement step η (see [`crate::refine`]).
    pub refine_step: f32,
    /// Uplift settings.
    pub settings: UpliftSettings,
}

impl Default for Job {
    fn default() -> Self {
        Self {
            features_dir: PathBuf::from("."),
            downscale: 1.0,
            pca: None,
            pca_samples: 50_000,
            refine_iterations: 0,
            refine_step: 0.5,
            settings: UpliftSettings::default(),
        }
    }
}

/// What happened.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// Views with a feature map, used.
    pub views_used: usize,
    /// Views without a feature map (names), skipped.
    pub views_missing: Vec<String>,
    /// Channels of the maps.
    pub dim_in: usize,
    /// Channels written (after PCA).
    pub dim_out: usize,
    /// PCA basis `[k][D_in]`, when reduced.
    pub pca_basis: Option<Vec<f32>>,
    /// Fraction of the maps' second moment the basis keeps.
    pub pca_kept: Option<f64>,
    /// (Gaussian, pixel) blends over all views.
    pub blends: u64,
    /// Mean cosine loss per pixel before refinement and after each iteration.
    pub losses: Vec<f64>,
}

/// A progress callback: `(stage, done, total)`.
pub type Progress<'a> = &'a mut dyn FnMut(&str, usize, usize);

/// Runs the uplift of `splats` from `views` (cameras at full resolution).
///
/// # Errors
/// [`Stage1Error`] for unreadable or inconsistent maps, or when no view has a map.
pub fn run(
    splats: &SplatView<'_>,
    views: &[TrainingView],
    job: &Job,
    progress: Progress<'_>,
) -> Result<(Uplifted, Report), Stage1Error> {
    let map_path = |v: &TrainingView| feature_map_path(&job.features_dir, v);
    let (present, missing): (Vec<&TrainingView>, Vec<&TrainingView>) =
        views.iter().partition(|v| map_path(v).is_file());
    let Some(first) = present.first() else {
        return Err(Stage1Error::NoFeatureMaps {
            views: views.len(),
            dir: job.features_dir.clone(),
            example: views
                .first()
                .map(|v| format!("{}.npy", v.name))
                .unwrap_or_default(),
        });
    };
    let dim_in = FeatureMap::read(&map_path(first))?.dim;
    let check = |v: &TrainingView, map: &FeatureMap| {
        if map.dim == dim_in {
            Ok(())
        } else {
            Err(UpliftError::Dimension {
                view: v.name.clone(),
                expected: dim_in,
                found: map.dim,
            })
        }
    };

    // PCA over sampled pixels of every map.
    let mut pca_basis = None;
    let mut pca_kept = None;
    if let Some(k) = job.pca.filter(|&k| k > 0 && k < dim_in) {
        let mut moment = SecondMoment::new(dim_in);
        for (i, v) in present.iter().enumerate() {
            progress("pca", i, present.len());
            let map = FeatureMap::read(&map_path(v))?;
            check(v, &map)?;
            let pixels = map.height * map.width * present.len();
            moment.add(&map, pixels.div_ceil(job.pca_samples.max(1)));
        }
        let (basis, kept) = moment.basis(k);
        pca_basis = Some(basis);
        pca_kept = Some(kept);
    }
    let dim_out = pca_basis.as_ref().map_or(dim_in, |b| b.len() / dim_in);
    let load = |v: &TrainingView| -> Result<FeatureMap, Stage1Error> {
        let mut map = FeatureMap::read(&map_path(v))?;
        check(v, &map)?;
        if let Some(b) = &pca_basis {
            map.project(b, dim_out);
        }
        Ok(map)
    };
    let project = |v: &TrainingView| {
        ProjectedView::new(
            splats,
            &downscaled(&v.view, job.downscale),
            job.settings.near_m,
        )
    };

    let mut acc = Accumulator::new(splats.len(), dim_out);
    let mut blends = 0;
    for (i, v) in present.iter().enumerate() {
        progress("uplift", i, present.len());
        let stats = acc.add_view(&v.name, &project(v)?, &load(v)?, &job.settings)?;
        blends += stats.blends;
    }
    let mut uplifted = acc.finish(job.settings.min_weight);

    let mut losses = Vec::new();
    if job.refine_iterations > 0 {
        for it in 0..=job.refine_iterations {
            let mut grad = vec![0.0f32; uplifted.features.len()];
            let (mut loss, mut pixels) = (0.0, 0u64);
            for (i, v) in present.iter().enumerate() {
                progress(
                    &format!("refine {it}/{}", job.refine_iterations),
                    i,
                    present.len(),
                );
                let l = add_view_gradient(
                    &project(v)?,
                    &load(v)?,
                    &uplifted.features,
                    dim_out,
                    job.settings.tiles_per_batch,
                    &mut grad,
                );
                loss += l.loss;
                pixels += l.pixels;
            }
            losses.push(if pixels > 0 {
                loss / pixels as f64
            } else {
                0.0
            });
            // The last pass only measures the final loss.
            if it < job.refine_iterations {
                apply_step(
                    &mut uplifted.features,
                    &grad,
                    &uplifted.weights,
                    dim_out,
                    job.refine_step,
                    job.settings.min_weight,
                );
            }
        }
    }
    progress("done", present.len(), present.len());
    Ok((
        uplifted,
        Report {
            views_used: present.len(),
            views_missing: missing.iter().map(|v| v.name.clone()).collect(),
            dim_in,
            dim_out,
            pca_basis,
            pca_kept,
            blends,
            losses,
        },
    ))
}

/// The feature-map path the uplift looks for: `<dir>/<view name>.npy`.
pub fn feature_map_path(dir: &Path, view: &TrainingView) -> PathBuf {
    dir.join(format!("{}.npy", view.name))
}
