//! Rigid objects skip MPM: semi-implicit Euler on the COM, orientation integrated from ω
//! (q ← normalise(q + dt/2 · ω q)), and contacts with the grid colliders resolved with the same
//! impulse law as object contacts (the collider is immovable) plus a positional push-out along
//! the contact normal. Sticky surfaces stop all tangential sliding; slip and separate ones use
//! Coulomb friction with the larger of the surface's and the object's coefficient.

use glam::{DMat3, DQuat, DVec3};

use super::body::{Body, inverse_or_zero};
use super::contact::{Dynamics, impulse};
use crate::collider::{Collider, Surface};

/// Advances rigid `body` by `dt_s` under gravity, with collider contacts at time `time_s`.
/// Returns the number of colliders touched.
pub fn step(
    body: &mut Body,
    gravity: DVec3,
    dt_s: f64,
    colliders: &[Collider],
    time_s: f64,
) -> u32 {
    let rs = &mut body.rigid;
    rs.velocity_m_s += gravity * dt_s;
    rs.com_m += rs.velocity_m_s * dt_s;
    let w = rs.omega_rad_s;
    let q = rs.orientation.as_dquat();
    let dq = DQuat::from_xyzw(w.x, w.y, w.z, 0.0) * q * (0.5 * dt_s);
    rs.orientation = (q + dq).normalize().as_quat();
    body.sync_rigid_particles();
    let mut touched = 0;
    for collider in colliders {
        let mut m = 0.0f64;
        let mut mx = DVec3::ZERO;
        let mut n = DVec3::ZERO;
        let mut depth = 0.0f64;
        for (x, &mi) in body.particles.x.iter().zip(&body.particles.mass_kg) {
            if let Some((normal, d)) = collider.penetration(*x, time_s) {
                m += mi as f64;
                mx += x.as_dvec3() * mi as f64;
                n += normal.as_dvec3() * mi as f64;
                depth = depth.max(d as f64);
            }
        }
        let Some(n) = n.try_normalize() else { continue };
        touched += 1;
        let point = mx / m;
        let world_inertia = body.rigid_world_inertia();
        let rs = &body.rigid;
        let me = Dynamics {
            com_m: rs.com_m,
            velocity_m_s: rs.velocity_m_s,
            omega_rad_s: rs.omega_rad_s,
            inverse_mass: 1.0 / rs.mass_kg,
            inverse_inertia: inverse_or_zero(world_inertia),
        };
        let wall = Dynamics {
            com_m: point,
            velocity_m_s: collider.velocity_at(time_s).as_dvec3(),
            omega_rad_s: DVec3::ZERO,
            inverse_mass: 0.0,
            inverse_inertia: DMat3::ZERO,
        };
        let mu = match collider.surface {
            Surface::Sticky => f64::INFINITY,
            _ => collider.friction.max(body.friction) as f64,
        };
        let resting = 2.0 * gravity.length() * dt_s;
        // The collider is "A" (normal from A to B = the body): impulse acts on the body.
        if let Some(j) = impulse(&wall, &me, point, n, body.restitution as f64, mu, resting) {
            let rs = &mut body.rigid;
            rs.velocity_m_s += j / rs.mass_kg;
            rs.omega_rad_s += inverse_or_zero(world_inertia) * (point - rs.com_m).cross(j);
        }
        body.rigid.com_m += n * depth;
        body.sync_rigid_particles();
    }
    touched
}
