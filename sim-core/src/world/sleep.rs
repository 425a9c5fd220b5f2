//! Sleeping: an object that stays still and touches nothing for a while skips all work until a
//! contact, a command or an event wakes it (as in rigid-body engines, per object rather than
//! per island). A sleeping object's velocities are zero and its object-level state is
//! cached ([`Body::state_cache`]).

use glam::{DVec3, Mat3A, Vec3A};

use super::{Body, World};
use crate::scene::ObjectKind;

/// Speed below which an object counts as still (m/s).
pub const SLEEP_SPEED_M_S: f32 = 5e-3;
/// How long an object must stay still, touching nothing, before it sleeps (s).
pub const SLEEP_AFTER_S: f64 = 0.25;

impl Body {
    /// Wakes the body when a contact touches it. Its cached state stays: the contact pass
    /// measured it this substep, and an awake body's cache is dropped on the next one.
    pub(super) fn wake_on_contact(&mut self) {
        if self.sleeping {
            self.sleeping = false;
            self.still_s = 0.0;
        }
    }
}

impl World {
    /// Wakes object `id` for a command or event: it may be edited, so its cached state goes.
    pub(super) fn wake(&mut self, id: usize) {
        self.bodies[id].sleeping = false;
        self.bodies[id].state_cache = None;
        self.bodies[id].still_s = 0.0;
    }

    /// Puts to sleep every object that has been still (slower than [`SLEEP_SPEED_M_S`]) and
    /// touching nothing for [`SLEEP_AFTER_S`]; its velocities become zero.
    pub(super) fn update_sleep(&mut self, dt: f64) {
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
}
