//! splatphys stage 1: per-Gaussian semantic features from 2-D feature maps of the training views
//! (the paper's stage 1, following Feature Splatting, Qiu et al. 2024), so objects can be
//! selected by a text query (`splatphys_core::selection::semantic`).
//!
//! The path reads as the module tree: [`camera_files`], [`cameras`] and [`colmap`] (training
//! views from `transforms.json` or a COLMAP model) and [`feature_map`] (`[H'][W'][D]` `.npy` per view) ->
//! optional [`pca`] (uncentred, to k channels) -> [`uplift`] (learning-free weighted means
//! through the rasterizer's blending weights) -> optional [`refine`] (cosine loss of rendered
//! features) -> [`output`] (PLY `feat_*` properties or a sidecar `.npy`). [`pipeline`] runs the
//! whole path; `splatphys uplift` (app/src/uplift.rs) is its command line.

pub mod camera_files;
pub mod cameras;
pub mod colmap;
pub mod feature_map;
pub mod output;
pub mod pca;
pub mod pipeline;
pub mod refine;
pub mod uplift;

pub use camera_files::read_cameras;
pub use cameras::{CameraSet, TrainingView};
pub use feature_map::FeatureMap;
pub use pipeline::{Job, Report, Stage1Error, run};
pub use uplift::{Accumulator, ProjectedView, UpliftSettings, Uplifted, render_features};
