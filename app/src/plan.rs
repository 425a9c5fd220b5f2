//! [`RunPlan`]: everything the parent of `splatphys run` needs, read once from the scene without
//! building a world (the server process builds the one world of a multi-process run).

use std::ffi::OsString;
use std::path::{Path, PathBuf};

use anyhow::Result;
use splatphys_core::scene::{CameraSpec, Scene, load_named};

use crate::child_args::{opt, vec3};

/// The plan of one `splatphys run`.
#[derive(Debug, Clone)]
pub struct RunPlan {
    /// Scene name (file stem, or `default`).
    pub name: String,
    /// Scene file; `None` for the built-in default scene.
    pub scene_path: Option<PathBuf>,
    /// Duration override, seconds.
    pub duration_s: Option<f64>,
    /// Published frames after the initial one: duration × frame rate.
    pub total_frames: u64,
    /// The scene's first camera, if it names one.
    pub camera: Option<CameraSpec>,
    /// Object names, indexed by object id.
    pub object_names: Vec<String>,
    /// Service prefix of the run.
    pub prefix: String,
}

impl RunPlan {
    /// Loads the scene (validating it, for a clear error before any process starts) and plans.
    ///
    /// # Errors
    /// Scene errors, naming the file and key.
    pub fn new(
        scene_path: Option<&Path>,
        duration_s: Option<f64>,
        prefix: Option<String>,
    ) -> Result<(Self, Scene)> {
        let (name, scene) = load_named(scene_path, duration_s)?;
        for w in &scene.warnings {
            eprintln!("splatphys: warning: {w}");
        }
        let s = &scene.simulation;
        let plan = Self {
            name,
            scene_path: scene_path.map(Path::to_path_buf),
            duration_s,
            total_frames: (s.duration_s * s.frame_rate_hz).round().max(0.0) as u64,
            camera: scene.cameras.first().cloned(),
            object_names: scene.objects.iter().map(|o| o.name.clone()).collect(),
            prefix: prefix.unwrap_or_else(|| format!("splatphys/run-{}", std::process::id())),
        };
        Ok((plan, scene))
    }

    /// The renderer's camera flags for the scene's camera (none when the scene names no camera:
    /// the renderer frames the scene itself).
    pub fn camera_args(&self) -> Vec<OsString> {
        camera_args(self.camera.as_ref())
    }
}

/// The camera flags of `splatphys-render` and `splatphys-web` for `camera` (none for `None`),
/// one `--flag=value` word each.
pub fn camera_args(camera: Option<&CameraSpec>) -> Vec<OsString> {
    let Some(cam) = camera else {
        return Vec::new();
    };
    vec![
        opt("--camera-pos", vec3(cam.position_m)),
        opt("--look-at", vec3(cam.look_at_m)),
        opt("--up", vec3(cam.up)),
        opt("--fov-deg", cam.fov_y_deg),
        opt("--width", cam.width_px),
        opt("--height", cam.height_px),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_scene_plan_counts_frames_and_names_objects_without_a_world() {
        let (plan, scene) = RunPlan::new(None, Some(0.5), Some("p".into())).unwrap();
        assert_eq!(plan.name, "default");
        assert_eq!(
            plan.total_frames,
            (0.5 * scene.simulation.frame_rate_hz).round() as u64
        );
        assert_eq!(plan.object_names.len(), scene.objects.len());
        assert!(!plan.object_names.is_empty());
        assert_eq!(plan.prefix, "p");
        let args = plan.camera_args();
        assert_eq!(args.len(), if plan.camera.is_some() { 6 } else { 0 });
    }
}
