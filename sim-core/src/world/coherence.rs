//! Applying a contact impulse to a deformable object and the paper's "COM-based constraint
//! enforcement".
//!
//! A fraction of the impulse goes to the particles of the contact zone (their velocity change is
//! capped at twice the COM's, so a small zone cannot be flung), which MPM then turns into local
//! deformation; the rest is spread evenly. Then the object's particle momentum, linear and
//! angular, is made equal to its object-level value (old momentum + J, old angular momentum +
//! r × J) by adding a uniform velocity and a rigid rotation field (v += δv + δω × r, C += `[δω]×`):
//! rigid fields carry no strain rate, so the internal deformation velocities are undisturbed.

use glam::{DVec3, Mat3A, Vec3A};

use super::body::{Body, inverse_or_zero, measure};

/// Share of a contact impulse given to the contact zone (the rest spreads over the object).
pub const ZONE_SHARE: f64 = 0.5;

/// Applies impulse `j` (N s) at `point` (m) and angular impulse `h` (N m s, a couple) to
/// deformable `body`, zone particles `zone`.
pub fn apply_impulse(body: &mut Body, j: DVec3, h: DVec3, point: DVec3, zone: &[u32]) {
    let dx = body.solver.dx_m;
    let before = measure(&body.particles, dx);
    if before.mass_kg <= 0.0 {
        return;
    }
    let target_p = before.velocity_m_s * before.mass_kg + j;
    let target_l = before.angular_momentum + (point - before.com_m).cross(j) + h;
    // The zone kick's own momentum and angular momentum (about the COM), so the rigid field
    // that follows needs no second pass over the object to measure them.
    let mut kicked_p = DVec3::ZERO;
    let mut kicked_l = DVec3::ZERO;
    let zone_mass: f64 = zone
        .iter()
        .map(|&i| body.particles.mass_kg[i as usize] as f64)
        .sum();
    if zone_mass > 0.0 {
        let mut dv = j * ZONE_SHARE / zone_mass;
        let cap = 2.0 * j.length() / before.mass_kg;
        if dv.length() > cap {
            dv = dv.normalize_or_zero() * cap;
        }
        let dv32 = dv.as_vec3a();
        let dv = dv32.as_dvec3();
        let p = &mut body.particles;
        let mut first_moment = DVec3::ZERO;
        for &i in zone {
            let i = i as usize;
            p.v[i] += dv32;
            first_moment += (p.x[i].as_dvec3() - before.com_m) * p.mass_kg[i] as f64;
        }
        kicked_p = dv * zone_mass;
        kicked_l = first_moment.cross(dv);
    }
    let s = &before;
    let dv = (target_p - s.velocity_m_s * s.mass_kg - kicked_p) / s.mass_kg;
    let dw = inverse_or_zero(s.inertia) * (target_l - s.angular_momentum - kicked_l);
    rigid_field(body, dv, dw, s.com_m);
}

/// Makes the particles' total momentum `target_p` (kg m/s) and angular momentum about `com`
/// `target_l` (kg m²/s) with a uniform velocity and a rigid rotation field.
pub fn enforce(body: &mut Body, target_p: DVec3, target_l: DVec3, com: DVec3) {
    let s = measure(&body.particles, body.solver.dx_m);
    if s.mass_kg <= 0.0 {
        return;
    }
    let dv = (target_p - s.velocity_m_s * s.mass_kg) / s.mass_kg;
    // L about `com` of the current particles (measure() reports it about their own COM, which
    // moved by at most rounding here).
    let l_now = s.angular_momentum + (s.com_m - com).cross(s.velocity_m_s * s.mass_kg);
    let dw = inverse_or_zero(s.inertia) * (target_l - l_now);
    rigid_field(body, dv, dw, s.com_m);
}

/// Adds the uniform velocity `dv` (m/s) and the rigid rotation field of `dw` (rad/s) about `com`
/// (m) to every particle: v += dv + dw × (x − com), C += `[dw]×`. Nothing when either is not
/// finite.
fn rigid_field(body: &mut Body, dv: DVec3, dw: DVec3, com: DVec3) {
    if !(dv.is_finite() && dw.is_finite()) {
        return;
    }
    let (dv, dw) = (dv.as_vec3a(), dw.as_vec3a());
    let skew = Mat3A::from_cols(
        Vec3A::new(0.0, dw.z, -dw.y),
        Vec3A::new(-dw.z, 0.0, dw.x),
        Vec3A::new(dw.y, -dw.x, 0.0),
    );
    let c = com.as_vec3a();
    let p = &mut body.particles;
    for i in 0..p.len() {
        p.v[i] += dv + dw.cross(p.x[i] - c);
        p.c[i] += skew;
    }
}
