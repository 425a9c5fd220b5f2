//! `splatphys uplift`: stage 1, per-Gaussian features from 2-D feature maps of
//! the training views. See the `splatphys_stage1` crate docs and docs/design/stage1.md.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;
use splatphys_core::formats::read_gaussians;
use splatphys_render::Splats;
use splatphys_stage1::output::{write_feature_ply, write_npy_matrix};
use splatphys_stage1::{Job, UpliftSettings, read_cameras};

/// Lift 2-D feature maps of the training views into one feature per Gaussian.
///
/// Every Gaussian's feature is the blending-weighted mean of the map pixels it contributes to,
/// with the rasterizer's own weights αT (learning-free uplift), optionally reduced by PCA and
/// refined by the rendered-feature cosine loss. The cameras must be in the PLY's frame (as the
/// 3DGS training used them).
#[derive(Args, Debug)]
#[command(after_help = "Examples:
  splatphys uplift --ply scene.ply --cameras transforms.json --features feats/ --out scene_feat.ply
  splatphys uplift --ply point_cloud.ply --cameras colmap/sparse/0 --features feats/ --out scene_feat.ply --pca 32 --refine 5
  splatphys uplift --ply scene.ply --cameras transforms.json --features feats/ --out feats.npy --downscale 4

Feature maps: FEATURES/<image stem>.npy, shape [H'][W'][D], float16 or float32, any resolution.
Output: .ply adds feat_0..feat_{D-1} and uplift_weight; .npy writes [N][D] float32. With --pca K
the basis [K][D] is written beside the output as <stem>.pca.npy (scene files name it in `pca`).")]
pub struct UpliftArgs {
    /// The trained 3DGS scene (INRIA PLY, .splat or compressed PLY).
    #[arg(long)]
    ply: PathBuf,
    /// transforms.json, or a COLMAP model folder (cameras/images .txt or .bin; sparse/0 is tried).
    #[arg(long)]
    cameras: PathBuf,
    /// Folder of feature maps, one `<image stem>.npy` per view.
    #[arg(long)]
    features: PathBuf,
    /// Output: `.ply` (scene + `feat_*` properties) or `.npy` (`[N][D]` float32).
    #[arg(long)]
    out: PathBuf,
    /// Reduce the features to K channels by (uncentred) PCA.
    #[arg(long, value_name = "K")]
    pca: Option<usize>,
    /// Pixels sampled for the PCA, at most.
    #[arg(long, default_value_t = 50_000)]
    pca_samples: usize,
    /// Cosine-loss refinement iterations after the uplift.
    #[arg(long, default_value_t = 0, value_name = "N")]
    refine: usize,
    /// Refinement step (fraction of one pixel's full correction).
    #[arg(long, default_value_t = 0.5)]
    refine_step: f32,
    /// Render each view this many times smaller per axis.
    #[arg(long, default_value_t = 1.0)]
    downscale: f32,
    /// Near plane, m: Gaussians closer to a camera are ignored in that view.
    #[arg(long, default_value_t = 0.01)]
    near_m: f32,
    /// Summed weight below which a Gaussian counts as unseen (zero feature).
    #[arg(long, default_value_t = 1e-3)]
    min_weight: f32,
    /// Image size for transforms.json frames without w/h whose image cannot be read, WxH.
    #[arg(long, value_parser = parse_size)]
    image_size: Option<[u32; 2]>,
    /// Worker threads (results are identical for any count).
    #[arg(long, default_value_t = 2)]
    threads: usize,
}

fn parse_size(s: &str) -> Result<[u32; 2], String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("{s:?}: expected WxH, e.g. 800x600"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<u32>()
            .ok()
            .filter(|&n| n > 0)
            .ok_or_else(|| format!("{s:?}: {v:?} is not a positive integer"))
    };
    Ok([parse(w)?, parse(h)?])
}

/// Runs the uplift.
///
/// # Errors
/// Unreadable inputs, cameras that do not match the feature maps, an unwritable output.
pub fn run(args: &UpliftArgs) -> Result<()> {
    if !(args.downscale >= 1.0 && args.downscale.is_finite()) {
        bail!("--downscale {} must be >= 1", args.downscale);
    }
    if !(args.near_m > 0.0 && args.near_m.is_finite()) {
        bail!("--near-m {} must be a positive distance", args.near_m);
    }
    if args.pca == Some(0) {
        bail!("--pca 0: give the number of channels to keep (e.g. 32)");
    }
    let kind = args
        .out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    if !matches!(kind.as_deref(), Some("ply" | "npy")) {
        bail!("--out {}: must end in .ply or .npy", args.out.display());
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.max(1))
        .build()
        .context("thread pool")?;

    let start = Instant::now();
    let cloud = read_gaussians(&args.ply)?;
    let splats = Splats::from_cloud(&cloud);
    let cameras = read_cameras(&args.cameras, args.image_size)?;
    for w in &cameras.warnings {
        eprintln!("warning: {w}");
    }
    let job = Job {
        features_dir: args.features.clone(),
        downscale: args.downscale,
        pca: args.pca,
        pca_samples: args.pca_samples,
        refine_iterations: args.refine,
        refine_step: args.refine_step,
        settings: UpliftSettings {
            near_m: args.near_m,
            min_weight: args.min_weight,
            ..UpliftSettings::default()
        },
    };
    let bar = ProgressBar::new(cameras.views.len() as u64).with_style(
        ProgressStyle::with_template("{msg:>12} [{bar:40}] {pos}/{len} views, {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let view = splats.view()?;
    let (uplifted, report) = pool.install(|| {
        splatphys_stage1::run(&view, &cameras.views, &job, &mut |stage, done, total| {
            bar.set_length(total as u64);
            bar.set_message(stage.to_string());
            bar.set_position(done as u64);
        })
    })?;
    bar.finish_and_clear();

    if !report.views_missing.is_empty() {
        eprintln!(
            "warning: {} of {} views have no feature map in {} and were skipped (first: {})",
            report.views_missing.len(),
            cameras.views.len(),
            args.features.display(),
            report.views_missing[0]
        );
    }
    if !uplifted.unseen.is_empty() {
        eprintln!(
            "warning: {} of {} Gaussians are seen by no view (summed weight < {}); their features are zero and uplift_weight says so",
            uplifted.unseen.len(),
            cloud.len(),
            args.min_weight
        );
    }

    write_atomically(&args.out, |tmp| match kind.as_deref() {
        Some("ply") => Ok(write_feature_ply(
            tmp,
            &cloud,
            &uplifted,
            &[format!(
                "splatphys uplift: {} views, {} channels{}",
                report.views_used,
                report.dim_out,
                if report.pca_basis.is_some() {
                    " (PCA)"
                } else {
                    ""
                }
            )],
        )?),
        _ => Ok(write_npy_matrix(tmp, &uplifted.features, uplifted.dim)?),
    })?;
    let basis_path = report.pca_basis.as_ref().map(|_| pca_path(&args.out));
    if let (Some(b), Some(p)) = (&report.pca_basis, &basis_path) {
        write_atomically(p, |tmp| Ok(write_npy_matrix(tmp, b, report.dim_in)?))?;
    }
    println!(
        "{}",
        json!({
            "gaussians": cloud.len(),
            "views": report.views_used,
            "views_missing": report.views_missing.len(),
            "channels_in": report.dim_in,
            "channels_out": report.dim_out,
            "pca_kept": report.pca_kept,
            "pca_basis": basis_path.map(|p| p.display().to_string()),
            "unseen": uplifted.unseen.len(),
            "unseen_first": uplifted.unseen.iter().take(10).collect::<Vec<_>>(),
            "blends": report.blends,
            "refine_loss": report.losses,
            "seconds": start.elapsed().as_secs_f64(),
            "out": args.out.display().to_string(),
        })
    );
    Ok(())
}

/// `<out stem>.pca.npy` beside the output.
fn pca_path(out: &Path) -> PathBuf {
    let stem = out.file_stem().map(|s| s.to_string_lossy().into_owned());
    out.with_file_name(format!("{}.pca.npy", stem.unwrap_or_default()))
}

/// Writes through a temporary file beside `path`, renamed into place only when complete, so a
/// failure never leaves a truncated output over an earlier good one.
fn write_atomically(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".partial");
    let tmp = PathBuf::from(tmp);
    write(&tmp).with_context(|| format!("writing {}", path.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("renaming into {}", path.display()))
}
