//! The TOML scene file as written (serde, unknown keys refused). Documented key by key in
//! `docs/reference/scene-format.md`; [`super::build`] turns it into a [`super::Scene`].

use serde::Deserialize;

use crate::procedural::Shape;

use super::model::{ContactSolver, Device, Method, ObjectKind, Surface, SurfaceContact};

fn default_one() -> f32 {
    1.0
}
fn default_cfl() -> f64 {
    0.5
}
fn default_gravity() -> [f32; 3] {
    [0.0, 0.0, -9.81]
}
fn default_duration() -> f64 {
    2.0
}
fn default_frame_rate() -> f64 {
    30.0
}
fn default_dx() -> f64 {
    0.01
}

/// The whole file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// `[simulation]`.
    #[serde(default)]
    pub simulation: SimulationToml,
    /// `[[source]]` entries.
    #[serde(default)]
    pub source: Vec<SourceToml>,
    /// `[[object]]` entries.
    #[serde(default)]
    pub object: Vec<ObjectToml>,
    /// `[[collider]]` entries.
    #[serde(default)]
    pub collider: Vec<ColliderToml>,
    /// `[[event]]` entries.
    #[serde(default)]
    pub event: Vec<toml::Table>,
    /// `[[camera]]` entries.
    #[serde(default)]
    pub camera: Vec<super::model::CameraSpec>,
}

/// `[simulation]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimulationToml {
    /// Method.
    #[serde(default)]
    pub method: Method,
    /// Where deformable objects' MPM runs.
    #[serde(default)]
    pub device: Device,
    /// Simulated time, s.
    #[serde(default = "default_duration")]
    pub duration_s: f64,
    /// Published frames per simulated second, Hz.
    #[serde(default = "default_frame_rate")]
    pub frame_rate_hz: f64,
    /// MPM grid spacing, m.
    #[serde(default = "default_dx")]
    pub grid_dx_m: f64,
    /// CFL number.
    #[serde(default = "default_cfl")]
    pub cfl: f64,
    /// Fixed substep, s.
    pub dt_s: Option<f64>,
    /// Use `dt_s` even above the CFL bound.
    #[serde(default)]
    pub force_dt: bool,
    /// Gravity, m/s².
    #[serde(default = "default_gravity")]
    pub gravity_m_s2: [f32; 3],
    /// Simulation domain `[min, max]`, m.
    pub domain_m: Option<[[f32; 3]; 2]>,
    /// RNG seed for jitter, RANSAC, subsampling.
    #[serde(default)]
    pub seed: u64,
    /// Default physics-particle spacing of deformable and rigid objects, m.
    pub physics_spacing_m: Option<f32>,
    /// Let still objects sleep.
    #[serde(default = "default_true")]
    pub sleep: bool,
    /// Objects out of each other's reach step apart, each island at its own substep.
    #[serde(default = "default_true")]
    pub islands: bool,
    /// The captured background collides.
    #[serde(default = "default_true")]
    pub background_collision: bool,
    /// Opacity a background Gaussian needs to be solid.
    #[serde(default = "default_background_opacity")]
    pub background_min_opacity: f32,
    /// Cell of the collision surfaces sampled from captured objects and the background, m.
    pub collision_dx_m: Option<f64>,
    /// Simulated frames per wall second that `splatphys run` coarsens deformable objects to meet.
    pub budget_fps: Option<f64>,
    /// How contacts between solids are solved.
    #[serde(default)]
    pub contact_solver: ContactSolver,
    /// How deformable material meets "separate" surfaces of immovable solids.
    #[serde(default)]
    pub surface_contact: SurfaceContact,
}

fn default_true() -> bool {
    true
}

fn default_background_opacity() -> f32 {
    0.5
}

impl Default for SimulationToml {
    fn default() -> Self {
        Self {
            method: Method::default(),
            device: Device::default(),
            duration_s: default_duration(),
            frame_rate_hz: default_frame_rate(),
            grid_dx_m: default_dx(),
            cfl: default_cfl(),
            dt_s: None,
            force_dt: false,
            gravity_m_s2: default_gravity(),
            domain_m: None,
            seed: 0,
            physics_spacing_m: None,
            sleep: true,
            islands: true,
            background_collision: true,
            background_min_opacity: default_background_opacity(),
            collision_dx_m: None,
            budget_fps: None,
            contact_solver: ContactSolver::default(),
            surface_contact: SurfaceContact::default(),
        }
    }
}

/// `[[source]]`: a 3DGS file placed in the world.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SourceToml {
    /// Unique name objects refer to.
    pub name: String,
    /// File path, relative to the scene file.
    pub path: String,
    /// Uniform scale (file units → m).
    #[serde(default = "default_one")]
    pub scale: f32,
    /// Euler angles x, y, z, degrees, applied in that order.
    #[serde(default)]
    pub rotation_deg: [f32; 3],
    /// Translation, m (applied after scale and rotation).
    #[serde(default)]
    pub translation_m: [f32; 3],
    /// Drop Gaussians with opacity below this (0..1) on load.
    #[serde(default)]
    pub min_opacity: f32,
    /// Keep at most one Gaussian (the most opaque) per cube of this side, m (world units).
    pub voxel_m: Option<f32>,
    /// Streamed SOG (`lod-meta.json`): the level to read, 0 the finest (the default).
    pub lod: Option<usize>,
    /// Which way is up in the file: `"auto"` (find the ground and level it at z = 0) or a
    /// direction `[x, y, z]` of the file's frame turned onto +z. Replaces `rotation_deg`.
    pub up: Option<UpToml>,
    /// SPZ: the frame its values are stored in, `"rub"` (the format's convention, the default)
    /// or `"as_stored"` (files written without the turn, as splat-transform writes them).
    pub spz_frame: Option<SpzFrameToml>,
}

/// `up` of a source: `"auto"` or a direction.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum UpToml {
    /// A word (only `"auto"` is known).
    Word(String),
    /// The file's up direction.
    Direction([f32; 3]),
}

/// `spz_frame` of a source.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SpzFrameToml {
    /// RUB (x right, y up, z back): turned into PLY's frame on reading.
    Rub,
    /// Values used as stored.
    AsStored,
}

/// `select = {...}`: which Gaussians form an object; present keys are intersected.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SelectToml {
    /// Only this source's Gaussians.
    pub source: Option<String>,
    /// Only Gaussians in this world box `[min, max]`, m.
    pub box_m: Option<[[f32; 3]; 2]>,
    /// Only Gaussians in this world sphere.
    pub sphere: Option<SphereToml>,
    /// Only Gaussians with opacity at least this.
    pub min_opacity: Option<f32>,
    /// Automatic: the k-th largest object on the support plane (0 = largest).
    pub auto: Option<usize>,
    /// Automatic: clustering link distance, m (default 0.01).
    pub cluster_eps_m: Option<f32>,
    /// Automatic: plane inlier tolerance, m (default 0.005).
    pub plane_tolerance_m: Option<f32>,
    /// Automatic: smallest cluster (default 50).
    pub min_cluster: Option<usize>,
    /// Semantic: the query phrase.
    pub query: Option<String>,
    /// Semantic: features `.npy` `[N][D]` (relative to the scene file); default PLY `feat_*`.
    pub features: Option<String>,
    /// Semantic: phrase embeddings (JSON or `.npy`).
    pub embeddings: Option<String>,
    /// Semantic: PCA basis `.npy` `[k][D]` (from `splatphys uplift --pca k`) when the features
    /// have k channels and the embeddings D.
    pub pca: Option<String>,
    /// Semantic: negative phrases (default: all other phrases in the file).
    pub negatives: Option<Vec<String>>,
    /// Semantic: probability threshold (default 0.6).
    pub threshold: Option<f32>,
    /// Semantic: softmax temperature (default 0.05).
    pub temperature: Option<f32>,
    /// Semantic: DBSCAN radius, m (default 0.02).
    pub eps_m: Option<f32>,
    /// Semantic: DBSCAN min samples (default 5).
    pub min_samples: Option<usize>,
    /// Semantic: kNN infill neighbours (default 8; 0 off).
    pub knn: Option<usize>,
}

/// A sphere for `select.sphere`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereToml {
    /// Centre, m.
    pub center_m: [f32; 3],
    /// Radius, m.
    pub radius_m: f32,
}

/// `material = {...}`: the material spec itself (unknown keys refused).
pub use crate::material::MaterialSpec as MaterialToml;

/// `[[object]]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectToml {
    /// Unique name.
    pub name: String,
    /// Gaussians from sources.
    pub select: Option<SelectToml>,
    /// Or a procedural shape.
    pub shape: Option<Shape>,
    /// Turns a procedural shape about its centre: Euler angles x, y, z in degrees (as sources).
    pub rotation_deg: Option<[f32; 3]>,
    /// Procedural lattice spacing, m.
    pub spacing_m: Option<f32>,
    /// Procedural colour, linear RGB 0..1.
    pub color: Option<[f32; 3]>,
    /// Dynamics kind.
    #[serde(default)]
    pub kind: ObjectKind,
    /// Material.
    pub material: Option<MaterialToml>,
    /// Coefficient of restitution e.
    pub restitution: Option<f32>,
    /// Coulomb friction coefficient.
    pub friction: Option<f32>,
    /// Rolling resistance b, m: the resisting couple is at most b times the normal force.
    pub rolling_resistance_m: Option<f32>,
    /// Boundary rule a static or rigid object imposes on deformable objects' grids.
    pub surface: Option<super::model::Surface>,
    /// Initial velocity, m/s.
    #[serde(default)]
    pub velocity_m_s: [f32; 3],
    /// Interior filling.
    pub fill: Option<FillToml>,
    /// Physics-particle spacing, m: one particle per occupied cube of this side.
    pub physics_spacing_m: Option<f32>,
    /// Its own MPM grid cell, m (method `com`).
    pub grid_dx_m: Option<f64>,
}

/// `fill = {...}` on an object.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FillToml {
    /// Fill grid spacing, m.
    pub spacing_m: f32,
    /// Opacity-density threshold for a cell to count as surface.
    pub density_threshold: Option<f32>,
    /// Hard limit on added particles.
    pub max_particles: Option<usize>,
    /// Largest seal of gaps in the surface, in fill cells (0: the plain ray test).
    pub max_seal_cells: Option<usize>,
}

/// `[[collider]]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColliderToml {
    /// Name.
    pub name: String,
    /// A plane, or `"auto"`: the support plane automatic selection finds.
    pub plane: Option<PlaneChoice>,
    /// Or a box.
    #[serde(rename = "box")]
    pub box_: Option<BoxToml>,
    /// Surface condition.
    #[serde(default)]
    pub surface: Surface,
    /// Coulomb friction.
    #[serde(default)]
    pub friction: f32,
    /// Box velocity, m/s.
    #[serde(default)]
    pub velocity_m_s: [f32; 3],
    /// Active window `[start, end]`, s.
    pub active_s: Option<[f64; 2]>,
}

/// `plane = {...}` or `plane = "auto"`.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum PlaneChoice {
    /// Given by a point and a normal.
    Given(PlaneToml),
    /// A keyword; `"auto"` is the only one.
    Keyword(String),
}

/// `plane = {...}`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlaneToml {
    /// A point on the plane, m.
    pub point_m: [f32; 3],
    /// Normal (into the free side).
    pub normal: [f32; 3],
}

/// `box = {...}`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxToml {
    /// Lower corner, m.
    pub min_m: [f32; 3],
    /// Upper corner, m.
    pub max_m: [f32; 3],
}

/// `impulse = {...}` in an `[[event]]`: the form before `command = "impulse"`, read with a
/// deprecation warning.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImpulseToml {
    /// Object name.
    pub object: String,
    /// Impulse, N·s.
    pub vector_n_s: [f64; 3],
    /// Application point, m (default COM).
    pub point_m: Option<[f64; 3]>,
}

/// `set_velocity = {...}` in an `[[event]]` (deprecated form).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SetVelocityToml {
    /// Object name.
    pub object: String,
    /// Velocity, m/s.
    pub velocity_m_s: [f64; 3],
}

/// `set_material = {...}` in an `[[event]]` (deprecated form).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SetMaterialToml {
    /// Object name.
    pub object: String,
    /// New material.
    pub material: Option<MaterialToml>,
    /// New restitution.
    pub restitution: Option<f64>,
    /// New friction.
    pub friction: Option<f64>,
}
