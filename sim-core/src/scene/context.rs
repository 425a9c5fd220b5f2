//! Where a scene is being built from: every error names the file and the key path.

use std::path::Path;

use super::SceneError;

/// Where a scene is being built from, for errors.
pub(super) struct Ctx<'a> {
    /// The scene file (or `<scene>` / `<builder>`).
    pub(super) file: &'a Path,
}

impl Ctx<'_> {
    pub(super) fn invalid(
        &self,
        key_path: impl Into<String>,
        message: impl Into<String>,
    ) -> SceneError {
        SceneError::Invalid {
            file: self.file.to_path_buf(),
            key_path: key_path.into(),
            message: message.into(),
        }
    }
    pub(super) fn check(
        &self,
        ok: bool,
        key: impl Into<String>,
        msg: impl Into<String>,
    ) -> Result<(), SceneError> {
        if ok {
            Ok(())
        } else {
            Err(self.invalid(key, msg))
        }
    }
    pub(super) fn finite3(&self, v: [f32; 3], key: String) -> Result<(), SceneError> {
        self.check(v.iter().all(|x| x.is_finite()), key, "must be finite")
    }
}
