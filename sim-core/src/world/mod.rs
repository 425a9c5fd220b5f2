//! The world: every object of a scene, stepped with the COM method (the paper's stage 2) or the
//! shared-grid MPM baseline, frame by frame.
//!
//! COM method, one substep (docs/design/com-layer.md; the stages in order in `world/step.rs`):
//! 0. gravity on awake rigid objects;
//! 1. each awake deformable object runs P2G, grid update and G2P on its own grid ([`Body`]),
//!    with grid colliders, static and rigid objects and the captured background as boundary
//!    nodes ([`crate::contact::boundary`], two-way with awake rigid objects; the background's
//!    surface in `world/background.rs`);
//! 2. the restitution law where a deformable object's grid contact with a solid ends
//!    (`impact.rs`), and rolling resistance while it lasts (`rolling.rs`);
//! 3. rigid objects' velocity half: the grids' reactions (`world/rigid.rs`);
//! 4. deformable pairs: the COM-level impulse law per contact patch (`deformable_pair/`,
//!    `world/coherence.rs`);
//! 5. one contact solve for rigid and static objects, colliders and the background
//!    ([`contact`], [`crate::contact::solver`]);
//! 6. rigid objects' position half, kinematic objects' motion (`world/kinematic.rs`: their velocities
//!    for the substep are set before its dt is chosen), then sleeping (`sleep.rs`).
//!
//! Objects that cannot reach each other before the frame's end step apart, each `world/islands.rs`
//! island at its own CFL substep.
//!
//! [`overlap`] measures how deep objects lie inside each other, on occupied cells; [`explain`]
//! reports per object what the scene needed and what was modelled. An object with a
//! `physics_spacing_m` simulates a voxel subset of its Gaussians and carries them ([`carry`]).
//!
//! Baseline `mpm`: all deformable objects share one grid (contact through the grid, which sticks).
//! Baseline `multi-field` (Bardenhagen et al. 2000): each deformable object keeps its own field on
//! the shared node lattice and fields meet through the multi-field contact rule
//! ([`crate::mpm::multi_field`]). In both baselines the COM layer still resolves contacts that
//! involve a rigid or static object. The MPM part of a substep, per method, is in `mpm_step.rs`;
//! commands are checked against `world/limits.rs` before they apply.

pub(crate) mod background;
pub(crate) mod block_order;
pub(crate) mod body;
pub mod carry;
pub(crate) mod coherence;
mod commands;
pub mod contact;
mod deformable_pair;
pub mod device;
mod device_run;
pub mod explain;
mod impact;
mod impact_friction;
pub(crate) mod islands;
pub(crate) mod kinematic;
pub(crate) mod limits;
pub mod measure;
mod mpm_step;
mod output;
pub mod overlap;
mod per_object;
pub(crate) mod rigid;
mod rolling;
mod sleep;
mod step;

use std::sync::Arc;

use glam::Vec3A;

use background::Background;
pub use background::{BACKGROUND_FRICTION, BackgroundReport};
pub use body::{Body, BodyStats, RigidState};
pub use device::{
    DeviceBackend, DeviceError, DeviceMpm, DeviceReport, DeviceRun, RunPlan, RunStep,
};
pub use measure::{BodyState, measure};
pub use sleep::{SLEEP_AFTER_S, SLEEP_SPEED_M_S};
use step::{ContactMemory, Env};

use crate::collider::{BoxShape, Collider, Plane, Shape, Surface};
use crate::gaussians::GaussianCloud;
use crate::material::MaterialError;
use crate::mpm::{MpmError, MpmSolver, TimeStepError, TimeStepPolicy};
use crate::scene::{self, EventSpec, Scene};

/// Why the world could not be built or stepped.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WorldError {
    /// An object's material was refused.
    #[error("object {object:?}: {source}")]
    Material {
        /// Object name.
        object: String,
        /// Why.
        source: MaterialError,
    },
    /// A collider's geometry is degenerate.
    #[error("collider {collider:?}: {reason}")]
    Collider {
        /// Collider name.
        collider: String,
        /// Why.
        reason: &'static str,
    },
    /// The scene's settings are unusable.
    #[error("[simulation] {0}")]
    Settings(String),
    /// The time step was refused.
    #[error("frame {frame}, t = {time_s:.6} s: {source}")]
    TimeStep {
        /// Frame being computed.
        frame: u64,
        /// Simulated time (s).
        time_s: f64,
        /// Why.
        source: TimeStepError,
    },
    /// An object's MPM step failed (the state holds no NaN).
    #[error("object {object:?}, substep {substep}, t = {time_s:.6} s: {source}")]
    Solver {
        /// Object name (or "shared grid").
        object: String,
        /// Substep index.
        substep: u64,
        /// Simulated time (s).
        time_s: f64,
        /// What failed.
        source: MpmError,
    },
    /// The state blew up: a particle moves faster than [`MAX_STABLE_SPEED_M_S`] (or not finitely).
    #[error(
        "object {object:?} became unstable at frame {frame}, t = {time_s:.6} s: a particle moves at {speed_m_s:.3e} m/s (limit {MAX_STABLE_SPEED_M_S} m/s)"
    )]
    Unstable {
        /// Object name.
        object: String,
        /// Frame being computed.
        frame: u64,
        /// Simulated time (s).
        time_s: f64,
        /// Its fastest particle (m/s).
        speed_m_s: f32,
    },
    /// [`World::advance_frame_with`] was told to stop mid-frame.
    #[error("frame {frame} interrupted")]
    Interrupted {
        /// Frame being computed.
        frame: u64,
    },
    /// The device an object's MPM ran on failed (`world/device.rs`).
    #[error("object {object:?} on the device: {message}")]
    Device {
        /// Object name.
        object: String,
        /// What failed.
        message: String,
    },
    /// A command or event named an object that does not exist.
    #[error("unknown object {0:?}")]
    UnknownObject(String),
    /// A command that cannot apply to that object.
    #[error("object {object:?}: {reason}")]
    Refused {
        /// Object name.
        object: String,
        /// Why.
        reason: String,
    },
}

/// Counters over the run.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WorldStats {
    /// Substeps taken.
    pub substeps: u64,
    /// Particle substeps actually computed by MPM (sleeping/static/rigid excluded).
    pub mpm_particle_substeps: u64,
    /// Object-object contacts resolved with an impulse.
    pub contact_impulses: u64,
    /// Multi-field baseline: field-node velocities corrected by the contact rule.
    pub contact_nodes: u64,
    /// Wall time in MPM (s).
    pub mpm_wall_s: f64,
    /// Wall time in the COM layer: measuring, contacts, impulses, rigid bodies (s).
    pub com_layer_wall_s: f64,
    /// Smallest and largest substep (s).
    pub dt_min_s: f64,
    /// Largest substep (s).
    pub dt_max_s: f64,
    /// Objects found outside their swept box after an interval of island stepping (`world/islands.rs`):
    /// zero unless something moved faster than the plan allowed for.
    #[serde(default)]
    pub island_escapes: u64,
    /// Wall time copying objects' particles back from the device (`[simulation] device =
    /// "gpu"`) for the frames and commands (s).
    #[serde(default)]
    pub device_read_wall_s: f64,
}

/// Per-object summary published every frame.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectSummary {
    /// Object index.
    pub id: u32,
    /// Name.
    pub name: String,
    /// COM (m).
    pub com_m: [f64; 3],
    /// COM velocity (m/s).
    pub velocity_m_s: [f64; 3],
    /// Orientation (w, x, y, z): rigid pose, or the best-fit rotation of the particles.
    pub orientation_wxyz: [f32; 4],
    /// Angular velocity (rad/s).
    pub angular_velocity_rad_s: [f64; 3],
    /// Mass (kg).
    pub mass_kg: f64,
    /// Contacts with other objects in the last frame.
    pub contacts: u32,
    /// Asleep.
    pub sleeping: bool,
    /// Contact force on a solid object, averaged over the last frame: the impulses it received
    /// from contacts, deformable objects' grids and the restitution law, over the frame time (N).
    /// Zero for deformable objects.
    pub contact_force_n: [f64; 3],
    /// The moment of those impulses about its COM over the frame time (N m).
    pub contact_torque_n_m: [f64; 3],
}

/// All objects of a scene and their clock.
#[derive(Debug)]
pub struct World {
    /// Scene settings.
    pub(crate) settings: scene::SimulationSettings,
    /// Objects in scene order.
    pub(crate) bodies: Vec<Body>,
    /// The bodies as built, for [`World::reset`] (shared: a checkpoint clone copies no more than
    /// the state that changes).
    initial: Arc<Vec<Body>>,
    /// The Gaussians no object claimed and the surface they make.
    pub(crate) background: Background,
    /// Grid colliders.
    pub(crate) colliders: Vec<Collider>,
    /// Gravity (m/s²).
    pub(crate) gravity_m_s2: Vec3A,
    /// Substep sizing.
    pub(crate) policy: TimeStepPolicy,
    events: Vec<EventSpec>,
    next_event: usize,
    /// Simulated time (s).
    pub(crate) time_s: f64,
    /// Frames completed.
    pub(crate) frame: u64,
    /// Scene generation (bumped on reset).
    pub(crate) generation: u32,
    shared: MpmSolver,
    /// Counters.
    pub(crate) stats: WorldStats,
    /// What contact remembers from one substep to the next.
    pub(crate) contacts: ContactMemory,
    /// Most particle-substeps per frame a material edit may require ([`limits`]).
    pub(crate) max_particle_substeps_per_frame: f64,
    /// While one island steps ([`islands`]): which objects are in it. `None`: every object steps.
    island: Option<Vec<bool>>,
    /// The device deformable objects' MPM may run on ([`World::set_device`]).
    device: Option<Arc<dyn DeviceBackend>>,
    /// Substeps a run on the device takes at most ([`World::set_device_run`]).
    device_run: u32,
}

crate::clone_reusing::clone_reusing!(World {
    settings,
    bodies,
    initial,
    background,
    colliders,
    gravity_m_s2,
    policy,
    events,
    next_event,
    time_s,
    frame,
    generation,
    shared,
    stats,
    contacts,
    max_particle_substeps_per_frame,
    island,
    device,
    device_run,
});

pub use splatphys_types::limits::MAX_STABLE_SPEED_M_S;

fn collider_from_spec(c: &scene::ColliderSpec) -> Result<Collider, WorldError> {
    let bad = |reason| WorldError::Collider {
        collider: c.name.clone(),
        reason,
    };
    let shape = match c.shape {
        scene::ColliderShape::Plane { point_m, normal } => Shape::Plane(
            Plane::new(Vec3A::from(point_m), Vec3A::from(normal))
                .ok_or_else(|| bad("plane normal is zero or not finite"))?,
        ),
        scene::ColliderShape::Box { min_m, max_m } => Shape::Box(
            BoxShape::new(Vec3A::from(min_m), Vec3A::from(max_m))
                .ok_or_else(|| bad("box needs min < max on every axis"))?,
        ),
    };
    let surface = c.surface;
    let velocity = Vec3A::from(c.velocity_m_s);
    let active_s = match c.active_s {
        Some([a, b]) => Some((a, b)),
        None if velocity != Vec3A::ZERO => Some((0.0, f64::INFINITY)),
        None => None,
    };
    Ok(Collider {
        shape,
        surface,
        friction: c.friction.max(0.0),
        velocity_m_s: velocity,
        active_s,
    })
}

/// The substep policy of settings `s`, after checking the grid cell size and frame rate.
fn time_step_policy(s: &scene::SimulationSettings) -> Result<TimeStepPolicy, WorldError> {
    let dx = s.grid_dx_m as f32;
    if !(dx.is_finite() && dx > 0.0) {
        return Err(WorldError::Settings(format!(
            "grid_dx_m = {} must be positive",
            s.grid_dx_m
        )));
    }
    if !(s.frame_rate_hz.is_finite() && s.frame_rate_hz > 0.0) {
        return Err(WorldError::Settings(format!(
            "frame_rate_hz = {} must be positive",
            s.frame_rate_hz
        )));
    }
    let policy = match s.dt_s {
        Some(dt) => TimeStepPolicy::Fixed {
            dt_s: dt as f32,
            force: s.force_dt,
        },
        None => TimeStepPolicy::Cfl {
            number: s.cfl as f32,
        },
    };
    policy
        .validate()
        .map_err(|e| WorldError::Settings(e.to_string()))?;
    Ok(policy)
}

/// The grid colliders of `scene`: its colliders, then the domain bound when it sets one.
fn grid_colliders(scene: &Scene) -> Result<Vec<Collider>, WorldError> {
    let mut colliders = scene
        .colliders
        .iter()
        .map(collider_from_spec)
        .collect::<Result<Vec<_>, _>>()?;
    if let Some([lo, hi]) = scene.simulation.domain_m {
        let b = BoxShape::new(Vec3A::from(lo), Vec3A::from(hi))
            .ok_or_else(|| WorldError::Settings("domain_m needs min < max on every axis".into()))?;
        colliders.push(Collider::fixed(
            Shape::DomainBound(b),
            Surface::Separate,
            0.0,
        ));
    }
    Ok(colliders)
}

/// The published state of the static background Gaussians: as loaded, unrotated.
impl World {
    /// Builds the world from a scene: one [`Body`] per object (`Body::from_object`).
    ///
    /// # Errors
    /// [`WorldError`] for a refused material, a degenerate collider or unusable settings.
    pub fn from_scene(scene: &Scene) -> Result<Self, WorldError> {
        let s = &scene.simulation;
        let policy = time_step_policy(s)?;
        let dx = s.grid_dx_m as f32;
        let colliders = grid_colliders(scene)?;
        let bodies = scene
            .objects
            .iter()
            .enumerate()
            .map(|(k, o)| {
                let dx_k = o.grid_dx_m(s) as f32;
                Body::from_object(o, k as u32, dx_k, s.collision_cell_m() as f32)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let events = kinematic::keyframes(scene.events.clone(), s.frame_rate_hz);
        let background = Background::new(
            &scene.background,
            &bodies,
            s.background_collision,
            s.collision_cell_m() as f32,
            s.background_min_opacity,
            Vec3A::from(s.gravity_m_s2),
        );
        Ok(Self {
            settings: s.clone(),
            initial: Arc::new(bodies.clone()),
            bodies,
            background,
            colliders,
            gravity_m_s2: Vec3A::from(s.gravity_m_s2),
            policy,
            events,
            next_event: 0,
            time_s: 0.0,
            frame: 0,
            generation: 0,
            shared: MpmSolver::new(dx),
            stats: WorldStats {
                dt_min_s: f64::INFINITY,
                ..Default::default()
            },
            contacts: ContactMemory::default(),
            max_particle_substeps_per_frame: limits::DEFAULT_MAX_PARTICLE_SUBSTEPS_PER_FRAME,
            island: None,
            device: None,
            device_run: device_run::default_substeps(),
        })
    }

    /// Scene settings.
    pub fn settings(&self) -> &scene::SimulationSettings {
        &self.settings
    }

    /// `[objects]` the bodies in scene order; an object's id is its index.
    pub fn bodies(&self) -> &[Body] {
        &self.bodies
    }

    /// Body `id`, to edit its particles ([`Body::particles_mut`]); `None` past the last object.
    pub fn body_mut(&mut self, id: usize) -> Option<&mut Body> {
        self.bodies.get_mut(id)
    }

    /// `[G]` the Gaussians no object claimed (static, published).
    pub fn background(&self) -> &GaussianCloud {
        &self.background.cloud
    }

    /// The grid colliders.
    pub fn colliders(&self) -> &[Collider] {
        &self.colliders
    }

    /// Gravity (m/s²).
    pub fn gravity_m_s2(&self) -> Vec3A {
        self.gravity_m_s2
    }

    /// Simulated time (s).
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// Frames completed.
    pub fn frame(&self) -> u64 {
        self.frame
    }

    /// Scene generation: bumped by every [`World::reset`].
    pub fn generation(&self) -> u32 {
        self.generation
    }

    /// Counters of the run so far.
    pub fn stats(&self) -> &WorldStats {
        &self.stats
    }

    /// The captured background's collision surface (`None`: it does not collide).
    pub fn background_collision(&self) -> Option<&crate::contact::Collision> {
        self.background.collision.as_deref()
    }

    /// What the background became.
    pub fn background_report(&self) -> &BackgroundReport {
        &self.background.report
    }

    /// The contact points of the last substep.
    pub fn last_contacts(&self) -> &[contact::ContactReport] {
        &self.contacts.last
    }

    /// The scene's grid cell size (m): the baselines' shared grid, the contact margins, and
    /// every object's grid unless it has its own ([`Body::dx_m`]).
    pub fn dx_m(&self) -> f32 {
        self.env().dx_m()
    }

    /// Seconds between published frames.
    pub fn frame_dt_s(&self) -> f64 {
        1.0 / self.settings.frame_rate_hz
    }

    /// Frames in the whole run (duration × frame rate, rounded).
    pub fn total_frames(&self) -> u64 {
        (self.settings.duration_s * self.settings.frame_rate_hz)
            .round()
            .max(0.0) as u64
    }

    /// Whether the scene's duration has been simulated.
    pub fn is_finished(&self) -> bool {
        self.frame >= self.total_frames()
    }

    /// Live particles (fill included): those of deformable objects (a solid's wait in its
    /// template).
    pub fn particle_count(&self) -> usize {
        self.bodies.iter().map(|b| b.particles.len()).sum()
    }

    /// Index of the object called `name`.
    pub fn object_index(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b.name == name)
    }

    /// Advances one published frame.
    ///
    /// # Errors
    /// [`WorldError`] when a substep fails; the state holds no NaN afterwards.
    pub fn advance_frame(&mut self) -> Result<u64, WorldError> {
        self.advance_frame_with(&mut || true)
    }

    /// [`World::advance_frame`], calling `keep_going` after every substep: when it returns
    /// `false` the frame is abandoned with [`WorldError::Interrupted`] (the state is then
    /// mid-frame; a server restores its checkpoint or exits). A server uses it to count progress
    /// and to see a stop or a signal within one substep.
    ///
    /// # Errors
    /// As [`World::substep`]; [`WorldError::Unstable`] when a particle moves faster than
    /// [`MAX_STABLE_SPEED_M_S`]; [`WorldError::Interrupted`].
    pub fn advance_frame_with(
        &mut self,
        keep_going: &mut dyn FnMut() -> bool,
    ) -> Result<u64, WorldError> {
        let end = (self.frame + 1) as f64 * self.frame_dt_s();
        let mut substeps = 0;
        for b in &mut self.bodies {
            b.stats.begin_frame();
        }
        // Islands are planned at the frame's start and again at every event within it when
        // there is more than one; one island steps as the whole world.
        let mut plan: Option<Vec<Vec<usize>>> = None;
        while end - self.time_s > 1e-9 {
            self.apply_due_events()?;
            let islands = match &plan {
                Some(p) => p,
                None => plan.insert(self.plan_islands(end)),
            };
            if islands.len() > 1 {
                let islands = plan.take().unwrap_or_default();
                let sync_s = self.next_event_s().filter(|&t| t < end).unwrap_or(end);
                substeps += self.advance_islands(&islands, sync_s, keep_going)?;
                continue;
            }
            // Several substeps of a lone object on the device in one wait (`device_run.rs`).
            if let Some(n) = self.device_run(end)? {
                substeps += n;
            } else {
                self.substep_on_pool(end - self.time_s)?;
                substeps += 1;
                self.check_stable()?;
            }
            if !keep_going() {
                return Err(WorldError::Interrupted { frame: self.frame });
            }
        }
        // What the frame publishes is read from the host.
        self.sync_devices(false)?;
        self.time_s = end;
        self.frame += 1;
        Ok(substeps)
    }

    /// [`World::substep`] on a worker of the thread pool: a substep makes many short parallel
    /// calls, and from outside the pool each one is injected and waits for a worker to wake.
    fn substep_on_pool(&mut self, max_dt_s: f64) -> Result<f64, WorldError> {
        if rayon::current_thread_index().is_some() {
            self.substep(max_dt_s)
        } else {
            rayon::scope(|_| self.substep(max_dt_s))
        }
    }

    /// When the next scene event fires (s), if any is left.
    fn next_event_s(&self) -> Option<f64> {
        self.events.get(self.next_event).map(|e| e.at_s)
    }

    /// [`WorldError::Unstable`] when any object moves faster than [`MAX_STABLE_SPEED_M_S`]: no
    /// command may push past [`limits::MAX_COMMAND_SPEED_M_S`], so such a speed is a blow-up,
    /// and stepping on would shrink the CFL substep toward zero.
    fn check_stable(&self) -> Result<(), WorldError> {
        for b in &self.bodies {
            let speed = b.max_speed_m_s;
            if !speed.is_finite() || f64::from(speed) > MAX_STABLE_SPEED_M_S {
                return Err(WorldError::Unstable {
                    object: b.name.clone(),
                    frame: self.frame,
                    time_s: self.time_s,
                    speed_m_s: speed,
                });
            }
        }
        Ok(())
    }

    fn apply_due_events(&mut self) -> Result<(), WorldError> {
        while self.next_event < self.events.len()
            && self.events[self.next_event].at_s <= self.time_s + 1e-12
        {
            let ev = self.events[self.next_event].clone();
            self.next_event += 1;
            let command = ev.command.map_object(|name| {
                self.object_index(&name)
                    .map(|id| id as u32)
                    .ok_or(WorldError::UnknownObject(name))
            })?;
            self.apply(&command)?;
        }
        Ok(())
    }

    /// Back to the initial state; bumps the scene generation.
    pub fn reset(&mut self) {
        self.bodies.clone_from(&self.initial);
        self.time_s = 0.0;
        self.frame = 0;
        self.next_event = 0;
        self.generation += 1;
        self.contacts = ContactMemory::default();
        self.island = None;
    }
}
