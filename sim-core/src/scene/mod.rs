//! The scene: a TOML file (docs/reference/scene-format.md) naming 3DGS sources and their
//! world transforms, the objects selected from them or built procedurally, materials, colliders,
//! scripted events, cameras and simulation settings, built into a plain-data [`Scene`].
//!
//! - [`schema`]: the file as written (serde, unknown keys refused);
//! - [`model`]: the built scene the simulation consumes;
//! - [`build`]: loading sources, selecting objects, validation;
//! - [`transform`]: similarity transforms, subsets, voxel subsampling;
//! - [`builder`]: scenes in code ([`Scene::builder`]), validated as a file is;
//! - [`builtin`]: the procedural default scene.
//!
//! ```no_run
//! let scene = splatphys_core::scene::load_scene("scenes/donut_drop.toml")?;
//! println!("{} objects, {} particles", scene.objects.len(), scene.particle_count());
//! # Ok::<(), splatphys_core::scene::SceneError>(())
//! ```

pub mod build;
pub mod builder;
pub mod builtin;
mod context;
mod events;
pub mod level_of_detail;
pub mod model;
pub mod schema;
pub mod transform;
pub mod up;

use std::path::{Path, PathBuf};

pub use build::build_scene;
pub use builder::{ObjectBuilder, SceneBuilder};
pub use level_of_detail::LevelOfDetail;
pub use model::{
    CameraSpec, ColliderShape, ColliderSpec, Command, Device, EventSpec, MaterialSpec, Method,
    ObjectKind, Scene, SceneObject, SimulationSettings, Surface, SurfaceContact,
};

use crate::formats::FormatError;
use crate::procedural::ProceduralError;
use crate::selection::SelectionError;

/// Why a scene could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The scene file could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The scene file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// TOML syntax error, unknown key or wrong type.
    #[error("{}:{line}:{column}: key `{key_path}`: {message}", file.display())]
    Toml {
        /// The scene file.
        file: PathBuf,
        /// 1-based line (0 when unknown).
        line: usize,
        /// 1-based column (0 when unknown).
        column: usize,
        /// Dotted key path, e.g. `object[0].material.model` (`.` for the root).
        key_path: String,
        /// What is wrong.
        message: String,
    },
    /// A value is out of range or refers to something that does not exist.
    #[error("{}: key `{key_path}`: {message}", file.display())]
    Invalid {
        /// The scene file.
        file: PathBuf,
        /// Dotted key path.
        key_path: String,
        /// What is wrong.
        message: String,
    },
    /// A source file could not be read.
    #[error("{}: key `{key_path}`: {source}", file.display())]
    Source {
        /// The scene file.
        file: PathBuf,
        /// The source's key path (`source[1].path`).
        key_path: String,
        /// The format error (names the 3DGS file, element and property).
        source: Box<FormatError>,
    },
    /// An object's selection failed.
    #[error("{}: key `{key_path}`: {source}", file.display())]
    Selection {
        /// The scene file.
        file: PathBuf,
        /// The object's key path.
        key_path: String,
        /// The selection error.
        source: Box<SelectionError>,
    },
    /// A procedural shape could not be filled.
    #[error("{}: key `{key_path}`: {source}", file.display())]
    Procedural {
        /// The scene file.
        file: PathBuf,
        /// The object's key path.
        key_path: String,
        /// The procedural error.
        source: ProceduralError,
    },
}

/// 1-based (line, column) of byte offset `at` in `text`.
fn line_col(text: &str, at: usize) -> (usize, usize) {
    let at = at.min(text.len());
    let before = &text.as_bytes()[..at];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let col = at
        - before
            .iter()
            .rposition(|&b| b == b'\n')
            .map_or(0, |p| p + 1)
        + 1;
    (line, col)
}

/// Parses scene TOML `text` (from `file`, used in errors) into the schema, without loading data.
///
/// # Errors
/// [`SceneError::Toml`] with the key path, line and column.
pub fn parse_scene_toml(file: &Path, text: &str) -> Result<schema::SceneFile, SceneError> {
    let toml_err = |key_path: String, e: &toml::de::Error| {
        let (line, column) = e.span().map_or((0, 0), |s| line_col(text, s.start));
        SceneError::Toml {
            file: file.to_path_buf(),
            line,
            column,
            key_path,
            message: e.message().to_string(),
        }
    };
    let de = toml::Deserializer::parse(text).map_err(|e| toml_err(".".into(), &e))?;
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        toml_err(path, e.inner())
    })
}

/// Reads, parses and builds the scene file at `path` (source paths relative to its folder).
///
/// # Errors
/// Any [`SceneError`].
pub fn load_scene(path: impl AsRef<Path>) -> Result<Scene, SceneError> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let parsed = parse_scene_toml(path, &text)?;
    let base = path.parent().unwrap_or(Path::new("."));
    build_scene(path, base, &parsed)
}

/// Parses and builds scene TOML `text`; relative paths resolve against `base_dir`.
///
/// # Errors
/// Any [`SceneError`].
pub fn load_scene_str(text: &str, base_dir: &Path) -> Result<Scene, SceneError> {
    let file = Path::new("<scene>");
    let parsed = parse_scene_toml(file, text)?;
    build_scene(file, base_dir, &parsed)
}

/// Loads the scene file at `path`, or the built-in default scene when `path` is `None`, and
/// applies a duration override. Returns the scene's name (the file stem, or `"default"`) and the
/// scene: what every command that takes an optional scene argument does.
///
/// # Errors
/// Any [`SceneError`] of [`load_scene`]; [`SceneError::Invalid`] at `simulation.duration_s` when
/// `duration_s` is not a positive number of seconds.
pub fn load_named(
    path: Option<&Path>,
    duration_s: Option<f64>,
) -> Result<(String, Scene), SceneError> {
    let (name, mut scene) = match path {
        Some(p) => {
            let name = p
                .file_stem()
                .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
            (name, load_scene(p)?)
        }
        None => ("default".to_string(), Scene::builtin_default()),
    };
    if let Some(d) = duration_s {
        if !(d.is_finite() && d > 0.0) {
            return Err(SceneError::Invalid {
                file: path.map_or_else(|| PathBuf::from("<default>"), Path::to_path_buf),
                key_path: "simulation.duration_s".into(),
                message: format!("duration override {d} must be a positive number of seconds"),
            });
        }
        scene.simulation.duration_s = d;
    }
    Ok((name, scene))
}
