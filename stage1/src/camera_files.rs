//! Which camera file a path is, and the reader for it: `transforms.json` ([`crate::cameras`]) or
//! a COLMAP model ([`crate::colmap`]).

use std::path::Path;

use crate::cameras::{CameraFileError, CameraSet};
use crate::colmap;

/// Reads cameras from `path`: a `.json` file is read as `transforms.json`, a folder as a COLMAP
/// model (text preferred over binary; `sparse/0` inside it is tried too). `image_size_px` is used
/// for `transforms.json` frames that state no `w`/`h` and whose image file cannot be read.
///
/// # Errors
/// [`CameraFileError`] naming the file and the line, frame or record that is wrong.
pub fn read_cameras(
    path: &Path,
    image_size_px: Option<[u32; 2]>,
) -> Result<CameraSet, CameraFileError> {
    if path.is_file() {
        return crate::cameras::read_transforms_json(path, image_size_px);
    }
    for dir in [path.to_path_buf(), path.join("sparse").join("0")] {
        if dir.join("cameras.txt").is_file() && dir.join("images.txt").is_file() {
            return colmap::read_text(&dir);
        }
        if dir.join("cameras.bin").is_file() && dir.join("images.bin").is_file() {
            return colmap::read_binary(&dir);
        }
    }
    Err(CameraFileError::Unrecognised {
        path: path.to_path_buf(),
    })
}
