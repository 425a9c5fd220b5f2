//! Rolling resistance where a deformable object meets a solid on its grid.
//!
//! A soft ball on a table stops rolling because the material entering its contact region is
//! compressed and the material leaving it recovers with a loss (hysteresis). On practical grids
//! the contact region is a cell or less wide, so MPM does not resolve that loss, and nothing
//! else slows a rolling or rocking object: a jelly ball dropped on a table rocks on for seconds.
//! The sub-grid model is Coulomb's rolling friction (the lever-arm form used by MuJoCo's
//! rolling friction and Box2D v3's rolling resistance): a couple against the rolling of at most
//! b N, b the pair's rolling resistance (m, the larger of the two objects'; grid colliders and
//! the background have none of their own) and N the contact's normal force.
//!
//! Per substep and per solid a deformable object touched on its grid:
//! - N dt = |J_n|, the normal impulse the grid gave the object there (`touches`), and n = J_n / |J_n|;
//! - ω_r: the object's angular velocity (ω = I⁻¹ L of its particles) relative to the solid's,
//!   without its part along n (a spin about the normal is the boundary's friction's);
//! - the couple's angular impulse h = s (I⁻¹ + I_s⁻¹)⁻¹ ω_r with s = min(1, b |J_n| / |(I⁻¹ +
//!   I_s⁻¹)⁻¹ ω_r|), I_s the solid's inertia (infinite unless it is an awake rigid object, which
//!   the couple turns: the two-body form, I ω_r against an immovable solid): the object's ω
//!   changes by −I⁻¹ h, the solid's by I_s⁻¹ h. It never reverses the rolling, and it is
//!   skipped if it would add kinetic energy.
//!
//! The change is a rigid rotation field about the COM (no strain rate, so the material's own
//! state is untouched); the grid's friction then brings the contact point back to rolling in
//! the next substeps, so the object slows as a whole: a rolling ball decelerates at
//! (5/7) g b / R. A solid object receives the opposite couple (a rigid one turns with it, any
//! one publishes it in its contact torque); a collider or the background takes it.

use glam::{DMat3, DVec3};

use super::Env;
use super::body::Body;
use super::coherence;
use super::impact::SolidOf;
use super::measure::inverse_or_zero;
use super::mpm_step::Touch;
use crate::contact::boundary::Reaction;
use crate::scene::ObjectKind;

/// The solid's rolling resistance (m), angular velocity (rad/s) and world inverse inertia
/// (1/(kg m²); zero unless it is an awake rigid object, which the couple turns).
fn solid_rolling(bodies: &[Body], solid: SolidOf) -> (f32, DVec3, DMat3) {
    match solid {
        SolidOf::Object(o) => {
            let b = &bodies[o];
            let omega = if b.moves_rigidly() {
                b.rigid.omega_rad_s
            } else {
                DVec3::ZERO
            };
            let inverse_inertia = if b.kind == ObjectKind::Rigid && !b.sleeping {
                inverse_or_zero(b.rigid_world_inertia())
            } else {
                DMat3::ZERO
            };
            (b.rolling_resistance_m, omega, inverse_inertia)
        }
        SolidOf::Collider(_) | SolidOf::Background => (0.0, DVec3::ZERO, DMat3::ZERO),
    }
}

/// Applies rolling resistance for this substep's `touches` (module docs); the couple a solid
/// object receives is added to its entry of `reactions`.
pub(super) fn rolling_resistance(
    env: &Env,
    bodies: &mut [Body],
    touches: &[Touch],
    reactions: &mut [Reaction],
) {
    // The substep functions list each object's touches together, in object order.
    for own in touches.chunk_by(|x, y| x.object == y.object) {
        let k = own[0].object;
        let b = &bodies[k];
        if b.kind != ObjectKind::Deformable || b.sleeping || !env.stepping(k) {
            continue;
        }
        // The pair's lever arm b for each touch (0: no rolling resistance there).
        let arm = |t: &Touch| {
            let (b_solid, j) = (solid_rolling(bodies, t.solid).0, t.impulse_n_s);
            let arm = f64::from(b.rolling_resistance_m.max(b_solid));
            if j.is_finite() && j != DVec3::ZERO {
                arm
            } else {
                0.0
            }
        };
        if !own.iter().any(|t| arm(t) > 0.0) {
            continue;
        }
        let s = b.measured();
        if s.mass_kg <= 0.0 {
            continue;
        }
        let mut omega = s.angular_velocity();
        let inverse_inertia = inverse_or_zero(s.inertia);
        let mut total = DVec3::ZERO;
        for touch in own {
            let (arm, solid, j) = (arm(touch), touch.solid, touch.impulse_n_s);
            if arm <= 0.0 {
                continue;
            }
            let (_, omega_solid, solid_inverse_inertia) = solid_rolling(bodies, solid);
            let n = j.normalize();
            let relative = omega - omega_solid;
            let rolling = relative - n * relative.dot(n);
            // The angular impulse h that stops the relative rolling of the two bodies,
            // (I_o⁻¹ + I_s⁻¹) h = ω_r: I_o ω_r against an immovable solid.
            let wanted = inverse_or_zero(inverse_inertia + solid_inverse_inertia) * rolling;
            if !(wanted.length() > 0.0 && wanted.is_finite()) {
                continue;
            }
            let share = (arm * j.length() / wanted.length()).min(1.0);
            let h = wanted * share;
            let dw = -(inverse_inertia * h);
            let dw_solid = solid_inverse_inertia * h;
            // Kinetic energy change of both rotations, ω·IΔω + ½ ΔωᵀIΔω each: never positive.
            let mut gain = omega.dot(s.inertia * dw) + 0.5 * dw.dot(s.inertia * dw);
            if solid_inverse_inertia != DMat3::ZERO {
                gain += omega_solid.dot(h) + 0.5 * h.dot(dw_solid);
            }
            if gain > 0.0 {
                continue;
            }
            omega += dw;
            total += dw;
            // A rigid solid turns with it; any solid publishes it in its contact torque.
            if let SolidOf::Object(o) = solid {
                reactions[o].angular_impulse_n_m_s += h;
            }
        }
        if total != DVec3::ZERO {
            if bodies[k].on_device() {
                bodies[k].device_rigid_field(DVec3::ZERO, total, s.com_m);
            } else {
                coherence::spin(&mut bodies[k], total, s.com_m);
            }
        }
    }
}
