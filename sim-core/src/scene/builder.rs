//! Scenes in code, for tests, benchmarks and examples (the way rapier builds bodies:
//! `RigidBodyBuilder::dynamic().translation(..).build()`), instead of TOML text put together
//! with `format!`.
//!
//! A builder holds what a scene file would say ([`super::schema`]) and [`SceneBuilder::build`]
//! runs it through the very path a scene file takes ([`super::build_scene`]): the same defaults,
//! the same validation with the same key paths (`object[0].material.poisson_ratio`), the same
//! procedural fill with the same seeds. A builder scene therefore equals the scene of the TOML
//! file with the same content, particle for particle.
//!
//! Builders cover procedural objects ([`SceneObject::sphere`], [`SceneObject::cuboid`],
//! [`SceneObject::cylinder`]), colliders, events and cameras; objects selected from 3DGS
//! sources still need a scene file.
//!
//! ```
//! use splatphys_core::scene::{ColliderSpec, MaterialSpec, Method, ObjectKind, Scene, SceneObject};
//!
//! let scene = Scene::builder()
//!     .method(Method::Com)
//!     .duration_s(0.5)
//!     .frame_rate_hz(50.0)
//!     .object(
//!         SceneObject::sphere("ball", [0.0, 0.0, 0.2], 0.04)
//!             .spacing_m(0.005)
//!             .material(MaterialSpec::jelly(2e5, 0.3, 1000.0))
//!             .velocity([1.0, 0.0, 0.0]),
//!     )
//!     .object(SceneObject::cuboid("table", [-0.2, -0.2, 0.0], [0.2, 0.2, 0.05]).kind(ObjectKind::Static))
//!     .collider(ColliderSpec::ground("floor"))
//!     .build()?;
//! assert_eq!(scene.objects.len(), 2);
//! # Ok::<(), splatphys_core::scene::SceneError>(())
//! ```

use std::path::Path;

use super::model::{
    self, CameraSpec, ColliderShape, ColliderSpec, EventSpec, MaterialSpec, Method, ObjectKind,
    Scene, SceneObject, Surface,
};
use super::schema::{
    BoxToml, ColliderToml, ObjectToml, PlaneChoice, PlaneToml, SceneFile, SimulationToml,
};
use super::{SceneError, build_scene};
use crate::procedural::Shape;
use splatphys_types::CommandToml;

/// The file name a builder scene's errors carry.
pub const BUILDER_FILE: &str = "<builder>";

/// A scene under construction: settings at the scene-file defaults (method `com`, 2 s,
/// 30 Hz, dx = 1 cm, CFL 0.5, gravity -9.81 m/s² along z, seed 0) until set.
#[derive(Debug, Clone)]
pub struct SceneBuilder {
    file: SceneFile,
}

impl Default for SceneBuilder {
    fn default() -> Self {
        Self::new()
    }
}

impl Scene {
    /// A [`SceneBuilder`] with the scene-file defaults and no objects.
    pub fn builder() -> SceneBuilder {
        SceneBuilder::new()
    }
}

impl SceneBuilder {
    /// The scene-file defaults, no objects, colliders, events or cameras.
    pub fn new() -> Self {
        Self {
            file: SceneFile {
                simulation: SimulationToml::default(),
                source: Vec::new(),
                object: Vec::new(),
                collider: Vec::new(),
                event: Vec::new(),
                camera: Vec::new(),
            },
        }
    }

    /// Simulation method. Default [`Method::Com`].
    pub fn method(mut self, method: Method) -> Self {
        self.file.simulation.method = method;
        self
    }

    /// Where deformable objects' MPM runs. Default [`super::Device::Cpu`]; `gpu` takes effect
    /// once the world is given a device (`World::set_device`).
    pub fn device(mut self, device: super::Device) -> Self {
        self.file.simulation.device = device;
        self
    }

    /// Simulated time, s (> 0). Default 2.
    pub fn duration_s(mut self, duration_s: f64) -> Self {
        self.file.simulation.duration_s = duration_s;
        self
    }

    /// Published frames per simulated second, Hz (> 0). Default 30.
    pub fn frame_rate_hz(mut self, frame_rate_hz: f64) -> Self {
        self.file.simulation.frame_rate_hz = frame_rate_hz;
        self
    }

    /// MPM grid cell size dx, m (> 0). Default 0.01.
    pub fn grid_dx_m(mut self, grid_dx_m: f64) -> Self {
        self.file.simulation.grid_dx_m = grid_dx_m;
        self
    }

    /// Automatic substeps with CFL number C in (0, 1]: dt <= C dx / (c_p + |v|max).
    /// Default 0.5.
    pub fn cfl(mut self, cfl: f64) -> Self {
        self.file.simulation.cfl = cfl;
        self
    }

    /// A fixed substep, s (> 0), still capped by the CFL bound.
    pub fn dt_s(mut self, dt_s: f64) -> Self {
        self.file.simulation.dt_s = Some(dt_s);
        self.file.simulation.force_dt = false;
        self
    }

    /// A fixed substep, s (> 0), used as is even above the CFL bound (`force_dt = true`).
    pub fn forced_dt_s(mut self, dt_s: f64) -> Self {
        self.file.simulation.dt_s = Some(dt_s);
        self.file.simulation.force_dt = true;
        self
    }

    /// Gravity, m/s². Default (0, 0, -9.81).
    pub fn gravity_m_s2(mut self, gravity_m_s2: [f32; 3]) -> Self {
        self.file.simulation.gravity_m_s2 = gravity_m_s2;
        self
    }

    /// Simulation domain `[min, max]`, m. Default: derived from the scene.
    pub fn domain_m(mut self, min_m: [f32; 3], max_m: [f32; 3]) -> Self {
        self.file.simulation.domain_m = Some([min_m, max_m]);
        self
    }

    /// Seed of every random choice (lattice jitter: object i uses seed + i). Default 0.
    pub fn seed(mut self, seed: u64) -> Self {
        self.file.simulation.seed = seed;
        self
    }

    /// Default physics-particle spacing of deformable and rigid objects, m (> 0).
    pub fn physics_spacing_m(mut self, physics_spacing_m: f32) -> Self {
        self.file.simulation.physics_spacing_m = Some(physics_spacing_m);
        self
    }

    /// Whether still objects sleep. Default true.
    pub fn sleep(mut self, sleep: bool) -> Self {
        self.file.simulation.sleep = sleep;
        self
    }

    /// Whether objects out of each other's reach step apart, each island at its own CFL
    /// substep. Default true.
    pub fn islands(mut self, islands: bool) -> Self {
        self.file.simulation.islands = islands;
        self
    }

    /// How deformable material meets "separate" colliders and static and kinematic procedural
    /// objects. Default [`crate::contact::SurfaceContact::Grid`].
    pub fn surface_contact(mut self, contact: crate::contact::SurfaceContact) -> Self {
        self.file.simulation.surface_contact = contact;
        self
    }

    /// How contacts between solids are solved. Default sequential impulses.
    pub fn contact_solver(mut self, solver: crate::contact::ContactSolver) -> Self {
        self.file.simulation.contact_solver = solver;
        self
    }

    /// Whether the captured background collides. Default true.
    pub fn background_collision(mut self, collide: bool) -> Self {
        self.file.simulation.background_collision = collide;
        self
    }

    /// Adds an object (after the ones already added: it is `object[i]` in errors).
    pub fn object(mut self, object: ObjectBuilder) -> Self {
        self.file.object.push(object.toml);
        self
    }

    /// Adds a kinematic collider.
    pub fn collider(mut self, collider: ColliderSpec) -> Self {
        let (plane, box_) = match collider.shape {
            ColliderShape::Plane { point_m, normal } => (
                Some(PlaneChoice::Given(PlaneToml { point_m, normal })),
                None,
            ),
            ColliderShape::Box { min_m, max_m } => (None, Some(BoxToml { min_m, max_m })),
        };
        self.file.collider.push(ColliderToml {
            name: collider.name,
            plane,
            box_,
            surface: collider.surface,
            friction: collider.friction,
            velocity_m_s: collider.velocity_m_s,
            active_s: collider.active_s,
        });
        self
    }

    /// Adds a scripted event (events are sorted by time on build): written as the scene file
    /// would write it, so it gets the same checks.
    pub fn event(mut self, event: EventSpec) -> Self {
        let mut table = toml::Table::try_from(CommandToml::from(event.command)).unwrap_or_default();
        table.insert("at_s".into(), toml::Value::Float(event.at_s));
        self.file.event.push(table);
        self
    }

    /// Adds a camera.
    pub fn camera(mut self, camera: CameraSpec) -> Self {
        self.file.camera.push(camera);
        self
    }

    /// Validates and builds the scene, as [`super::load_scene_str`] does a scene file.
    ///
    /// # Errors
    /// The [`SceneError`] the equivalent scene file gives (file [`BUILDER_FILE`]), with its key
    /// path: [`SceneError::Invalid`] for a value out of range, [`SceneError::Procedural`] for a
    /// shape that cannot be filled.
    pub fn build(&self) -> Result<Scene, SceneError> {
        build_scene(Path::new(BUILDER_FILE), Path::new("."), &self.file)
    }
}

/// A procedural object under construction; [`SceneBuilder::object`] adds it. Unset values take
/// the scene-file defaults: deformable, the default material (jelly, E = 1e5 Pa, nu = 0.3,
/// 1000 kg/m³), restitution 0.5, friction 0.3, at rest, lattice spacing 1 cm, grey.
#[derive(Debug, Clone)]
pub struct ObjectBuilder {
    toml: ObjectToml,
}

impl ObjectBuilder {
    /// An object called `name` filling `shape` (the lattice of [`crate::procedural`]).
    pub fn new(name: impl Into<String>, shape: Shape) -> Self {
        Self {
            toml: ObjectToml {
                name: name.into(),
                select: None,
                shape: Some(shape),
                rotation_deg: None,
                spacing_m: None,
                color: None,
                kind: ObjectKind::default(),
                material: None,
                restitution: None,
                friction: None,
                rolling_resistance_m: None,
                surface: None,
                velocity_m_s: [0.0; 3],
                fill: None,
                physics_spacing_m: None,
                grid_dx_m: None,
            },
        }
    }

    /// Turns the shape about its centre: Euler angles x, y, z in degrees. Default none.
    pub fn rotation_deg(mut self, rotation_deg: [f32; 3]) -> Self {
        self.toml.rotation_deg = Some(rotation_deg);
        self
    }

    /// How it moves. Default [`ObjectKind::Deformable`].
    pub fn kind(mut self, kind: ObjectKind) -> Self {
        self.toml.kind = kind;
        self
    }

    /// Its material. Default [`MaterialSpec::default`].
    pub fn material(mut self, material: MaterialSpec) -> Self {
        self.toml.material = Some(material);
        self
    }

    /// Initial velocity, m/s. Default 0.
    pub fn velocity(mut self, velocity_m_s: [f32; 3]) -> Self {
        self.toml.velocity_m_s = velocity_m_s;
        self
    }

    /// Coefficient of restitution e in [0, 1]. Default 0.5.
    pub fn restitution(mut self, restitution: f32) -> Self {
        self.toml.restitution = Some(restitution);
        self
    }

    /// Coulomb friction coefficient (>= 0). Default 0.3.
    pub fn friction(mut self, friction: f32) -> Self {
        self.toml.friction = Some(friction);
        self
    }

    /// Rolling resistance b (m, >= 0): a contact resists rolling with a couple of at most b
    /// times its normal force. Default 0.
    pub fn rolling_resistance_m(mut self, b_m: f32) -> Self {
        self.toml.rolling_resistance_m = Some(b_m);
        self
    }

    /// The boundary rule a static or rigid object imposes on deformable objects' grids.
    /// Default [`Surface::Separate`].
    pub fn surface(mut self, surface: Surface) -> Self {
        self.toml.surface = Some(surface);
        self
    }

    /// Lattice spacing of the procedural fill, m (> 0). Default 0.01.
    pub fn spacing_m(mut self, spacing_m: f32) -> Self {
        self.toml.spacing_m = Some(spacing_m);
        self
    }

    /// Colour, linear RGB, each channel in [0, 1]. Default (0.7, 0.7, 0.7).
    pub fn color(mut self, color: [f32; 3]) -> Self {
        self.toml.color = Some(color);
        self
    }

    /// Physics-particle spacing h, m (> 0; not for static objects): one particle per occupied
    /// cube of side h, carrying the Gaussians. Default: the scene's, else every Gaussian.
    pub fn physics_spacing_m(mut self, physics_spacing_m: f32) -> Self {
        self.toml.physics_spacing_m = Some(physics_spacing_m);
        self
    }

    /// Its own MPM grid cell, m (> 0; method `com` only). Default: two physics spacings when
    /// coarser than the scene's cell, else the scene's ([`SceneObject::grid_dx_m`]).
    pub fn grid_dx_m(mut self, grid_dx_m: f64) -> Self {
        self.toml.grid_dx_m = Some(grid_dx_m);
        self
    }
}

impl SceneObject {
    /// A ball of radius `radius_m` centred at `center_m` (m).
    pub fn sphere(name: impl Into<String>, center_m: [f32; 3], radius_m: f32) -> ObjectBuilder {
        ObjectBuilder::new(name, Shape::Sphere { center_m, radius_m })
    }

    /// An axis-aligned box from corner `min_m` to corner `max_m` (m).
    pub fn cuboid(name: impl Into<String>, min_m: [f32; 3], max_m: [f32; 3]) -> ObjectBuilder {
        ObjectBuilder::new(name, Shape::Box { min_m, max_m })
    }

    /// A solid cylinder: base disc centred at `base_m` (m), `axis` from it (need not be unit),
    /// radius and height in m.
    pub fn cylinder(
        name: impl Into<String>,
        base_m: [f32; 3],
        axis: [f32; 3],
        radius_m: f32,
        height_m: f32,
    ) -> ObjectBuilder {
        ObjectBuilder::new(
            name,
            Shape::Cylinder {
                base_m,
                axis,
                radius_m,
                height_m,
            },
        )
    }
}

impl ColliderSpec {
    /// A plane through `point_m` (m) whose free side is where `normal` points (normalised on
    /// build). Sticky, no friction, at rest, always active.
    pub fn plane(name: impl Into<String>, point_m: [f32; 3], normal: [f32; 3]) -> Self {
        Self {
            name: name.into(),
            shape: ColliderShape::Plane { point_m, normal },
            surface: Surface::default(),
            friction: 0.0,
            velocity_m_s: [0.0; 3],
            active_s: None,
        }
    }

    /// The ground: the plane z = 0 with +z free, sticky.
    pub fn ground(name: impl Into<String>) -> Self {
        Self::plane(name, [0.0; 3], [0.0, 0.0, 1.0])
    }

    /// A solid axis-aligned box from `min_m` to `max_m` (m). Sticky, no friction, at rest.
    pub fn cuboid(name: impl Into<String>, min_m: [f32; 3], max_m: [f32; 3]) -> Self {
        Self {
            shape: ColliderShape::Box { min_m, max_m },
            ..Self::plane(name, [0.0; 3], [0.0, 0.0, 1.0])
        }
    }

    /// Surface condition. Default [`Surface::Sticky`].
    pub fn surface(mut self, surface: Surface) -> Self {
        self.surface = surface;
        self
    }

    /// Coulomb friction (slip and separate surfaces, >= 0). Default 0.
    pub fn friction(mut self, friction: f32) -> Self {
        self.friction = friction;
        self
    }

    /// Velocity, m/s. Default 0.
    pub fn velocity(mut self, velocity_m_s: [f32; 3]) -> Self {
        self.velocity_m_s = velocity_m_s;
        self
    }

    /// Active only from `start_s` to `end_s` (s). Default: always.
    pub fn active_s(mut self, start_s: f64, end_s: f64) -> Self {
        self.active_s = Some([start_s, end_s]);
        self
    }
}

impl CameraSpec {
    /// A camera at `position_m` looking at `look_at_m` (m): up +z, 45° vertical field of
    /// view, 640 × 480 px (the scene-file defaults).
    pub fn new(name: impl Into<String>, position_m: [f32; 3], look_at_m: [f32; 3]) -> Self {
        Self {
            name: name.into(),
            position_m,
            look_at_m,
            up: model::default_up(),
            fov_y_deg: model::default_fov(),
            width_px: model::default_width(),
            height_px: model::default_height(),
        }
    }

    /// Vertical field of view, degrees in (0, 180).
    pub fn fov_y_deg(mut self, fov_y_deg: f32) -> Self {
        self.fov_y_deg = fov_y_deg;
        self
    }

    /// Image size, px (> 0).
    pub fn size_px(mut self, width_px: u32, height_px: u32) -> Self {
        self.width_px = width_px;
        self.height_px = height_px;
        self
    }

    /// Up vector.
    pub fn up(mut self, up: [f32; 3]) -> Self {
        self.up = up;
        self
    }
}
