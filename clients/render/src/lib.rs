//! splatphys-render: a CPU rasterizer for 3D Gaussian Splatting (Kerbl et al. 2023, "3D Gaussian
//! Splatting for Real-Time Radiance Field Rendering", SIGGRAPH 2023), following the reference CUDA
//! rasterizer (`diff-gaussian-rasterization`, `forward.cu`) step by step.
//!
//! The pipeline reads as the module tree: [`splats`] (the struct-of-arrays input) and [`camera`]
//! (pinhole, [`framing`] of bounds, [`orbit`] paths) -> [`project`] (EWA projection of each
//! Gaussian, Zwicker et al. 2001, eq. 29-31 of the 3DGS paper; colour from [`sh`]) -> [`tiles`]
//! (16×16 tile binning) -> [`raster`] (per-tile depth sort, front-to-back alpha blending, eq. 2-3
//! of the 3DGS paper) -> [`image`] -> [`output`] (PNG, GIF, MP4 through ffmpeg).
//!
//! ```
//! use splatphys_render::{Camera, RenderSettings, SplatView, render};
//! use glam::Vec3;
//!
//! // One grey Gaussian, 1 cm standard deviation, 1 m in front of the camera.
//! let positions = [[0.0, 0.0, 0.0]];
//! let covariances = [[1e-4, 0.0, 0.0, 1e-4, 0.0, 1e-4]];
//! let opacities = [0.9];
//! let sh = [[0.0, 0.0, 0.0]]; // degree 0: one RGB triple per Gaussian, colour = 0.5
//! let splats = SplatView::new(&positions, &covariances, &opacities, &sh, 0, &[]).unwrap();
//! let camera = Camera::new(Vec3::new(1.0, 0.0, 0.0), Vec3::ZERO, Vec3::Z, 50.0, 64, 48).unwrap();
//! let image = render(&splats, &camera, &RenderSettings::default()).unwrap();
//! let rgb8 = image.to_rgb8();
//! assert_eq!(rgb8.data.len(), 64 * 48 * 3);
//! ```

pub mod camera;
pub mod cli;
pub mod framing;
pub mod image;
pub mod orbit;
pub mod output;
pub mod project;
pub mod raster;
pub mod render;
pub mod report;
pub mod sh;
pub mod splats;
pub mod tiles;

pub use camera::{Camera, CameraError};
pub use framing::Bounds;
pub use image::{ImageF32, ImageRgb8};
pub use orbit::OrbitPath;
pub use output::{OutputError, write_gif, write_mp4, write_png};
pub use render::{RenderError, RenderSettings, render, render_rgb8};
pub use splats::{InputError, SplatView, Splats};
