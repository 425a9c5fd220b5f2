//! One substep of the world as a pipeline of stages (the order of the module docs of
//! [`super`]). Each stage is a function over the parts of the world it borrows: [`Env`], what
//! every stage reads and none changes, and the mutable parts it names (the bodies, the
//! [`ContactMemory`], the counters), so what a stage reads and writes is in its signature
//! (rapier's `PhysicsPipeline::step` over its sets is the model).

use std::collections::HashMap;
use std::time::Instant;

use glam::{DVec3, Vec3A};

use super::background::Background;
use super::body::Body;
use super::contact::{ContactCache, ContactReport};
use super::deformable_pair::{self, RestingPatch};
use super::impact::{Impact, SolidOf};
use super::{
    World, WorldError, WorldStats, contact, impact, kinematic, mpm_step, per_object, rigid,
    rolling, sleep,
};
use crate::collider::Collider;
use crate::contact::boundary::Reaction;
use crate::contact::geometry::Placed;
use crate::material::ConstitutiveModel;
use crate::mpm::MpmSolver;
use crate::scene::{Method, ObjectKind, SimulationSettings};

/// What every stage of a substep reads and none of them changes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Env<'a> {
    /// Scene settings.
    pub(crate) settings: &'a SimulationSettings,
    /// Gravity (m/s²).
    pub(crate) gravity_m_s2: Vec3A,
    /// Simulated time at the substep's start (s).
    pub(crate) time_s: f64,
    /// The grid colliders.
    pub(crate) colliders: &'a [Collider],
    /// The captured background.
    pub(crate) background: &'a Background,
    /// While one island steps (`islands.rs`): which objects are in it. `None`: every object.
    pub(crate) island: Option<&'a [bool]>,
    /// The device deformable objects' MPM may run on (`device.rs`).
    pub(crate) device: Option<&'a dyn super::device::DeviceBackend>,
}

impl Env<'_> {
    /// The cell of the world's grid (m): the shared grid's, and every object's unless its own is
    /// set.
    pub(crate) fn dx_m(&self) -> f32 {
        self.settings.grid_dx_m as f32
    }

    /// Whether object `k` takes part in the substep: every object does, except while another
    /// island steps (`islands.rs`).
    pub(crate) fn stepping(&self, k: usize) -> bool {
        self.island
            .is_none_or(|m| m.get(k).copied().unwrap_or(true))
    }

    /// Whether object `k` (body `b`) is seen by the substep: it steps, or it is static (every
    /// island sees static objects).
    pub(crate) fn present(&self, k: usize, b: &Body) -> bool {
        self.stepping(k) || b.kind == ObjectKind::Static
    }

    /// The surface of solid object `k` of `bodies` where it is now; `None` for a deformable
    /// object and for an object of another island.
    pub(crate) fn placed<'b>(&self, bodies: &'b [Body], k: usize) -> Option<Placed<'b>> {
        let b = &bodies[k];
        if b.kind == ObjectKind::Deformable || !self.present(k, b) {
            return None;
        }
        let c = b.collision.as_ref()?;
        Some(c.placed(b.rigid.com_m, b.rigid.orientation))
    }
}

/// What contact remembers from one substep to the next.
#[derive(Debug, Clone, Default)]
pub(crate) struct ContactMemory {
    /// The solids' contact impulses, for warm starting (`contact.rs`).
    pub(crate) cache: ContactCache,
    /// Resting patches of deformable pairs, warm-started into the next substep
    /// (`deformable_pair/`).
    pub(crate) resting_patches: Vec<RestingPatch>,
    /// Open deformable–solid impacts (`impact.rs`).
    pub(crate) impacts: HashMap<(usize, SolidOf), Impact>,
    /// The contact points of the last substep.
    pub(crate) last: Vec<ContactReport>,
    /// Objects made solid by a command since their last contact pass: the overlaps their frozen
    /// shape starts with are kept, not pushed out (`contact.rs`).
    pub(crate) made_solid: Vec<usize>,
}

/// The world split for a stage: what it reads ([`Env`]) and what it may change.
pub(crate) struct Parts<'a> {
    /// What every stage reads.
    pub(crate) env: Env<'a>,
    /// The bodies, in scene order.
    pub(crate) bodies: &'a mut [Body],
    /// What contact remembers.
    pub(crate) contacts: &'a mut ContactMemory,
    /// The world's counters.
    pub(crate) stats: &'a mut WorldStats,
    /// The grid every deformable object shares under method `mpm`.
    pub(crate) shared: &'a mut MpmSolver,
}

impl World {
    /// What every stage of the substep being taken reads.
    pub(crate) fn env(&self) -> Env<'_> {
        Env {
            settings: &self.settings,
            gravity_m_s2: self.gravity_m_s2,
            time_s: self.time_s,
            colliders: &self.colliders,
            background: &self.background,
            island: self.island.as_deref(),
            device: self.device.as_deref(),
        }
    }

    /// Whether object `k` takes part in the substep being taken ([`Env::stepping`]).
    pub(crate) fn stepping(&self, k: usize) -> bool {
        self.env().stepping(k)
    }

    /// The world split into what a stage reads and what it may change.
    pub(crate) fn parts(&mut self) -> Parts<'_> {
        let World {
            settings,
            gravity_m_s2,
            time_s,
            colliders,
            background,
            island,
            bodies,
            contacts,
            stats,
            shared,
            device,
            ..
        } = self;
        Parts {
            env: Env {
                settings,
                gravity_m_s2: *gravity_m_s2,
                time_s: *time_s,
                colliders,
                background,
                island: island.as_deref(),
                device: device.as_deref(),
            },
            bodies,
            contacts,
            stats,
            shared,
        }
    }

    /// One substep of at most `max_dt_s` with the scene's method.
    ///
    /// # Errors
    /// [`WorldError::TimeStep`] or [`WorldError::Solver`].
    pub fn substep(&mut self, max_dt_s: f64) -> Result<f64, WorldError> {
        let Parts { env, bodies, .. } = self.parts();
        kinematic::drive(&env, bodies);
        let dt = self.time_step(max_dt_s)?;
        self.substep_of(dt)
    }

    /// A substep of `dt` (s) after the kinematic drives: [`World::substep`] once dt is chosen.
    ///
    /// # Errors
    /// As [`World::substep`].
    pub(super) fn substep_of(&mut self, dt: f32) -> Result<f64, WorldError> {
        let dt_s = dt as f64;
        let Parts { env, bodies, .. } = self.parts();
        rigid_gravity(&env, bodies, dt_s);
        let t0 = Instant::now();
        if self.settings.method == Method::Com {
            deformable_pair::warm_start(&mut self.bodies, &self.contacts.resting_patches, dt_s);
        }
        let mpm_step::GridContacts {
            mut reactions,
            touches,
        } = match self.settings.method {
            Method::Mpm => {
                let Parts {
                    env,
                    bodies,
                    stats,
                    shared,
                    ..
                } = self.parts();
                mpm_step::shared_grid(&env, bodies, shared, stats, dt)?
            }
            Method::MultiField => {
                let Parts {
                    env, bodies, stats, ..
                } = self.parts();
                mpm_step::multi_field(&env, bodies, stats, dt)?
            }
            Method::Com => {
                let Parts {
                    env, bodies, stats, ..
                } = self.parts();
                per_object::per_object(&env, bodies, stats, dt)?
            }
        };
        let t1 = Instant::now();
        let Parts {
            env,
            bodies,
            contacts,
            stats,
            ..
        } = self.parts();
        impact::boundary_restitution(&env, bodies, &mut contacts.impacts, &touches);
        rolling::rolling_resistance(&env, bodies, &touches, &mut reactions);
        rigid_velocities(&env, bodies, dt_s, &reactions);
        deformable_pair::resolve(&env, bodies, &mut contacts.resting_patches, stats, dt_s);
        contact::solve(&env, bodies, contacts, stats, dt_s);
        rigid_positions(&env, bodies, dt_s);
        kinematic::positions(&env, bodies, dt_s);
        sleep::update(&env, bodies, &contacts.last, dt_s);
        let t2 = Instant::now();
        stats.mpm_wall_s += (t1 - t0).as_secs_f64();
        stats.com_layer_wall_s += (t2 - t1).as_secs_f64();
        stats.substeps += 1;
        stats.dt_min_s = stats.dt_min_s.min(dt_s);
        stats.dt_max_s = stats.dt_max_s.max(dt_s);
        for (k, b) in bodies.iter_mut().enumerate() {
            if env.stepping(k) {
                b.count_substep(dt_s);
            }
        }
        self.time_s += dt_s;
        // A read-back outside the MPM part (a law's rigid field, a command) that failed.
        self.device_failure()?;
        Ok(dt_s)
    }

    /// The substep (s) of at most `max_dt_s`: the CFL bound of the stepping objects, the
    /// smallest C dx / (c_p + |v|max) of any of them, with |v|max over all of them and the
    /// active colliders (c_p includes the speed that stands for a damped material's viscous
    /// limit).
    pub(super) fn time_step(&self, max_dt_s: f64) -> Result<f32, WorldError> {
        let mut vmax = 0.0f32;
        for (k, b) in self.bodies.iter().enumerate() {
            if b.is_active() && self.stepping(k) {
                vmax = vmax.max(b.max_speed_m_s);
            }
        }
        for c in self.colliders.iter().filter(|c| c.is_active(self.time_s)) {
            vmax = vmax.max(c.velocity_m_s.length());
        }
        let (mut dx, mut wave) = (self.dx_m(), 0.0f32);
        for (k, b) in self.bodies.iter().enumerate() {
            if b.is_active() && self.stepping(k) && b.kind == ObjectKind::Deformable {
                let m = &b.materials[0];
                let (dx_b, c_b) = (
                    b.solver.dx_m,
                    m.wave_speed_for_m_s(b.plastic_for_cfl())
                        + m.elastic().damping_speed_m_s(b.solver.dx_m),
                );
                if dx_b / (c_b + vmax) < dx / (wave + vmax) {
                    (dx, wave) = (dx_b, c_b);
                }
            }
        }
        self.policy
            .next_dt_s(dx, wave, vmax, max_dt_s)
            .map_err(|source| WorldError::TimeStep {
                frame: self.frame,
                time_s: self.time_s,
                source,
            })
    }
}

/// Gravity on every stepping awake rigid object, before the MPM part: a solid meets a
/// deformable's grid two-way with this substep's velocity, as the grid's nodes do (with gravity
/// after, a block resting on a jelly started each substep lighter than the nodes under it and
/// crept into it).
fn rigid_gravity(env: &Env, bodies: &mut [Body], dt: f64) {
    let g = env.gravity_m_s2.as_dvec3();
    for (k, b) in bodies.iter_mut().enumerate() {
        if b.kind == ObjectKind::Rigid && !b.sleeping && env.stepping(k) {
            rigid::integrate_velocity(b, g, dt, DVec3::ZERO, DVec3::ZERO);
        }
    }
}

/// Velocity half of the rigid step, after [`rigid_gravity`]: the reactions of deformable
/// objects' grids (`reactions[k]`: the impulse and angular impulse object k received this
/// substep; every solid adds its reaction to its frame's contact impulses). A sleeping rigid
/// object that a reaction wakes takes this substep's gravity here.
fn rigid_velocities(env: &Env, bodies: &mut [Body], dt: f64, reactions: &[Reaction]) {
    let g = env.gravity_m_s2.as_dvec3();
    for (k, b) in bodies.iter_mut().enumerate() {
        let r = reactions.get(k).copied().unwrap_or_default();
        b.stats.frame_impulse_n_s += r.impulse_n_s;
        b.stats.frame_angular_impulse_n_m_s += r.angular_impulse_n_m_s;
        if b.kind != ObjectKind::Rigid || !env.stepping(k) {
            continue;
        }
        let mut gravity = DVec3::ZERO;
        if b.sleeping {
            // A moving deformable object pushing on it wakes it.
            if r.nodes == 0 || r.impulse_n_s.length() < b.rigid.mass_kg * g.length() * dt {
                continue;
            }
            b.sleeping = false;
            b.still_s = 0.0;
            gravity = g;
        }
        rigid::integrate_velocity(b, gravity, dt, r.impulse_n_s, r.angular_impulse_n_m_s);
        b.push = (DVec3::ZERO, DVec3::ZERO);
    }
}

/// Position half of the rigid step, with the contact solver's push-out.
fn rigid_positions(env: &Env, bodies: &mut [Body], dt: f64) {
    for (k, b) in bodies.iter_mut().enumerate() {
        if b.kind == ObjectKind::Rigid && !b.sleeping && env.stepping(k) {
            let (pv, pw) = b.push;
            rigid::integrate_position(b, dt, pv, pw);
        }
    }
}
