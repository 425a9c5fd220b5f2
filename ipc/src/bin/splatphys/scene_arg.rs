//! Loading the scene a command names, or the built-in default scene when it names none.

use std::path::Path;

use anyhow::{Context, Result, bail};
use splatphys_core::scene::{Scene, load_scene};

/// Loads `path` (or the built-in default), applying a duration override. Returns the scene's name
/// (the file stem, or "default") and the scene.
pub fn load(path: Option<&Path>, duration_s: Option<f64>) -> Result<(String, Scene)> {
    let (name, mut scene) = match path {
        Some(p) => {
            let scene = load_scene(p).with_context(|| format!("loading scene {}", p.display()))?;
            let name = p
                .file_stem()
                .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
            (name, scene)
        }
        None => ("default".to_string(), Scene::builtin_default()),
    };
    if let Some(d) = duration_s {
        if !(d.is_finite() && d > 0.0) {
            bail!("--duration-s {d} must be a positive number of seconds");
        }
        scene.simulation.duration_s = d;
    }
    Ok((name, scene))
}
