//! The world: every object of a scene, stepped with the COM method (the paper's stage 2) or the
//! shared-grid MPM baseline, frame by frame.
//!
//! COM method, one substep (DESIGN.md "Objects and the COM layer"):
//! 1. each awake deformable object runs P2G, grid update and G2P on its own grid ([`Body`]);
//!    rigid objects integrate as rigid bodies ([`rigid`]); static and sleeping ones cost nothing;
//! 2. broad phase on bounding spheres and boxes, narrow phase on occupied cells ([`contact`]);
//! 3. the impulse law for approaching pairs with restitution e and Coulomb friction;
//! 4. the impulse goes to the contact zone, then each object's momentum is made equal to its
//!    object-level value ([`coherence`]).
//!
//! [`overlap`] measures how deep objects lie inside each other, on occupied cells; [`explain`]
//! reports per object what the scene needed and what was modelled. An object with a
//! `physics_spacing_m` simulates a voxel subset of its Gaussians and carries them ([`carry`]).
//!
//! Baseline `mpm`: all deformable objects share one grid (contact through the grid, which sticks).
//! Baseline `multi-field` (Bardenhagen et al. 2000): each deformable object keeps its own field on
//! the shared node lattice and fields meet through the multi-field contact rule
//! ([`crate::mpm::multi_field`]). In both baselines the COM layer still resolves contacts that
//! involve a rigid or static object. The MPM part of a substep, per method, is in `mpm_step.rs`.

pub mod body;
pub mod carry;
pub mod coherence;
mod commands;
pub mod contact;
pub mod explain;
mod mpm_step;
mod output;
pub mod overlap;
pub mod rigid;

use std::time::Instant;

use glam::{DVec3, Mat3A, Quat, Vec3A};
use rayon::prelude::*;

pub use body::{Body, BodyState, RigidState, measure};

use crate::collider::{BoxShape, Collider, Plane, Shape, Surface};
use crate::gaussians::GaussianCloud;
use crate::kinematics::{GaussianState, pack_symmetric};
use crate::material::{ConstitutiveModel, Material, MaterialError};
use crate::mpm::{MpmError, MpmSolver, Particles, TimeStepError, TimeStepPolicy};
use crate::scene::{self, EventAction, EventSpec, Method, ObjectKind, Scene};

/// Speed below which an object counts as still (m/s).
pub const SLEEP_SPEED_M_S: f32 = 5e-3;
/// How long an object must stay still, touching nothing, before it sleeps (s).
pub const SLEEP_AFTER_S: f64 = 0.25;

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
}

/// All objects of a scene and their clock.
#[derive(Debug, Clone)]
pub struct World {
    /// Scene settings.
    pub settings: scene::SimulationSettings,
    /// Objects in scene order.
    pub bodies: Vec<Body>,
    initial: Vec<Body>,
    /// Gaussians no object claimed (static, published).
    pub background: GaussianCloud,
    background_state: Vec<GaussianState>,
    /// Grid colliders.
    pub colliders: Vec<Collider>,
    /// Gravity (m/s²).
    pub gravity_m_s2: Vec3A,
    /// Substep sizing.
    pub policy: TimeStepPolicy,
    events: Vec<EventSpec>,
    next_event: usize,
    /// Simulated time (s).
    pub time_s: f64,
    /// Frames completed.
    pub frame: u64,
    /// Scene generation (bumped on reset).
    pub generation: u32,
    shared: MpmSolver,
    /// Counters.
    pub stats: WorldStats,
}

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
    let surface = match c.surface {
        scene::Surface::Sticky => Surface::Sticky,
        scene::Surface::Slip => Surface::Slip,
        scene::Surface::Separate => Surface::Separate,
    };
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

impl World {
    /// Builds the world from a scene.
    ///
    /// # Errors
    /// [`WorldError`] for a refused material, a degenerate collider or unusable settings.
    pub fn from_scene(scene: &Scene) -> Result<Self, WorldError> {
        let s = &scene.simulation;
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
        let mut colliders = scene
            .colliders
            .iter()
            .map(collider_from_spec)
            .collect::<Result<Vec<_>, _>>()?;
        if let Some([lo, hi]) = s.domain_m {
            let b = BoxShape::new(Vec3A::from(lo), Vec3A::from(hi)).ok_or_else(|| {
                WorldError::Settings("domain_m needs min < max on every axis".into())
            })?;
            colliders.push(Collider::fixed(
                Shape::DomainBound(b),
                Surface::Separate,
                0.0,
            ));
        }
        let mut bodies = Vec::with_capacity(scene.objects.len());
        for (k, o) in scene.objects.iter().enumerate() {
            let material = Material::from_spec(&o.material).map_err(|source| {
                WorldError::Material {
                    object: o.name.clone(),
                    source,
                }
            })?;
            let g = &o.gaussians;
            let x: Vec<Vec3A> = g.positions.iter().map(|p| Vec3A::from(*p)).collect();
            let phys = carry::physics_particles(&x, dx, o.physics_spacing_m);
            let rho = material.density_kg_m3();
            let mut particles = Particles::default();
            let v0 = Vec3A::from(o.velocity_m_s);
            for (xi, vol) in phys.x.iter().zip(&phys.volume_m3) {
                particles.push(
                    *xi,
                    v0,
                    rho * vol,
                    *vol,
                    0,
                    k as u32,
                    material.initial_plastic_state(),
                );
            }
            let sigma0 = (0..g.len()).map(|i| Mat3A::from(g.covariance(i))).collect();
            let mut body = Body {
                name: o.name.clone(),
                kind: o.kind,
                restitution: o.restitution.clamp(0.0, 1.0),
                friction: o.friction.max(0.0),
                particles,
                materials: vec![material],
                solver: MpmSolver::new(dx),
                gaussians: g.clone(),
                sigma0,
                rest_offsets: Vec::new(),
                visible: if o.visible.len() == g.len() {
                    o.visible.clone()
                } else {
                    vec![true; g.len()]
                },
                carry: phys.carry,
                rigid: RigidState {
                    orientation: Quat::IDENTITY,
                    com_m: DVec3::ZERO,
                    velocity_m_s: DVec3::ZERO,
                    omega_rad_s: DVec3::ZERO,
                    inertia_rest: glam::DMat3::ZERO,
                    mass_kg: 0.0,
                },
                sleeping: false,
                state_cache: None,
                still_s: 0.0,
                substeps_skipped: 0,
                contacts: 0,
                max_speed_m_s: v0.length(),
                impulse_total_n_s: 0.0,
            };
            body.capture_rigid_pose();
            if o.kind == ObjectKind::Static {
                body.particles.v.iter_mut().for_each(|v| *v = Vec3A::ZERO);
                body.max_speed_m_s = 0.0;
            }
            bodies.push(body);
        }
        let background_state = (0..scene.background.len())
            .map(|i| GaussianState {
                position_m: scene.background.positions[i],
                covariance_m2: pack_symmetric(Mat3A::from(scene.background.covariance(i))),
                rotation_wxyz: [1.0, 0.0, 0.0, 0.0],
            })
            .collect();
        let mut events = scene.events.clone();
        events.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
        Ok(Self {
            settings: s.clone(),
            initial: bodies.clone(),
            bodies,
            background: scene.background.clone(),
            background_state,
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
        })
    }

    /// Grid cell size (m).
    pub fn dx_m(&self) -> f32 {
        self.shared.dx_m
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

    /// Total particles (fill included).
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
        let end = (self.frame + 1) as f64 * self.frame_dt_s();
        let mut substeps = 0;
        for b in &mut self.bodies {
            b.contacts = 0;
        }
        while end - self.time_s > 1e-9 {
            self.apply_due_events()?;
            self.substep(end - self.time_s)?;
            substeps += 1;
        }
        self.time_s = end;
        self.frame += 1;
        Ok(substeps)
    }

    fn apply_due_events(&mut self) -> Result<(), WorldError> {
        while self.next_event < self.events.len()
            && self.events[self.next_event].at_s <= self.time_s + 1e-12
        {
            let ev = self.events[self.next_event].clone();
            self.next_event += 1;
            match ev.action {
                EventAction::Impulse {
                    object,
                    vector_n_s,
                    point_m,
                } => {
                    let id = self
                        .object_index(&object)
                        .ok_or(WorldError::UnknownObject(object))?;
                    self.apply_impulse(id, Vec3A::from(vector_n_s), point_m.map(Vec3A::from))?;
                }
                EventAction::SetVelocity {
                    object,
                    velocity_m_s,
                } => {
                    let id = self
                        .object_index(&object)
                        .ok_or(WorldError::UnknownObject(object))?;
                    self.set_velocity(id, Vec3A::from(velocity_m_s))?;
                }
                EventAction::SetMaterial {
                    object,
                    material,
                    restitution,
                    friction,
                } => {
                    let id = self
                        .object_index(&object)
                        .ok_or(WorldError::UnknownObject(object))?;
                    let spec = material.clone();
                    self.set_material(id, spec.as_ref(), restitution, friction)?;
                }
            }
        }
        Ok(())
    }

    /// One substep of at most `max_dt_s` with the scene's method.
    ///
    /// # Errors
    /// [`WorldError::TimeStep`] or [`WorldError::Solver`].
    pub fn substep(&mut self, max_dt_s: f64) -> Result<f64, WorldError> {
        let mut wave = 0.0f32;
        let mut vmax = 0.0f32;
        for b in self.bodies.iter().filter(|b| b.is_active()) {
            if b.kind == ObjectKind::Deformable {
                wave = wave.max(b.materials[0].max_wave_speed_m_s());
            }
            vmax = vmax.max(b.max_speed_m_s);
        }
        let dt = self
            .policy
            .next_dt_s(self.dx_m(), wave, vmax, max_dt_s)
            .map_err(|source| WorldError::TimeStep {
                frame: self.frame,
                time_s: self.time_s,
                source,
            })?;
        let t0 = Instant::now();
        match self.settings.method {
            Method::Mpm => self.mpm_shared_substep(dt)?,
            Method::MultiField => self.multi_field_substep(dt)?,
            Method::Com => self.mpm_per_object_substep(dt)?,
        }
        let t1 = Instant::now();
        self.rigid_substep(dt as f64);
        self.resolve_contacts(dt as f64);
        self.update_sleep(dt as f64);
        let t2 = Instant::now();
        self.stats.mpm_wall_s += (t1 - t0).as_secs_f64();
        self.stats.com_layer_wall_s += (t2 - t1).as_secs_f64();
        self.stats.substeps += 1;
        self.stats.dt_min_s = self.stats.dt_min_s.min(dt as f64);
        self.stats.dt_max_s = self.stats.dt_max_s.max(dt as f64);
        self.time_s += dt as f64;
        Ok(dt as f64)
    }

    fn rigid_substep(&mut self, dt: f64) {
        let g = self.gravity_m_s2.as_dvec3();
        for b in &mut self.bodies {
            if b.kind == ObjectKind::Rigid && !b.sleeping {
                rigid::step(b, g, dt, &self.colliders, self.time_s);
                let rs = &b.rigid;
                let arm = b
                    .rest_offsets
                    .iter()
                    .map(|r| r.length())
                    .fold(0.0f32, f32::max) as f64;
                b.max_speed_m_s = (rs.velocity_m_s.length() + rs.omega_rad_s.length() * arm) as f32;
            }
        }
    }

    fn dynamics(&self, k: usize, s: &BodyState) -> contact::Dynamics {
        let b = &self.bodies[k];
        if b.kind == ObjectKind::Rigid {
            let rs = &b.rigid;
            contact::Dynamics {
                com_m: rs.com_m,
                velocity_m_s: rs.velocity_m_s,
                omega_rad_s: rs.omega_rad_s,
                inverse_mass: 1.0 / rs.mass_kg.max(f64::MIN_POSITIVE),
                inverse_inertia: body::inverse_or_zero(b.rigid_world_inertia()),
            }
        } else {
            contact::Dynamics {
                com_m: s.com_m,
                velocity_m_s: if b.kind == ObjectKind::Static {
                    DVec3::ZERO
                } else {
                    s.velocity_m_s
                },
                omega_rad_s: if b.kind == ObjectKind::Static {
                    DVec3::ZERO
                } else {
                    s.angular_velocity()
                },
                inverse_mass: b.inverse_mass(s),
                inverse_inertia: b.inverse_inertia(s),
            }
        }
    }

    fn resolve_contacts(&mut self, dt: f64) {
        let n = self.bodies.len();
        if n < 2 {
            return;
        }
        let dx = self.dx_m();
        // Static and sleeping objects do not move: their state is measured once and cached
        // (cleared when they wake or are edited).
        // Awake objects get the broad phase's bounds only; the full state (inertia, angular
        // momentum) is measured for the objects of a pair that passes it.
        let mut states: Vec<(BodyState, bool)> = self
            .bodies
            .par_iter_mut()
            .map(|b| {
                if b.is_active() {
                    b.state_cache = None;
                    return (body::measure_bounds(&b.particles, dx), false);
                }
                let s = *b
                    .state_cache
                    .get_or_insert_with(|| measure(&b.particles, dx));
                (s, true)
            })
            .collect();
        let resting = 2.0 * self.gravity_m_s2.length() as f64 * dt;
        for i in 0..n {
            for j in i + 1..n {
                let (bi, bj) = (&self.bodies[i], &self.bodies[j]);
                if !(bi.is_active() || bj.is_active()) {
                    continue;
                }
                if self.settings.method != Method::Com
                    && bi.kind == ObjectKind::Deformable
                    && bj.kind == ObjectKind::Deformable
                {
                    continue; // the grid handles these in the baselines
                }
                if !contact::broad_phase(&states[i].0, &states[j].0, dx as f64) {
                    continue;
                }
                for k in [i, j] {
                    if !states[k].1 {
                        states[k] = (measure(&self.bodies[k].particles, dx), true);
                    }
                }
                let (bi, bj) = (&self.bodies[i], &self.bodies[j]);
                let Some(c) = contact::narrow_phase(bi, &states[i].0, bj, &states[j].0, dx) else {
                    continue;
                };
                self.bodies[i].contacts += 1;
                self.bodies[j].contacts += 1;
                for k in [i, j] {
                    if self.bodies[k].sleeping {
                        self.bodies[k].sleeping = false;
                        self.bodies[k].still_s = 0.0;
                    }
                }
                let (da, db) = (
                    self.dynamics(i, &states[i].0),
                    self.dynamics(j, &states[j].0),
                );
                let e = self.bodies[i].restitution.min(self.bodies[j].restitution) as f64;
                let mu = ((self.bodies[i].friction * self.bodies[j].friction) as f64).sqrt();
                let Some(jv) = contact::impulse(&da, &db, c.point_m, c.normal, e, mu, resting)
                else {
                    continue;
                };
                self.stats.contact_impulses += 1;
                self.give_impulse(i, -jv, c.point_m, &c.zone_a);
                self.give_impulse(j, jv, c.point_m, &c.zone_b);
            }
        }
    }

    fn give_impulse(&mut self, k: usize, j: DVec3, point: DVec3, zone: &[u32]) {
        let b = &mut self.bodies[k];
        b.impulse_total_n_s += j.length();
        match b.kind {
            ObjectKind::Static => {}
            ObjectKind::Rigid => {
                let inv_i = body::inverse_or_zero(b.rigid_world_inertia());
                let rs = &mut b.rigid;
                rs.velocity_m_s += j / rs.mass_kg;
                rs.omega_rad_s += inv_i * (point - rs.com_m).cross(j);
                b.sync_rigid_particles();
            }
            ObjectKind::Deformable => coherence::apply_impulse(b, j, point, zone),
        }
    }

    fn update_sleep(&mut self, dt: f64) {
        for b in &mut self.bodies {
            if b.kind == ObjectKind::Static || b.sleeping {
                continue;
            }
            if b.max_speed_m_s < SLEEP_SPEED_M_S && b.contacts == 0 {
                b.still_s += dt;
                if b.still_s >= SLEEP_AFTER_S {
                    b.sleeping = true;
                    b.particles.v.iter_mut().for_each(|v| *v = Vec3A::ZERO);
                    b.particles.c.iter_mut().for_each(|c| *c = Mat3A::ZERO);
                    b.rigid.velocity_m_s = DVec3::ZERO;
                    b.rigid.omega_rad_s = DVec3::ZERO;
                }
            } else {
                b.still_s = 0.0;
            }
        }
    }

    /// Back to the initial state; bumps the scene generation.
    pub fn reset(&mut self) {
        self.bodies = self.initial.clone();
        self.time_s = 0.0;
        self.frame = 0;
        self.next_event = 0;
        self.generation += 1;
    }
}
