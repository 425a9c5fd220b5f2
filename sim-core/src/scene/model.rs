//! The plain-data scene the simulation consumes: settings, objects with world-frame Gaussians,
//! background, colliders, events, cameras. SI units, world frame right-handed, z up.

use serde::{Deserialize, Serialize};
pub use splatphys_types::Command;

use crate::gaussians::GaussianCloud;

/// The one of `all` whose `name` is `s` (trimmed, any case), or an error naming `what` and the
/// names expected.
fn from_name<T: Copy>(
    all: &[T],
    name: fn(T) -> &'static str,
    what: &'static str,
    s: &str,
) -> Result<T, splatphys_types::UnknownName> {
    let key = s.trim().to_ascii_lowercase();
    all.iter()
        .copied()
        .find(|&m| name(m) == key)
        .ok_or_else(|| splatphys_types::UnknownName {
            what,
            name: s.to_string(),
            expected: all.iter().map(|&m| name(m)).collect::<Vec<_>>().join(", "),
        })
}

/// Simulation method (docs/design/com-layer.md, "One substep" and "Baselines").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Per-object MPM + centre-of-mass collision layer (the paper's method).
    #[default]
    Com,
    /// Standard MPM, one shared grid.
    Mpm,
    /// Multi-velocity-field contact MPM (Bardenhagen 2000).
    MultiField,
}

impl Method {
    /// Every method, in the order the benchmarks chart them.
    pub const ALL: [Self; 3] = [Self::Com, Self::Mpm, Self::MultiField];

    /// The scene-file name (`com`, `mpm`, `multi-field`).
    pub const fn name(self) -> &'static str {
        match self {
            Self::Com => "com",
            Self::Mpm => "mpm",
            Self::MultiField => "multi-field",
        }
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Method {
    type Err = splatphys_types::UnknownName;

    /// Parses a scene-file name (`com`, `mpm`, `multi-field`), case-insensitively.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        from_name(&Self::ALL, Self::name, "method", s)
    }
}

/// Where deformable objects' MPM runs (`[simulation] device`; `--device` on the command line).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Device {
    /// On the CPU's threads.
    #[default]
    Cpu,
    /// On a GPU where one is found and the object's situation allows (`splatphys-gpu`,
    /// docs/guide/gpu.md); elsewhere on the CPU.
    Gpu,
}

impl Device {
    /// Every device, in the order the benchmarks chart them.
    pub const ALL: [Self; 2] = [Self::Cpu, Self::Gpu];

    /// The scene-file name (`cpu`, `gpu`).
    pub const fn name(self) -> &'static str {
        match self {
            Self::Cpu => "cpu",
            Self::Gpu => "gpu",
        }
    }
}

impl std::fmt::Display for Device {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Device {
    type Err = splatphys_types::UnknownName;

    /// Parses a scene-file name (`cpu`, `gpu`), case-insensitively.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        from_name(&Self::ALL, Self::name, "device", s)
    }
}

pub use splatphys_types::ObjectKind;

pub use crate::collider::Surface;

pub use crate::contact::{ContactSolver, SurfaceContact};
pub use crate::material::MaterialSpec;

/// Simulation settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SimulationSettings {
    /// Method. Default [`Method::Com`].
    pub method: Method,
    /// Where deformable objects' MPM runs. Default [`Device::Cpu`].
    pub device: Device,
    /// Simulated time, s. Default 2.0.
    pub duration_s: f64,
    /// Published frames per simulated second, Hz. Default 30.
    pub frame_rate_hz: f64,
    /// MPM grid cell size, m. Default 0.01.
    pub grid_dx_m: f64,
    /// CFL number C in dt <= C dx / (c_p + |v|max). Default 0.5.
    pub cfl: f64,
    /// Fixed substep, s, when given (the CFL bound still caps it unless `force_dt`).
    pub dt_s: Option<f64>,
    /// Use `dt_s` as is, even above the CFL bound. Default false.
    pub force_dt: bool,
    /// Gravity, m/s². Default (0, 0, -9.81).
    pub gravity_m_s2: [f32; 3],
    /// Simulation domain `[min, max]`, m; `None`: the simulation derives it from the scene.
    pub domain_m: Option<[[f32; 3]; 2]>,
    /// Seed for every random choice in building the scene. Default 0.
    pub seed: u64,
    /// Default physics-particle spacing of deformable and rigid objects, m (see
    /// [`SceneObject::physics_spacing_m`]). Default `None`.
    pub physics_spacing_m: Option<f32>,
    /// Objects that stay still put to sleep (skip all work until touched). Default true.
    pub sleep: bool,
    /// Under method `com`, objects that cannot touch before the next frame step apart, each
    /// island at its own CFL substep (`world/islands.rs`). Default true.
    pub islands: bool,
    /// The captured background (Gaussians no object selects) is a static collision surface.
    /// Default true.
    pub background_collision: bool,
    /// Opacity a background Gaussian needs to count as solid, in [0, 1]. Default 0.5.
    pub background_min_opacity: f32,
    /// Cell of the collision surfaces sampled from points (captured rigid, static and kinematic
    /// objects, and the background), m. `None` (the default): `grid_dx_m`. A level of detail
    /// that coarsens the grid keeps it at the written grid's cell, so solid objects keep their
    /// surfaces ([`crate::scene::LevelOfDetail`]).
    pub collision_dx_m: Option<f64>,
    /// Simulated frames per wall second that `splatphys run` chooses deformable objects'
    /// spacing to meet ([`crate::scene::LevelOfDetail`]). `None` (the default): as written.
    pub budget_fps: Option<f64>,
    /// How contacts between solids are solved. Default
    /// [`ContactSolver::SequentialImpulses`].
    pub contact_solver: ContactSolver,
    /// How deformable material meets "separate" colliders and static and kinematic procedural
    /// objects. Default [`SurfaceContact::Grid`].
    pub surface_contact: SurfaceContact,
}

impl SceneObject {
    /// The cell of this object's MPM grid, m, in a scene of settings `s`: for a deformable
    /// object under method `com`, its own `grid_dx_m`, else two physics spacings when that is
    /// coarser than the scene's cell (two particles per cell per axis, the usual MPM choice),
    /// else the scene's `grid_dx_m`. The baselines share one grid, and objects of other kinds
    /// run no MPM: always the scene's.
    pub fn grid_dx_m(&self, s: &SimulationSettings) -> f64 {
        if s.method != Method::Com || self.kind != ObjectKind::Deformable {
            return s.grid_dx_m;
        }
        match (self.grid_dx_m, self.physics_spacing_m) {
            (Some(dx), _) => dx,
            (None, Some(h)) => s.grid_dx_m.max(2.0 * f64::from(h)),
            (None, None) => s.grid_dx_m,
        }
    }
}

impl SimulationSettings {
    /// The cell of collision surfaces sampled from points, m (`collision_dx_m`, else the grid's).
    pub fn collision_cell_m(&self) -> f64 {
        self.collision_dx_m.unwrap_or(self.grid_dx_m)
    }
}

/// One simulated (or static) object.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneObject {
    /// Unique name (events and commands refer to it).
    pub name: String,
    /// How it moves.
    pub kind: ObjectKind,
    /// Its material.
    pub material: MaterialSpec,
    /// Coefficient of restitution e in [0, 1]. Default 0.5.
    pub restitution: f32,
    /// Coulomb friction coefficient (>= 0). Default 0.3.
    pub friction: f32,
    /// Rolling resistance b, m (>= 0): a contact's couple against rolling is at most b times
    /// its normal force (the lever arm of rolling friction). Default 0.
    pub rolling_resistance_m: f32,
    /// Initial velocity, m/s.
    pub velocity_m_s: [f32; 3],
    /// Its particles as Gaussians, world frame (m, z up). `[N]`.
    pub gaussians: GaussianCloud,
    /// `[N]`: false for interior fill particles (simulated, never published).
    pub visible: Vec<bool>,
    /// Physics-particle spacing h, m (> 0): the object simulates one particle per occupied cube
    /// of side h and carries its Gaussians along (`crate::world::carry`). `None` (the default,
    /// and always for static objects): every Gaussian is a particle.
    pub physics_spacing_m: Option<f32>,
    /// Its own MPM grid cell, m (> 0), method `com` only; `None` (the default): see
    /// [`SceneObject::grid_dx_m`].
    pub grid_dx_m: Option<f64>,
    /// The procedural shape the object fills, when it is one: contact then uses its exact
    /// surface. `None` for objects selected from a capture (their surface is sampled from
    /// their particles, `crate::contact::LevelSet`).
    pub shape: Option<crate::procedural::Shape>,
    /// How `shape` is turned about its centre (identity: as written).
    pub shape_rotation: glam::Quat,
    /// The boundary rule this object imposes, as a static or rigid object, on deformable
    /// objects' grids. Default [`Surface::Separate`].
    pub surface: Surface,
}

/// Collider geometry.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum ColliderShape {
    /// Half-space boundary: the free side is where `normal` points.
    Plane {
        /// A point on the plane, m.
        point_m: [f32; 3],
        /// Unit normal (normalised on load).
        normal: [f32; 3],
    },
    /// Solid axis-aligned box.
    Box {
        /// Lower corner, m.
        min_m: [f32; 3],
        /// Upper corner, m.
        max_m: [f32; 3],
    },
}

/// A kinematic collider.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ColliderSpec {
    /// Name.
    pub name: String,
    /// Geometry at t = 0.
    pub shape: ColliderShape,
    /// Surface condition. Default sticky.
    pub surface: Surface,
    /// Coulomb friction (slip/separate). Default 0.
    pub friction: f32,
    /// Velocity, m/s (a box moves; a plane too). Default 0.
    pub velocity_m_s: [f32; 3],
    /// Active window `[start, end]`, s; `None` = always.
    pub active_s: Option<[f64; 2]>,
}

/// A scripted event: a command (objects named) applied when simulated time reaches `at_s`.
/// Scene files write it as a [`CommandToml`](splatphys_types::CommandToml) table plus `at_s`,
/// the same keys control timelines use.
#[derive(Debug, Clone, PartialEq)]
pub struct EventSpec {
    /// Simulated time, s (>= 0).
    pub at_s: f64,
    /// What happens: `impulse`, `set-velocity`, `edit-material` or `set-kind`.
    pub command: Command<String>,
}

pub(super) fn default_up() -> [f32; 3] {
    [0.0, 0.0, 1.0]
}
pub(super) fn default_fov() -> f32 {
    45.0
}
pub(super) fn default_width() -> u32 {
    640
}
pub(super) fn default_height() -> u32 {
    480
}

/// A pinhole camera.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    /// Name.
    pub name: String,
    /// Eye position, m.
    pub position_m: [f32; 3],
    /// Point looked at, m.
    pub look_at_m: [f32; 3],
    /// Up vector. Default (0, 0, 1).
    #[serde(default = "default_up")]
    pub up: [f32; 3],
    /// Vertical field of view, degrees. Default 45.
    #[serde(default = "default_fov")]
    pub fov_y_deg: f32,
    /// Image width, px. Default 640.
    #[serde(default = "default_width")]
    pub width_px: u32,
    /// Image height, px. Default 480.
    #[serde(default = "default_height")]
    pub height_px: u32,
}

/// A built scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Settings.
    pub simulation: SimulationSettings,
    /// Objects, in file order.
    pub objects: Vec<SceneObject>,
    /// Gaussians no object claimed: static, rendered, not simulated. World frame.
    pub background: GaussianCloud,
    /// Colliders.
    pub colliders: Vec<ColliderSpec>,
    /// Events, sorted by time (stable).
    pub events: Vec<EventSpec>,
    /// Cameras.
    pub cameras: Vec<CameraSpec>,
    /// What the scene file wrote in a deprecated form, one message each (the commands print
    /// them; the scene still loads).
    pub warnings: Vec<String>,
}

impl Scene {
    /// Index of the object called `name`.
    pub fn object_index(&self, name: &str) -> Option<usize> {
        self.objects.iter().position(|o| o.name == name)
    }

    /// Total Gaussians over all objects (fill included): the particle count when no object sets
    /// a physics-particle spacing.
    pub fn particle_count(&self) -> usize {
        self.objects.iter().map(|o| o.gaussians.len()).sum()
    }
}
