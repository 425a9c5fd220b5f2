//! Sleeping: objects that stay still skip all work until something moving touches them, a
//! command or an event (as in rigid-body engines). Objects in contact sleep together, as an
//! island (the objects connected by contacts this substep): an island sleeps once every member
//! has been slower than [`SLEEP_SPEED_M_S`] for [`SLEEP_AFTER_S`]. A sleeping object is
//! immovable to the contact solver; it wakes when a moving object touches it (a contact, or for
//! a deformable object the bounds of a moving solid or an active moving collider reaching it).
//! A sleeping object's velocities are zero and its object-level state is cached
//! ([`Body::state_cache`]). `[simulation] sleep = false` turns sleeping off.

use glam::{DVec3, Mat3A, Vec3A};

use super::contact::{ContactReport, Other};
use super::{Body, Env, World};
use crate::scene::ObjectKind;

/// Speed below which an object counts as still (m/s).
pub const SLEEP_SPEED_M_S: f32 = 5e-3;
/// How long an island must stay still before it sleeps (s).
pub const SLEEP_AFTER_S: f64 = 0.25;

impl Body {
    /// Wakes the body: it may be edited or moved, so its cached state goes.
    pub(super) fn wake(&mut self) {
        self.sleeping = false;
        self.state_cache = None;
        self.still_s = 0.0;
    }

    /// Wakes the body because something moving touches it.
    pub(super) fn wake_on_contact(&mut self) {
        if self.sleeping {
            self.sleeping = false;
            self.still_s = 0.0;
            self.state_cache = None;
        }
    }

    /// Whether the body moves fast enough to wake what it touches.
    pub(super) fn is_moving(&self) -> bool {
        self.is_active() && self.max_speed_m_s >= SLEEP_SPEED_M_S
    }

    fn fall_asleep(&mut self) {
        self.leave_device();
        self.sleeping = true;
        self.particles.v.iter_mut().for_each(|v| *v = Vec3A::ZERO);
        self.particles.c.iter_mut().for_each(|c| *c = Mat3A::ZERO);
        self.rigid.velocity_m_s = DVec3::ZERO;
        self.rigid.omega_rad_s = DVec3::ZERO;
        self.max_speed_m_s = 0.0;
        self.supports.clear();
    }
}

/// Union-find root of `k`, with path halving.
pub(super) fn root(parent: &mut [usize], mut k: usize) -> usize {
    while parent[k] != k {
        parent[k] = parent[parent[k]];
        k = parent[k];
    }
    k
}

impl World {
    /// Wakes object `id` for a command or event: it may be edited, so its cached state goes.
    pub(super) fn wake(&mut self, id: usize) {
        self.bodies[id].wake();
    }
}

/// Counts still time, puts still islands (objects joined by the `last` contact points) to sleep
/// and wakes sleeping deformable objects that a moving solid or collider reaches.
pub(super) fn update(env: &Env, bodies: &mut [Body], last: &[ContactReport], dt: f64) {
    if !env.settings.sleep {
        return;
    }
    let n = bodies.len();
    // Kinematic objects move as commanded and never sleep; to islands they are supports.
    // Objects of another island (`islands.rs`) count their time when they step.
    let stepping: Vec<bool> = (0..n).map(|k| env.stepping(k)).collect();
    let sleeper = |b: &Body| b.is_active() && b.kind != ObjectKind::Kinematic;
    for (b, _) in bodies.iter_mut().zip(&stepping).filter(|(_, s)| **s) {
        if sleeper(b) {
            if b.max_speed_m_s < SLEEP_SPEED_M_S {
                b.still_s += dt;
            } else {
                b.still_s = 0.0;
            }
        }
    }
    // Islands of awake objects joined by contacts; an island is ready when all are still.
    let mut parent: Vec<usize> = (0..n).collect();
    for c in last {
        let (a, b) = match c.b {
            Other::Object(b) => (c.a as usize, b as usize),
            _ => continue,
        };
        if sleeper(&bodies[a]) && sleeper(&bodies[b]) {
            let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
            parent[ra.max(rb)] = ra.min(rb);
        }
    }
    let mut ready = vec![true; n];
    for (k, &steps) in stepping.iter().enumerate() {
        let r = root(&mut parent, k);
        if sleeper(&bodies[k]) && (bodies[k].still_s < SLEEP_AFTER_S || !steps) {
            ready[r] = false;
        }
    }
    for (k, &steps) in stepping.iter().enumerate() {
        let r = root(&mut parent, k);
        if sleeper(&bodies[k]) && ready[r] && steps {
            bodies[k].fall_asleep();
        }
    }
    // Sleeping objects reached by a moving collider, and sleeping deformable objects reached
    // by a moving solid, wake up (solids touching solids wake through contacts, solids under
    // deformable objects through grid reactions).
    for k in 0..n {
        let b = &bodies[k];
        let dx = b.dx_m();
        if !b.sleeping || !stepping[k] {
            continue;
        }
        let (lo, hi) = match (env.placed(bodies, k), b.state_cache.as_ref()) {
            (Some(p), _) => p.bounds_m,
            (None, Some(s)) => (s.aabb_m.0.as_vec3a(), s.aabb_m.1.as_vec3a()),
            (None, None) => {
                let s = match b.kind {
                    ObjectKind::Deformable => super::measure::measure_bounds(&b.particles, dx),
                    _ => b.state(),
                };
                (s.aabb_m.0.as_vec3a(), s.aabb_m.1.as_vec3a())
            }
        };
        let reach = |o: (Vec3A, Vec3A)| (lo - dx).cmple(o.1).all() && (o.0 - dx).cmple(hi).all();
        let by_solid = b.kind == ObjectKind::Deformable
            && (0..n).any(|j| {
                j != k
                    && stepping[j]
                    && bodies[j].is_moving()
                    && env.placed(bodies, j).is_some_and(|p| reach(p.bounds_m))
            });
        let by_collider = env.colliders.iter().any(|c| {
            c.velocity_at(env.time_s) != Vec3A::ZERO
                && c.signed_distance((lo + hi) * 0.5, env.time_s)
                    .is_some_and(|(d, _)| d < (hi - lo).length() * 0.5 + dx)
        });
        if by_solid || by_collider {
            bodies[k].wake();
        }
    }
}
