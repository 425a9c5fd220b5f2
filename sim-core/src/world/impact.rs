//! The restitution law where a deformable object meets a solid on its grid.
//!
//! Boundary nodes stop a deformable object's approach, and its rebound is then its own
//! elasticity: an MPM jelly is nearly lossless, so without more it would bounce off a static
//! table for ever whatever e says. The law is applied at the object level, as the paper does for
//! object pairs:
//! - when the grid first gives a deformable object an impulse at a solid (more than
//!   [`NEGLIGIBLE_TOUCH_M_S`] of velocity), its velocity relative to the solid's at the contact
//!   point is recorded; the contact lasts while any of the object's grid nodes with mass lies
//!   inside the solid;
//! - over the contact, the normal impulses the grid gives it (each node's Δp along the solid's
//!   normal there) and their moments about the solid's COM are summed; the direction of the sum
//!   is the contact normal n, from the solid into the object, and its line of action the
//!   contact point (lever arm r from the solid's COM, [`lever_m`]), where a turning solid's
//!   velocity v + ω × r is the one the object's is taken against. (The whole impulse leans with
//!   the friction of an oblique impact: taken along the first substep's whole impulse, the law
//!   let a jelly thrown at 45° onto a plane with friction leave at 0.80 to 1.17 m/s for e = 0.5
//!   and a 1 m/s approach.)
//! - when the contact ends, the approach speed a is the recorded velocity along n, and a
//!   separation speed s above e·a (e = max(e_object, e_solid); a grid collider's and the
//!   background's e is 0, so the object's own applies; above the normal velocity at first touch
//!   when the object was already separating then, so a grazing second touch does not take a
//!   rebound away) is removed by a uniform velocity change −(s − e a) n.
//!
//! When the law acts, the friction the grid gave the object over the contact is also held to μ
//! times the normal impulse the object keeps, the excess given back at the contact point
//! (`impact_friction.rs`): the grid's friction acted on the elastic rebound too.
//!
//! The normal change leaves the object's deformation and angular momentum alone, and the law only
//! ever removes energy; a rigid solid takes the opposite momentum (a kinematic or static one counts
//! it in its contact force). Against an awake rigid solid the excess is removed between the two,
//! with the effective mass at the contact, 1 / (1/m + 1/M + (r × n)·I⁻¹(r × n)), the solid taking
//! its impulse at the contact point, so it turns (the impulse of Mirtich 1996): the object's share
//! alone would throw a solid lighter than it, and against the solid's COM velocity alone a jelly
//! ball landing at e = 0 on the end of a free plank left with the plank's end falling away at 2.5
//! times its speed. But where the solid leans on others along n (a floor, a box under it), they
//! gave the rebound: up to what they pushed it with along n over the contact (its momentum change
//! less the object's impulse and gravity's), the excess goes back to them, the solid held as
//! immovable (shared with it, a 154 g box lying on a floor was thrown 16 cm up by a jelly ball
//! landing on it at e = 0). Held, its contact point keeps the velocity it had at first touch, so
//! only the object's separation from that is taken back this way.
//!
//! Until the contact ends the grid's impact is nearly elastic, so a light solid that meets a
//! third body during it does so with the elastic kick (a see-saw's end striking the floor).
//! Taken in every substep of the contact instead, the law made objects resting on light rigid
//! solids land lower and drift on them in the first half second.
//!
//! A resting object never ends its contact and is not touched; a contact older than
//! [`IMPACT_SETTLES_S`], or one a command interrupts (an impulse or a velocity on the object),
//! ends without the law.

use std::collections::HashMap;

use glam::{DMat3, DVec3};

use super::body::Body;
use super::impact_friction::{Side, after, give_back};
use super::measure::inverse_or_zero;
use super::mpm_step::Touch;
use super::{Env, World};
use crate::collider::Surface;
use crate::contact::{mix_friction, mix_restitution};
use crate::scene::ObjectKind;

/// A solid a deformable object touched.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub(crate) enum SolidOf {
    /// A static, rigid or kinematic object.
    Object(usize),
    /// A grid collider (its e is the object's).
    Collider(usize),
    /// The captured background (its e is the object's).
    Background,
}

/// A contact between a deformable object and a solid, from its first substep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Impact {
    /// The object's COM velocity relative to the solid at first touch (m/s).
    pub touch_velocity_m_s: DVec3,
    /// The solid's own COM velocity at first touch (m/s).
    pub solid_velocity_m_s: DVec3,
    /// The solid's velocity at the contact point at first touch (m/s).
    pub solid_point_velocity_m_s: DVec3,
    /// Normal impulse the grid gave the object so far (N s); its direction is the contact
    /// normal, from the solid into the object.
    pub impulse_n_s: DVec3,
    /// The moment of `impulse_n_s` about the solid's COM, summed as it went (N m s): where the
    /// contact is, [`lever_m`].
    pub moment_n_m_s: DVec3,
    /// Friction impulse the grid gave the object so far (N s; `impact_friction.rs`).
    pub friction_n_s: DVec3,
    /// When it began (simulated s).
    pub start_s: f64,
}

/// A contact that lasts longer than this (s) has come to rest: what ends it later (a command, a
/// push from another object) is not its rebound, and the law leaves it alone. Impacts of the
/// softest jellies last about 0.1 s.
pub const IMPACT_SETTLES_S: f64 = 0.5;

/// A grid impulse that changes the object's velocity by less than this (m/s) does not open a
/// contact.
pub const NEGLIGIBLE_TOUCH_M_S: f64 = 1e-6;

/// The velocity (m/s) of `solid` at `lever_m` (m) from its COM: a rigid or kinematic object's
/// v + ω × r, a collider's.
fn solid_velocity(env: &Env, bodies: &[Body], solid: SolidOf, lever_m: DVec3) -> DVec3 {
    match solid {
        SolidOf::Object(k) if bodies[k].moves_rigidly() => {
            let rigid = &bodies[k].rigid;
            rigid.velocity_m_s + rigid.omega_rad_s.cross(lever_m)
        }
        SolidOf::Collider(c) => env.colliders[c].velocity_at(env.time_s).as_dvec3(),
        _ => DVec3::ZERO,
    }
}

/// The friction impulse the law gives back to deformable `k` as its impact `imp` on `solid`
/// ends (N s, on the object; `impact_friction.rs`), the object's change of angular velocity
/// from it (rad/s), and the contact point (m) where that and the law's normal impulse act,
/// after the law took normal impulse `j` (N s) off the object, `j_shared` of it shared with an
/// awake rigid solid. The contact point lies on the normal
/// impulses' line of action ([`lever_m`]; through the object's COM at a collider or the
/// background), where the object's bounding box reaches furthest toward the solid.
fn friction_given_back(
    env: &Env,
    bodies: &[Body],
    (k, solid): (usize, SolidOf),
    imp: &Impact,
    (j, j_shared): (f64, f64),
) -> (DVec3, DVec3, DVec3) {
    let normal = imp.impulse_n_s.normalize_or_zero();
    let state = bodies[k].measured();
    let (lo, hi) = state.aabb_m;
    let nearest = (lo * normal).min(hi * normal);
    let reach = state.com_m.dot(normal) - (nearest.x + nearest.y + nearest.z);
    let foot = state.com_m - normal * reach;
    let immovable = |velocity_m_s: DVec3, omega_rad_s: DVec3, arm_m: DVec3| Side {
        inverse_mass: 0.0,
        inverse_inertia: DMat3::ZERO,
        velocity_m_s,
        omega_rad_s,
        arm_m,
    };
    let (point, solid_side) = match solid {
        SolidOf::Object(o) => {
            let b = &bodies[o];
            let com = b.rigid.com_m;
            let lever = lever_on(bodies, solid, imp.impulse_n_s, imp.moment_n_m_s);
            let point = com + lever + normal * (foot - com).dot(normal);
            let (v, w) = if b.moves_rigidly() {
                (b.rigid.velocity_m_s, b.rigid.omega_rad_s)
            } else {
                (DVec3::ZERO, DVec3::ZERO)
            };
            let mut side = immovable(v, w, point - com);
            if b.kind == ObjectKind::Rigid && !b.sleeping {
                side.inverse_mass = 1.0 / b.rigid.mass_kg.max(f64::MIN_POSITIVE);
                side.inverse_inertia = inverse_or_zero(b.rigid_world_inertia());
            }
            (point, side)
        }
        SolidOf::Collider(_) | SolidOf::Background => {
            let v = solid_velocity(env, bodies, solid, DVec3::ZERO);
            (foot, immovable(v, DVec3::ZERO, DVec3::ZERO))
        }
    };
    let Some(mu) = pair_friction(env, bodies, k, solid) else {
        return (DVec3::ZERO, DVec3::ZERO, point);
    };
    let object = Side {
        inverse_mass: 1.0 / state.mass_kg,
        inverse_inertia: inverse_or_zero(state.inertia),
        velocity_m_s: state.velocity_m_s,
        omega_rad_s: state.angular_velocity(),
        arm_m: point - state.com_m,
    };
    // The kinetic energy the normal part removes, relative to the solid's contact point: the
    // held part against the solid as immovable, then the shared part between the two (the
    // object's change is uniform: its COM's).
    let k_object = object.inverse_mass;
    let u_n = (object.velocity_m_s - solid_side.point_velocity()).dot(normal);
    let held = j - j_shared;
    let k_shared = k_object + solid_side.inverse_mass_along(normal);
    let removed = held * u_n - 0.5 * held * held * k_object + j_shared * (u_n - held * k_object)
        - 0.5 * j_shared * j_shared * k_shared;
    let object = Side {
        velocity_m_s: object.velocity_m_s - normal * (j * k_object),
        ..object
    };
    let solid_side = after(&solid_side, normal * j_shared);
    let kept = imp.impulse_n_s.length() - j;
    let friction = give_back(
        (imp.friction_n_s, normal),
        kept,
        mu,
        (&object, &solid_side),
        imp.touch_velocity_m_s,
        removed,
    );
    let turn = object.inverse_inertia * object.arm_m.cross(friction);
    (friction, turn, point)
}

/// The friction μ the grid's rule applied between deformable `k` and `solid` (the surface's
/// rule, [`crate::collider::Surface::friction`]); `None` for a clamp, which holds without
/// bound.
fn pair_friction(env: &Env, bodies: &[Body], k: usize, solid: SolidOf) -> Option<f64> {
    let (surface, mu) = match solid {
        SolidOf::Object(o) => (
            bodies[o].surface,
            mix_friction(bodies[k].friction, bodies[o].friction),
        ),
        SolidOf::Collider(c) => (env.colliders[c].surface, env.colliders[c].friction),
        SolidOf::Background => (
            Surface::Separate,
            mix_friction(bodies[k].friction, env.background.friction),
        ),
    };
    (surface != Surface::Clamp).then(|| f64::from(surface.friction(mu)))
}

impl World {
    /// Forgets object `k`'s open impacts: a command moved it, so how they end is not a rebound.
    pub(super) fn forget_impacts(&mut self, k: usize) {
        self.contacts.impacts.retain(|(object, _), _| *object != k);
    }
}

/// The lever arm (m) from a solid's COM to the line of action of a normal impulse `j_n_s`
/// (N s) whose moment about that COM is `moment_n_m_s` (N m s): r's part across j, from
/// j × (r × j) = r |j|² − j (j·r). Zero for no impulse.
fn lever_m(j_n_s: DVec3, moment_n_m_s: DVec3) -> DVec3 {
    let jj = j_n_s.length_squared();
    let r = j_n_s.cross(moment_n_m_s) / jj;
    if jj > 0.0 && r.is_finite() {
        r
    } else {
        DVec3::ZERO
    }
}

/// [`lever_m`] of a contact on `solid`, no longer than an object's reach from its COM
/// ([`Body::arm_m`]): normal impulses from opposite sides that nearly cancel leave a moment
/// whose line of action lies far off the body.
fn lever_on(bodies: &[Body], solid: SolidOf, j_n_s: DVec3, moment_n_m_s: DVec3) -> DVec3 {
    let r = lever_m(j_n_s, moment_n_m_s);
    match solid {
        SolidOf::Object(o) => r.clamp_length_max(bodies[o].arm_m()),
        SolidOf::Collider(_) | SolidOf::Background => r,
    }
}

/// Opens and closes `impacts` from this substep's `touches` and applies the law to the closed
/// ones (module docs).
pub(super) fn boundary_restitution(
    env: &Env,
    bodies: &mut [Body],
    impacts: &mut HashMap<(usize, SolidOf), Impact>,
    touches: &[Touch],
) {
    for t in touches {
        let (k, solid, j) = (t.object, t.solid, t.impulse_n_s);
        if !(j.is_finite() && t.moment_n_m_s.is_finite() && t.friction_n_s.is_finite()) {
            continue;
        }
        if let Some(open) = impacts.get_mut(&(k, solid)) {
            open.impulse_n_s += j;
            open.moment_n_m_s += t.moment_n_m_s;
            open.friction_n_s += t.friction_n_s;
            continue;
        }
        // A contact opens at its first impulse (the grid's nodes reach into the solid a cell
        // or more before the material does; round-off of nodes the rule leaves as they were,
        // ±1e-13 N s on a 0.27 kg ball, is none) and lasts while any of the object's nodes lies
        // inside the solid.
        if j.length() <= NEGLIGIBLE_TOUCH_M_S * bodies[k].rigid.mass_kg {
            continue;
        }
        let v = bodies[k].measured_bounds().velocity_m_s;
        let at = solid_velocity(
            env,
            bodies,
            solid,
            lever_on(bodies, solid, j, t.moment_n_m_s),
        );
        impacts.insert(
            (k, solid),
            Impact {
                touch_velocity_m_s: v - at,
                solid_velocity_m_s: solid_velocity(env, bodies, solid, DVec3::ZERO),
                solid_point_velocity_m_s: at,
                impulse_n_s: j,
                moment_n_m_s: t.moment_n_m_s,
                friction_n_s: t.friction_n_s,
                start_s: env.time_s,
            },
        );
    }
    let mut ended: Vec<((usize, SolidOf), Impact)> = impacts
        .iter()
        .filter(|(key, _)| {
            env.stepping(key.0) && !touches.iter().any(|t| (t.object, t.solid) == **key)
        })
        .map(|(key, imp)| (*key, *imp))
        .collect();
    ended.sort_by_key(|(key, _)| *key);
    for ((k, solid), imp) in ended {
        impacts.remove(&(k, solid));
        let b = &bodies[k];
        if b.kind != ObjectKind::Deformable || b.sleeping {
            continue;
        }
        // A settled contact, or a collider whose active window closed, is not a rebound.
        if env.time_s - imp.start_s > IMPACT_SETTLES_S {
            continue;
        }
        if let SolidOf::Collider(c) = solid
            && !env.colliders[c].is_active(env.time_s)
        {
            continue;
        }
        let Some(normal) = imp.impulse_n_s.try_normalize() else {
            continue;
        };
        let touch = imp.touch_velocity_m_s.dot(normal);
        let approach = (-touch).max(0.0);
        let s = b.measured_bounds();
        let lever = lever_on(bodies, solid, imp.impulse_n_s, imp.moment_n_m_s);
        let at = solid_velocity(env, bodies, solid, lever);
        let separation = (s.velocity_m_s - at).dot(normal);
        let e_solid = match solid {
            SolidOf::Object(o) => bodies[o].restitution,
            SolidOf::Collider(_) | SolidOf::Background => 0.0,
        };
        let e = mix_restitution(b.restitution, e_solid) as f64;
        // A touch while already separating (the far side of a ringing object grazing the
        // boundary again) keeps the speed it came with: the law caps what a contact adds.
        let allowed = (e * approach).max(touch);
        let excess = separation - allowed;
        if excess <= 0.0 || !excess.is_finite() {
            continue;
        }
        // The impulse that removes the excess: the object's mass alone against an immovable
        // solid; against an awake rigid one, first what others than the object (its supports)
        // pushed it with along n over the contact, besides gravity: they answered the object's
        // push, and their push less that stays ≥ 0. Then the rest between the two with the
        // effective mass at the contact, 1 / (1/m + 1/M + (r × n)·I⁻¹(r × n)).
        let (j_held, j_shared) = match solid {
            SolidOf::Object(o) if bodies[o].kind == ObjectKind::Rigid && !bodies[o].sleeping => {
                let solid = &bodies[o];
                let m_solid = solid.rigid.mass_kg.max(f64::MIN_POSITIVE);
                let gained = solid.rigid.velocity_m_s
                    - imp.solid_velocity_m_s
                    - env.gravity_m_s2.as_dvec3() * (env.time_s - imp.start_s);
                let held = (imp.impulse_n_s + gained * m_solid).dot(normal).max(0.0);
                // Held, the solid's contact point keeps its velocity at first touch: only the
                // object's separation from that is the supports' rebound (a see-saw's end
                // falling away from a jelly is not, and taking that back threw the jelly down
                // faster than it came).
                let held_excess = (s.velocity_m_s - imp.solid_point_velocity_m_s).dot(normal);
                let held_excess = (held_excess - allowed).clamp(0.0, excess);
                let j_held = (held_excess * s.mass_kg).min(held);
                let rest = excess - j_held / s.mass_kg;
                let arm = lever.cross(normal);
                let turn = arm.dot(inverse_or_zero(solid.rigid_world_inertia()) * arm);
                (j_held, rest / (1.0 / s.mass_kg + 1.0 / m_solid + turn))
            }
            _ => (excess * s.mass_kg, 0.0),
        };
        let j = j_held + j_shared;
        let (friction, dw, point) =
            friction_given_back(env, bodies, (k, solid), &imp, (j, j_shared));
        let dv = normal * -(j / s.mass_kg) + friction / s.mass_kg;
        let b = &mut bodies[k];
        if b.on_device() {
            b.device_rigid_field(dv, dw, s.com_m);
        } else {
            let (dv, dw, com) = (dv.as_vec3a(), dw.as_vec3a(), s.com_m.as_vec3a());
            for (v, x) in b.particles.v.iter_mut().zip(&b.particles.x) {
                *v += dv + dw.cross(*x - com);
            }
            b.max_speed_m_s = b.particles.v.iter().map(|v| v.length()).fold(0.0, f32::max);
        }
        if let SolidOf::Object(o) = solid {
            bodies[o].record_contact(normal * j - friction, point);
            if bodies[o].kind == ObjectKind::Rigid && !bodies[o].sleeping {
                bodies[o].apply_rigid_impulse(normal * j_shared - friction, point);
            }
        }
    }
}
