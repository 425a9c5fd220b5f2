//! Training-view cameras: NeRF-style `transforms.json` (Mildenhall et al. 2020, as written by
//! Blender, instant-ngp and nerfstudio) and COLMAP sparse models (Schönberger & Frahm 2016;
//! `cameras.txt`/`images.txt` or `cameras.bin`/`images.bin`), turned into the rasterizer's
//! [`ViewParams`] (OpenCV view frame: x right, y down, z forward; pixel centres at integers).
//!
//! Conventions converted here:
//! - `transform_matrix` is camera-to-world in the OpenGL frame (x right, y up, z backwards), so
//!   the view rotation's rows are (x, −y, −z) of its columns and the camera sits at its
//!   translation.
//! - COLMAP stores world-to-camera `x_cam = R(q) x_world + t` in the OpenCV frame: the rotation is
//!   R(q) and the camera sits at −Rᵀt.
//! - Both put the image's top-left corner at (0, 0), so a pixel centre is at +0.5; the principal
//!   point is shifted by −0.5 into the rasterizer's integer-centred pixels.
//!
//! Only pinhole projection is modelled: COLMAP's radial and OpenCV distortion terms are ignored
//! with a warning (3DGS trains on undistorted images, so its models are `PINHOLE` or
//! `SIMPLE_PINHOLE`); fisheye models are refused.

use std::path::{Path, PathBuf};

use glam::{Mat3, Quat, Vec3};
use splatphys_render::camera::ViewParams;

/// Why the cameras could not be read.
#[derive(Debug, thiserror::Error)]
pub enum CameraFileError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The file's content is not what its format requires.
    #[error("{path}: {message}")]
    Malformed {
        /// The file.
        path: PathBuf,
        /// What was wrong and where (line, frame or record).
        message: String,
    },
    /// Neither a `.json` file nor a folder with a COLMAP model.
    #[error(
        "{path}: not a transforms.json file nor a folder with cameras.txt/images.txt or cameras.bin/images.bin (also looked in sparse/0)"
    )]
    Unrecognised {
        /// The path given.
        path: PathBuf,
    },
}

/// One training view.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainingView {
    /// The image's file stem (`r_0` for `./train/r_0.png`): its feature map is `<stem>.npy`.
    pub name: String,
    /// The rasterizer's camera for this view at the image's full resolution.
    pub view: ViewParams,
}

/// Cameras read from a file, with what was approximated.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraSet {
    /// The views in file order (COLMAP: sorted by image name).
    pub views: Vec<TrainingView>,
    /// Approximations made (ignored distortion...), one line each.
    pub warnings: Vec<String>,
}

/// Pinhole intrinsics in the file's pixel convention (top-left corner at 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intrinsics {
    /// Focal lengths, pixels.
    pub focal_px: [f64; 2],
    /// Principal point, pixels (corner-origin: a pixel centre is at +0.5).
    pub principal_px: [f64; 2],
    /// Image width and height, pixels.
    pub size_px: [u32; 2],
}

/// Builds the rasterizer's view from a world-to-camera rotation (OpenCV frame) and position.
pub fn view_params(world_to_camera: Mat3, position_m: Vec3, k: &Intrinsics) -> ViewParams {
    let [w, h] = k.size_px;
    ViewParams {
        rotation: world_to_camera,
        position: position_m,
        focal_px: [k.focal_px[0] as f32, k.focal_px[1] as f32],
        principal_px: [
            (k.principal_px[0] - 0.5) as f32,
            (k.principal_px[1] - 0.5) as f32,
        ],
        tan_half_fov: [
            (f64::from(w) / (2.0 * k.focal_px[0])) as f32,
            (f64::from(h) / (2.0 * k.focal_px[1])) as f32,
        ],
        size_px: [w, h],
    }
}

/// The same view rendered `factor` times smaller per axis (at least 1 pixel): focal lengths and
/// the corner-origin principal point scale by `1/factor`.
pub fn downscaled(view: &ViewParams, factor: f32) -> ViewParams {
    if !(factor > 1.0 && factor.is_finite()) {
        return *view;
    }
    let size = view
        .size_px
        .map(|s| ((s as f32 / factor).round() as u32).max(1));
    let sx = size[0] as f32 / view.size_px[0] as f32;
    let sy = size[1] as f32 / view.size_px[1] as f32;
    ViewParams {
        focal_px: [view.focal_px[0] * sx, view.focal_px[1] * sy],
        principal_px: [
            (view.principal_px[0] + 0.5) * sx - 0.5,
            (view.principal_px[1] + 0.5) * sy - 0.5,
        ],
        size_px: size,
        ..*view
    }
}

/// The stem of an image path (`./train/r_0.png` -> `r_0`).
pub fn image_stem(name: &str) -> String {
    Path::new(name)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| name.to_string())
}

pub(crate) fn read_transforms_json(
    path: &Path,
    image_size_px: Option<[u32; 2]>,
) -> Result<CameraSet, CameraFileError> {
    let malformed = |message: String| CameraFileError::Malformed {
        path: path.to_path_buf(),
        message,
    };
    let text = std::fs::read_to_string(path).map_err(|source| CameraFileError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let root: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| malformed(format!("not JSON: {e}")))?;
    let frames = root
        .get("frames")
        .and_then(|f| f.as_array())
        .ok_or_else(|| malformed("no `frames` array".into()))?;
    if frames.is_empty() {
        return Err(malformed("`frames` is empty".into()));
    }
    let base = path.parent().unwrap_or(Path::new("."));
    let mut views = Vec::with_capacity(frames.len());
    for (i, frame) in frames.iter().enumerate() {
        let at = |key: &str| format!("frames[{i}].{key}");
        // Per-frame values override the file's.
        let num = |key: &str| -> Result<Option<f64>, CameraFileError> {
            match frame.get(key).or_else(|| root.get(key)) {
                None | Some(serde_json::Value::Null) => Ok(None),
                Some(v) => v
                    .as_f64()
                    .filter(|x| x.is_finite())
                    .map(Some)
                    .ok_or_else(|| malformed(format!("{} is not a finite number", at(key)))),
            }
        };
        let file_path = frame
            .get("file_path")
            .and_then(|p| p.as_str())
            .ok_or_else(|| malformed(format!("{} is missing", at("file_path"))))?;
        let size = match (num("w")?, num("h")?) {
            (Some(w), Some(h)) if w >= 1.0 && h >= 1.0 => [w as u32, h as u32],
            (Some(_), Some(_)) => {
                return Err(malformed(format!("{} / h must be >= 1 pixel", at("w"))));
            }
            _ => image_size(base, file_path)
                .or(image_size_px)
                .ok_or_else(|| {
                    malformed(format!(
                        "{}: no `w`/`h` and the image {file_path} could not be read; pass --image-size WxH",
                        at("w")
                    ))
                })?,
        };
        let fx = match (num("fl_x")?, num("camera_angle_x")?) {
            (Some(f), _) => f,
            (None, Some(a)) if a > 0.0 && a < std::f64::consts::PI => {
                0.5 * f64::from(size[0]) / (0.5 * a).tan()
            }
            _ => {
                return Err(malformed(format!(
                    "{}: neither `fl_x` nor a `camera_angle_x` in (0, pi)",
                    at("fl_x")
                )));
            }
        };
        let fy = match (num("fl_y")?, num("camera_angle_y")?) {
            (Some(f), _) => f,
            (None, Some(a)) if a > 0.0 && a < std::f64::consts::PI => {
                0.5 * f64::from(size[1]) / (0.5 * a).tan()
            }
            _ => fx,
        };
        if !(fx > 0.0 && fy > 0.0) {
            return Err(malformed(format!(
                "{}: focal lengths must be positive, got {fx}, {fy}",
                at("fl_x")
            )));
        }
        let cx = num("cx")?.unwrap_or(0.5 * f64::from(size[0]));
        let cy = num("cy")?.unwrap_or(0.5 * f64::from(size[1]));
        let m = frame
            .get("transform_matrix")
            .and_then(|m| m.as_array())
            .filter(|rows| rows.len() >= 3)
            .ok_or_else(|| malformed(format!("{} must be a 4x4 array", at("transform_matrix"))))?;
        let mut c2w = [[0f32; 4]; 3];
        for (r, row) in m.iter().take(3).enumerate() {
            let row = row.as_array().filter(|v| v.len() == 4).ok_or_else(|| {
                malformed(format!(
                    "{}[{r}] must have 4 numbers",
                    at("transform_matrix")
                ))
            })?;
            for (c, v) in row.iter().enumerate() {
                c2w[r][c] = v.as_f64().filter(|x| x.is_finite()).ok_or_else(|| {
                    malformed(format!(
                        "{}[{r}][{c}] is not a finite number",
                        at("transform_matrix")
                    ))
                })? as f32;
            }
        }
        let col = |c: usize| Vec3::new(c2w[0][c], c2w[1][c], c2w[2][c]);
        let (right, up, back) = (col(0), col(1), col(2));
        let (right, down, forward) = (
            right.normalize_or_zero(),
            -up.normalize_or_zero(),
            -back.normalize_or_zero(),
        );
        if right == Vec3::ZERO || down == Vec3::ZERO || forward == Vec3::ZERO {
            return Err(malformed(format!(
                "{} has a zero rotation column",
                at("transform_matrix")
            )));
        }
        let rotation = Mat3::from_cols(right, down, forward).transpose();
        let k = Intrinsics {
            focal_px: [fx, fy],
            principal_px: [cx, cy],
            size_px: size,
        };
        views.push(TrainingView {
            name: image_stem(file_path),
            view: view_params(rotation, col(3), &k),
        });
    }
    Ok(CameraSet {
        views,
        warnings: Vec::new(),
    })
}

/// Size of the image `file_path` (relative to `base`, extension optional as in Blender's
/// transforms files), when it can be read.
fn image_size(base: &Path, file_path: &str) -> Option<[u32; 2]> {
    let p = base.join(file_path);
    [
        p.clone(),
        p.with_extension("png"),
        p.with_extension("jpg"),
        p.with_extension("jpeg"),
    ]
    .iter()
    .find_map(|c| image::image_dimensions(c).ok())
    .map(|(w, h)| [w, h])
}

/// World-to-camera rotation of a COLMAP quaternion `qw qx qy qz`, normalised; `None` when it is
/// zero or not finite.
pub fn colmap_rotation(q: [f64; 4]) -> Option<Mat3> {
    let q = Quat::from_xyzw(q[1] as f32, q[2] as f32, q[3] as f32, q[0] as f32);
    let n = q.length();
    (n.is_finite() && n > 1e-6).then(|| Mat3::from_quat(q / n))
}
