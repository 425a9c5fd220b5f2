//! Kinematic objects: solids that move only as commanded, with infinite mass in contacts (a hand
//! or a tool driven by a client, a scripted paddle).
//!
//! A kinematic object is driven by a [`Drive`]: a velocity (linear and angular, held until the
//! next command) or a pose to reach at the end of a step. A pose is reached at constant linear
//! and angular velocity from where the object is: at the start of every substep the velocity is
//! re-derived as (target − now) / (time left), and the rotation as the shortest rotation
//! log(q_target q⁻¹) / (time left), so the motion is interpolated over the frame's substeps and
//! ends exactly on the pose. The object then holds still.
//!
//! Its velocity field v + ω × r enters the contact solver (zero inverse mass and inertia) and the
//! deformable objects' grids as a moving boundary, and its speed at its farthest particle enters
//! the CFL bound, so a fast motion cannot tunnel through a cell in one substep. Gravity, contacts
//! and commands other than `set-pose`, `set-velocity`, `set-kind` and `edit-material` do not move
//! it. The impulses it receives are summed over each frame and published as a contact force and
//! torque ([`Body::frame_impulse_n_s`]).

use glam::{DQuat, DVec3};

use super::{Body, Env, World, WorldError};
use crate::scene::{Command, EventSpec, ObjectKind};
use splatphys_types::limits::{MAX_COMMAND_SPEED_M_S, MAX_POSITION_M};

/// What moves a kinematic object.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Drive {
    /// Its rigid state's velocity and angular velocity, held (zero: still).
    #[default]
    Velocity,
    /// Reach this pose at simulated time `at_s`, then hold still.
    Pose {
        /// COM position (m).
        com_m: DVec3,
        /// Orientation relative to the rest pose (unit).
        orientation: DQuat,
        /// When (s).
        at_s: f64,
    },
}

/// The rotation vector (axis × angle, rad) of the shortest rotation from `from` to `to`.
fn rotation_between(from: DQuat, to: DQuat) -> DVec3 {
    let mut d = (to * from.inverse()).normalize();
    if d.w < 0.0 {
        d = -d;
    }
    d.to_scaled_axis()
}

impl Body {
    /// Sets a kinematic object's velocity for the substep starting at `time_s` from its drive
    /// (module docs), and its fastest particle speed for the CFL bound.
    fn drive_velocity(&mut self, time_s: f64) {
        if let Drive::Pose {
            com_m,
            orientation,
            at_s,
        } = self.drive
        {
            let left = at_s - time_s;
            let rs = &mut self.rigid;
            if left > 1e-12 {
                rs.velocity_m_s = (com_m - rs.com_m) / left;
                rs.omega_rad_s = rotation_between(rs.orientation.as_dquat(), orientation) / left;
            } else {
                self.arrive();
            }
        }
        self.max_speed_m_s = self.rigid_speed_m_s();
    }

    /// Puts a kinematic object on its target pose, still.
    fn arrive(&mut self) {
        if let Drive::Pose {
            com_m, orientation, ..
        } = self.drive
        {
            self.rigid.com_m = com_m;
            self.rigid.orientation = orientation.as_quat();
        }
        self.rigid.velocity_m_s = DVec3::ZERO;
        self.rigid.omega_rad_s = DVec3::ZERO;
        self.drive = Drive::Velocity;
    }

    /// Moves a kinematic object over a substep of `dt_s` ending at `end_s`: x += v dt,
    /// R = exp(ω dt) R; on its target pose when the substep ends at the pose's time.
    fn advance_kinematic(&mut self, dt_s: f64, end_s: f64) {
        let rs = &mut self.rigid;
        rs.com_m += rs.velocity_m_s * dt_s;
        let q = DQuat::from_scaled_axis(rs.omega_rad_s * dt_s) * rs.orientation.as_dquat();
        rs.orientation = q.normalize().as_quat();
        if let Drive::Pose { at_s, .. } = self.drive
            && end_s >= at_s - 1e-9
        {
            self.arrive();
        }
    }

    /// Adds a contact impulse `j_n_s` (N s) received at `point_m` (m) to this frame's sums.
    pub(super) fn record_contact(&mut self, j_n_s: DVec3, point_m: DVec3) {
        self.stats.frame_impulse_n_s += j_n_s;
        self.stats.frame_angular_impulse_n_m_s += (point_m - self.rigid.com_m).cross(j_n_s);
    }
}

impl World {
    fn kinematic(&self, id: usize, command: &str) -> Result<&Body, WorldError> {
        let b = self
            .bodies
            .get(id)
            .ok_or_else(|| WorldError::UnknownObject(format!("#{id}")))?;
        if b.kind != ObjectKind::Kinematic {
            return Err(WorldError::Refused {
                object: b.name.clone(),
                reason: format!(
                    "{command} drives kinematic objects; this one is {} (set-kind it to kinematic first)",
                    b.kind
                ),
            });
        }
        Ok(b)
    }

    /// Drives kinematic object `id` to COM `position_m` and orientation `orientation_wxyz`
    /// (relative to its rest pose) at the end of step `at_step` (module docs); a step already
    /// begun, or `None`, means the end of the current step.
    ///
    /// # Errors
    /// [`WorldError::Refused`] for an object that is not kinematic, a non-finite or zero
    /// quaternion, a position farther than [`MAX_POSITION_M`] from the origin, or a motion whose
    /// speed (linear plus ω times the object's farthest particle distance) would exceed
    /// [`MAX_COMMAND_SPEED_M_S`]; unknown object.
    pub fn set_pose(
        &mut self,
        id: usize,
        position_m: [f64; 3],
        orientation_wxyz: [f64; 4],
        at_step: Option<u64>,
    ) -> Result<(), WorldError> {
        let b = self.kinematic(id, "set-pose")?;
        let refuse = |reason: String| WorldError::Refused {
            object: b.name.clone(),
            reason,
        };
        let p = DVec3::from(position_m);
        let [w, x, y, z] = orientation_wxyz;
        let q = DQuat::from_xyzw(x, y, z, w);
        if !p.is_finite() || !q.is_finite() {
            return Err(refuse("non-finite pose".into()));
        }
        if p.length() > MAX_POSITION_M {
            return Err(refuse(format!(
                "position {:.3e} m from the origin is beyond the limit of {MAX_POSITION_M} m",
                p.length()
            )));
        }
        if q.length() < 1e-6 {
            return Err(refuse(
                "orientation_wxyz is not a rotation (zero length)".into(),
            ));
        }
        let q = q.normalize();
        let step = at_step.unwrap_or(0).max(self.frame + 1);
        let at_s = step as f64 * self.frame_dt_s();
        let left = at_s - self.time_s;
        let linear = (p - b.rigid.com_m).length() / left;
        let angular = rotation_between(b.rigid.orientation.as_dquat(), q).length() / left;
        let speed = linear + angular * b.arm_m();
        if !speed.is_finite() || speed > MAX_COMMAND_SPEED_M_S {
            return Err(refuse(format!(
                "reaching that pose by step {step} ({left:.4} s from now) needs {speed:.3e} m/s \
                 ({linear:.3e} m/s linear, {angular:.3e} rad/s); the limit is \
                 {MAX_COMMAND_SPEED_M_S} m/s: give a later at_step"
            )));
        }
        self.wake(id);
        self.bodies[id].drive = Drive::Pose {
            com_m: p,
            orientation: q,
            at_s,
        };
        Ok(())
    }
}

/// Sets every stepping kinematic object's velocity for the substep about to start (before its
/// dt is chosen, so their speeds enter the CFL bound).
pub(super) fn drive(env: &Env, bodies: &mut [Body]) {
    for (k, b) in bodies.iter_mut().enumerate() {
        if b.kind == ObjectKind::Kinematic && env.stepping(k) {
            b.drive_velocity(env.time_s);
        }
    }
}

/// Moves every stepping kinematic object over the substep of `dt_s` that starts at
/// `env.time_s`.
pub(super) fn positions(env: &Env, bodies: &mut [Body], dt_s: f64) {
    let end = env.time_s + dt_s;
    for (k, b) in bodies.iter_mut().enumerate() {
        if b.kind == ObjectKind::Kinematic && env.stepping(k) {
            b.advance_kinematic(dt_s, end);
        }
    }
}

/// Scene `set-pose` events without `at_step` are keyframes: the object reaches the pose at the
/// event's `at_s` (the end of step round(at_s × `frame_rate_hz`)), moving from where it is at its
/// previous event (or at 0 s). Such an event is moved to fire at that previous event's time with
/// that step; the result is sorted by firing time (stable).
pub fn keyframes(mut events: Vec<EventSpec>, frame_rate_hz: f64) -> Vec<EventSpec> {
    events.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
    let mut last: std::collections::HashMap<String, f64> = Default::default();
    for e in &mut events {
        let Some(object) = e.command.object().cloned() else {
            continue;
        };
        let previous = last.insert(object, e.at_s).unwrap_or(0.0);
        if let Command::SetPose { at_step, .. } = &mut e.command
            && at_step.is_none()
        {
            *at_step = Some((e.at_s * frame_rate_hz).round() as u64);
            e.at_s = previous;
        }
    }
    events.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
    events
}
