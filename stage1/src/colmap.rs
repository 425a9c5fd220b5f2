//! COLMAP sparse models (Schönberger & Frahm 2016; format: COLMAP's `src/colmap/scene/
//! reconstruction_io.cc`): `cameras.txt` (`CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]`) and
//! `images.txt` (`IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME`, then one line of 2-D points), or
//! their binary twins `cameras.bin` / `images.bin` (little-endian; the model as an integer id).
//! See [`crate::cameras`] for the frame conventions.

use std::collections::BTreeMap;
use std::path::Path;

use glam::{DVec3, Vec3};

use crate::cameras::{
    CameraFileError, CameraSet, Intrinsics, TrainingView, colmap_rotation, image_stem, view_params,
};

/// A camera model: name, binary id, parameter count, whether it is a pinhole with distortion
/// terms that are ignored here, and whether it is a fisheye (refused).
struct Model {
    name: &'static str,
    id: i32,
    params: usize,
    fisheye: bool,
}

const MODELS: [Model; 11] = [
    model("SIMPLE_PINHOLE", 0, 3, false),
    model("PINHOLE", 1, 4, false),
    model("SIMPLE_RADIAL", 2, 4, false),
    model("RADIAL", 3, 5, false),
    model("OPENCV", 4, 8, false),
    model("OPENCV_FISHEYE", 5, 8, true),
    model("FULL_OPENCV", 6, 12, false),
    model("FOV", 7, 5, true),
    model("SIMPLE_RADIAL_FISHEYE", 8, 4, true),
    model("RADIAL_FISHEYE", 9, 5, true),
    model("THIN_PRISM_FISHEYE", 10, 12, true),
];

const fn model(name: &'static str, id: i32, params: usize, fisheye: bool) -> Model {
    Model {
        name,
        id,
        params,
        fisheye,
    }
}

/// Intrinsics of one camera from its model and parameters; a note when distortion is ignored.
fn intrinsics(
    m: &Model,
    size: [u32; 2],
    p: &[f64],
) -> Result<(Intrinsics, Option<String>), String> {
    if m.fisheye {
        return Err(format!(
            "camera model {} is a fisheye; undistort the images first (colmap image_undistorter)",
            m.name
        ));
    }
    if p.len() != m.params {
        return Err(format!(
            "camera model {} needs {} parameters, got {}",
            m.name,
            m.params,
            p.len()
        ));
    }
    // SIMPLE_* and RADIAL share one focal length: f, cx, cy, ...
    let (f, c) = match m.name {
        "SIMPLE_PINHOLE" | "SIMPLE_RADIAL" | "RADIAL" => ([p[0], p[0]], [p[1], p[2]]),
        _ => ([p[0], p[1]], [p[2], p[3]]),
    };
    if !(f[0] > 0.0 && f[1] > 0.0 && c.iter().all(|v| v.is_finite())) {
        return Err(format!(
            "focal lengths {f:?} must be positive and the principal point finite"
        ));
    }
    if size[0] == 0 || size[1] == 0 {
        return Err(format!("image size {}x{} is empty", size[0], size[1]));
    }
    let note = (!matches!(m.name, "SIMPLE_PINHOLE" | "PINHOLE")).then(|| {
        format!(
            "camera model {}: distortion parameters ignored (features will be slightly misplaced near the image edges)",
            m.name
        )
    });
    Ok((
        Intrinsics {
            focal_px: f,
            principal_px: c,
            size_px: size,
        },
        note,
    ))
}

/// One image record before the camera is attached.
struct Image {
    q: [f64; 4],
    t: [f64; 3],
    camera: i64,
    name: String,
}

fn assemble(
    dir: &Path,
    cameras_file: &str,
    cameras: BTreeMap<i64, (Intrinsics, Option<String>)>,
    mut images: Vec<Image>,
    images_file: &str,
) -> Result<CameraSet, CameraFileError> {
    images.sort_by(|a, b| a.name.cmp(&b.name));
    let mut warnings: Vec<String> = cameras
        .values()
        .filter_map(|(_, note)| note.clone())
        .collect();
    warnings.dedup();
    let mut views = Vec::with_capacity(images.len());
    for img in &images {
        let malformed = |message: String| CameraFileError::Malformed {
            path: dir.join(images_file),
            message,
        };
        let (k, _) = cameras.get(&img.camera).ok_or_else(|| {
            malformed(format!(
                "image {} uses camera {} which {cameras_file} does not define",
                img.name, img.camera
            ))
        })?;
        let r = colmap_rotation(img.q)
            .ok_or_else(|| malformed(format!("image {}: zero quaternion", img.name)))?;
        let t = DVec3::from_array(img.t);
        if !t.is_finite() {
            return Err(malformed(format!(
                "image {}: translation not finite",
                img.name
            )));
        }
        // Camera centre −Rᵀ t, in f64 before rounding.
        let rd = r.as_dmat3();
        let centre: Vec3 = (-(rd.transpose() * t)).as_vec3();
        views.push(TrainingView {
            name: image_stem(&img.name),
            view: view_params(r, centre, k),
        });
    }
    if views.is_empty() {
        return Err(CameraFileError::Malformed {
            path: dir.join(images_file),
            message: "no images".into(),
        });
    }
    Ok(CameraSet { views, warnings })
}

/// Reads `cameras.txt` and `images.txt` from `dir`.
///
/// # Errors
/// [`CameraFileError`] naming the file and line.
pub fn read_text(dir: &Path) -> Result<CameraSet, CameraFileError> {
    let read = |name: &str| {
        std::fs::read_to_string(dir.join(name)).map_err(|source| CameraFileError::Io {
            path: dir.join(name),
            source,
        })
    };
    let text = read("cameras.txt")?;
    let mut cameras = BTreeMap::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let malformed = |message: String| CameraFileError::Malformed {
            path: dir.join("cameras.txt"),
            message: format!("line {}: {message}", n + 1),
        };
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.len() < 4 {
            return Err(malformed(
                "expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]".into(),
            ));
        }
        let id: i64 = f[0]
            .parse()
            .map_err(|_| malformed(format!("camera id {:?}", f[0])))?;
        let m = MODELS
            .iter()
            .find(|m| m.name == f[1])
            .ok_or_else(|| malformed(format!("unknown camera model {}", f[1])))?;
        let size = [f[2], f[3]].map(|v| v.parse::<u32>().ok());
        let [Some(w), Some(h)] = size else {
            return Err(malformed(format!("image size {} {}", f[2], f[3])));
        };
        let params = f[4..]
            .iter()
            .map(|v| v.parse::<f64>())
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| malformed(format!("parameter: {e}")))?;
        cameras.insert(id, intrinsics(m, [w, h], &params).map_err(malformed)?);
    }

    let text = read("images.txt")?;
    let mut images = Vec::new();
    let mut expect_points = false;
    for (n, line) in text.lines().enumerate() {
        if line.trim_start().starts_with('#') {
            continue;
        }
        // Every image line is followed by one (possibly empty) line of 2-D points.
        if expect_points {
            expect_points = false;
            continue;
        }
        if line.trim().is_empty() {
            continue;
        }
        let malformed = |message: String| CameraFileError::Malformed {
            path: dir.join("images.txt"),
            message: format!("line {}: {message}", n + 1),
        };
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.len() < 10 {
            return Err(malformed(
                "expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME".into(),
            ));
        }
        let num = |s: &str| {
            s.parse::<f64>()
                .map_err(|_| malformed(format!("not a number: {s:?}")))
        };
        images.push(Image {
            q: [num(f[1])?, num(f[2])?, num(f[3])?, num(f[4])?],
            t: [num(f[5])?, num(f[6])?, num(f[7])?],
            camera: f[8]
                .parse()
                .map_err(|_| malformed(format!("camera id {:?}", f[8])))?,
            // Names may contain spaces: everything after the camera id.
            name: f[9..].join(" "),
        });
        expect_points = true;
    }
    assemble(dir, "cameras.txt", cameras, images, "images.txt")
}

/// A little-endian reader over a byte slice that names the file and offset in errors.
struct Bytes<'a> {
    data: &'a [u8],
    at: usize,
    path: &'a Path,
}

impl Bytes<'_> {
    fn take<const N: usize>(&mut self, what: &str) -> Result<[u8; N], CameraFileError> {
        let end = self.at + N;
        let bytes = self
            .data
            .get(self.at..end)
            .ok_or_else(|| CameraFileError::Malformed {
                path: self.path.to_path_buf(),
                message: format!("truncated at byte {} reading {what}", self.at),
            })?;
        self.at = end;
        let mut out = [0u8; N];
        out.copy_from_slice(bytes);
        Ok(out)
    }
    fn u64(&mut self, what: &str) -> Result<u64, CameraFileError> {
        self.take::<8>(what).map(u64::from_le_bytes)
    }
    fn i32(&mut self, what: &str) -> Result<i32, CameraFileError> {
        self.take::<4>(what).map(i32::from_le_bytes)
    }
    fn f64(&mut self, what: &str) -> Result<f64, CameraFileError> {
        self.take::<8>(what).map(f64::from_le_bytes)
    }
    fn malformed(&self, message: String) -> CameraFileError {
        CameraFileError::Malformed {
            path: self.path.to_path_buf(),
            message: format!("byte {}: {message}", self.at),
        }
    }
}

/// Reads `cameras.bin` and `images.bin` from `dir`.
///
/// # Errors
/// [`CameraFileError`] naming the file and byte offset.
pub fn read_binary(dir: &Path) -> Result<CameraSet, CameraFileError> {
    let read = |name: &str| {
        std::fs::read(dir.join(name)).map_err(|source| CameraFileError::Io {
            path: dir.join(name),
            source,
        })
    };
    let data = read("cameras.bin")?;
    let path = dir.join("cameras.bin");
    let mut b = Bytes {
        data: &data,
        at: 0,
        path: &path,
    };
    let count = b.u64("camera count")?;
    let mut cameras = BTreeMap::new();
    for _ in 0..count {
        let id = b.i32("camera id")?;
        let model_id = b.i32("model id")?;
        let m = MODELS
            .iter()
            .find(|m| m.id == model_id)
            .ok_or_else(|| b.malformed(format!("unknown camera model id {model_id}")))?;
        let w = b.u64("width")?;
        let h = b.u64("height")?;
        let params = (0..m.params)
            .map(|_| b.f64("camera parameter"))
            .collect::<Result<Vec<_>, _>>()?;
        let size = [u32::try_from(w), u32::try_from(h)];
        let [Ok(w), Ok(h)] = size else {
            return Err(b.malformed(format!("image size {w}x{h} too large")));
        };
        let k = intrinsics(m, [w, h], &params).map_err(|e| b.malformed(e))?;
        cameras.insert(i64::from(id), k);
    }

    let data = read("images.bin")?;
    let path = dir.join("images.bin");
    let mut b = Bytes {
        data: &data,
        at: 0,
        path: &path,
    };
    let count = b.u64("image count")?;
    let mut images = Vec::new();
    for _ in 0..count {
        let _id = b.i32("image id")?;
        let q = [b.f64("qw")?, b.f64("qx")?, b.f64("qy")?, b.f64("qz")?];
        let t = [b.f64("tx")?, b.f64("ty")?, b.f64("tz")?];
        let camera = i64::from(b.i32("camera id")?);
        let rest = &data[b.at..];
        let len = rest
            .iter()
            .position(|&c| c == 0)
            .ok_or_else(|| b.malformed("image name without a terminating NUL".into()))?;
        let name = String::from_utf8_lossy(&rest[..len]).into_owned();
        b.at += len + 1;
        let points = b.u64("2-D point count")?;
        // Each point: x, y (f64) and a 3-D point id (i64).
        let skip = usize::try_from(points)
            .ok()
            .and_then(|p| p.checked_mul(24))
            .filter(|s| b.at + s <= data.len())
            .ok_or_else(|| b.malformed(format!("{points} 2-D points run past the end")))?;
        b.at += skip;
        images.push(Image { q, t, camera, name });
    }
    assemble(dir, "cameras.bin", cameras, images, "images.bin")
}
