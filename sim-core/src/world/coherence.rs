//! Applying a contact impulse to a deformable object and the paper's "COM-based constraint
//! enforcement".
//!
//! A fraction of the impulse goes to the particles of the contact zone (their velocity change is
//! capped at twice the COM's, so a small zone cannot be flung), which MPM then turns into local
//! deformation; the rest is spread evenly. Then the object's particle momentum, linear and
//! angular, is made equal to its object-level value (old momentum + J, old angular momentum +
//! r × J) by adding a uniform velocity and a rigid rotation field (v += δv + δω × r, C += `[δω]×`):
//! rigid fields carry no strain rate, so the internal deformation velocities are undisturbed.
//!
//! Contact impulses ([`apply_contact_impulses`], one per contact patch, applied together) may
//! change the object's rigid-level kinetic energy as the restitution law says, and no more:
//! when the zone kicks raise the kinetic energy of the particles' motion relative to their rigid
//! fit (v − v_com − ω × r, with ω from the orbital angular momentum and inertia, so it carries
//! no momentum or angular momentum), that relative motion is scaled back to the energy it had
//! before. Without it, a kick of J/2 over a zone of mass M_z adds up to ½ |J/2|² / M_z at once
//! (6 % of the kinetic energy in a head-on impact of two jelly spheres at e = 1), which MPM's
//! transfers then mostly dissipate.

use glam::{DVec3, Mat3A, Vec3A};

use super::body::Body;
use super::measure::{BodyState, RigidFit, inverse_or_zero, measure, measure_with_fit};

/// Share of a contact impulse given to the contact zone (the rest spreads over the object).
pub const ZONE_SHARE: f64 = 0.5;

/// One impulse on a deformable object: `impulse_n_s` (N s) at `point_m` (m) plus the couple
/// `couple_n_m_s` (N m s), its zone kick going to the particles `zone`.
#[derive(Debug, Clone, Copy)]
pub struct Kick<'a> {
    /// Impulse (N s).
    pub impulse_n_s: DVec3,
    /// Couple (N m s).
    pub couple_n_m_s: DVec3,
    /// Where the impulse acts (m).
    pub point_m: DVec3,
    /// The particles near that point (indices into the body's particles).
    pub zone: &'a [u32],
}

/// Applies impulse `j` (N s) at `point` (m) and angular impulse `h` (N m s, a couple) to
/// deformable `body`, zone particles `zone`, and updates its largest particle speed.
pub fn apply_impulse(body: &mut Body, j: DVec3, h: DVec3, point: DVec3, zone: &[u32]) {
    let kick = Kick {
        impulse_n_s: j,
        couple_n_m_s: h,
        point_m: point,
        zone,
    };
    let measured = measure_with_fit(&body.particles, body.dx_m());
    apply_kicks(body, &[kick], measured, false);
}

/// [`apply_impulse`] for several contact impulses at once: afterwards the kinetic energy of the
/// particles' motion relative to their rigid fit is no larger than before (see the module docs).
/// Momentum and angular momentum are those of the kicks (the relative motion carries none).
/// Three passes over the particles (two to measure, one for the rigid field) and a fourth only
/// when the energy has to be scaled back, however many kicks.
///
/// `measured` is the body's [`measure_with_fit`] when the caller has it for its particles as they
/// are (saving two of the passes).
pub fn apply_contact_impulses(
    body: &mut Body,
    kicks: &[Kick<'_>],
    measured: Option<(BodyState, RigidFit)>,
) {
    let measured = measured.unwrap_or_else(|| measure_with_fit(&body.particles, body.dx_m()));
    apply_kicks(body, kicks, measured, true);
}

fn apply_kicks(
    body: &mut Body,
    kicks: &[Kick<'_>],
    (before, fit): (BodyState, RigidFit),
    bound_energy: bool,
) {
    if before.mass_kg <= 0.0 {
        return;
    }
    let mut target_p = before.velocity_m_s * before.mass_kg;
    let mut target_l = before.angular_momentum;
    // The zone kicks' own momentum and angular momentum (about the COM), so the rigid field
    // that follows needs no second pass over the object to measure them.
    let mut kicked_p = DVec3::ZERO;
    let mut kicked_l = DVec3::ZERO;
    let mut kicked_zone = false;
    for k in kicks {
        let j = k.impulse_n_s;
        if !(j.is_finite() && k.couple_n_m_s.is_finite() && k.point_m.is_finite()) {
            continue;
        }
        target_p += j;
        target_l += (k.point_m - before.com_m).cross(j) + k.couple_n_m_s;
        let p = &mut body.particles;
        let zone_mass: f64 = k.zone.iter().map(|&i| p.mass_kg[i as usize] as f64).sum();
        if zone_mass <= 0.0 {
            continue;
        }
        let mut dv = j * ZONE_SHARE / zone_mass;
        let cap = 2.0 * j.length() / before.mass_kg;
        if dv.length() > cap {
            dv = dv.normalize_or_zero() * cap;
        }
        let dv32 = dv.as_vec3a();
        let dv = dv32.as_dvec3();
        let mut first_moment = DVec3::ZERO;
        for &i in k.zone {
            let i = i as usize;
            p.v[i] += dv32;
            first_moment += (p.x[i].as_dvec3() - before.com_m) * p.mass_kg[i] as f64;
        }
        kicked_p += dv * zone_mass;
        kicked_l += first_moment.cross(dv);
        kicked_zone = true;
    }
    let s = &before;
    let dv = (target_p - s.velocity_m_s * s.mass_kg - kicked_p) / s.mass_kg;
    let dw = inverse_or_zero(s.inertia) * (target_l - s.angular_momentum - kicked_l);
    let Some(sums) = rigid_field(body, dv, dw, s.com_m) else {
        // Only the zone kicks moved.
        body.max_speed_m_s = body
            .particles
            .v
            .iter()
            .map(|v| v.length())
            .fold(0.0, f32::max);
        return;
    };
    body.max_speed_m_s = sums.max_speed_m_s;
    if !(bound_energy && kicked_zone) {
        // Uniform and rigid fields only: the relative motion is unchanged.
        return;
    }
    let after = fit.with_velocities(sums.mass_kg, sums.momentum, sums.orbital, sums.twice_energy);
    if let Some(max_speed_m_s) = bound_relative_energy(body, &fit, &after) {
        body.max_speed_m_s = max_speed_m_s;
    }
}

/// Scales the particles' motion relative to their rigid fit `after` back to the energy it had
/// in `before` when it has more (a relative 1e-9 is rounding between the two fits' sums), and
/// returns the particles' largest speed then (m/s).
fn bound_relative_energy(body: &mut Body, before: &RigidFit, after: &RigidFit) -> Option<f32> {
    let (e0, e1) = (before.relative_energy_j.max(0.0), after.relative_energy_j);
    if !(e1 > e0 * (1.0 + 1e-9) && e1 > 0.0) {
        return None;
    }
    let alpha = (e0 / e1).sqrt() as f32;
    let (com, v_com, omega) = (
        after.com_m.as_vec3a(),
        after.velocity_m_s.as_vec3a(),
        after.omega_rad_s.as_vec3a(),
    );
    if !(com.is_finite() && v_com.is_finite() && omega.is_finite()) {
        return None;
    }
    let p = &mut body.particles;
    let mut max_speed2 = 0.0f32;
    for i in 0..p.len() {
        let rigid = v_com + omega.cross(p.x[i] - com);
        p.v[i] = rigid + (p.v[i] - rigid) * alpha;
        max_speed2 = max_speed2.max(p.v[i].length_squared());
    }
    Some(max_speed2.sqrt())
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

/// Adds the rigid rotation field of `dw` (rad/s) about `com` (m) to `body`'s particles
/// (v += dw × (x − com), C += `[dw]×`) and updates its largest particle speed.
pub fn spin(body: &mut Body, dw: DVec3, com: DVec3) {
    if let Some(sums) = rigid_field(body, DVec3::ZERO, dw, com) {
        body.max_speed_m_s = sums.max_speed_m_s;
    }
}

/// Velocity sums over every particle after a [`rigid_field`], about the COM it was given.
struct VelocitySums {
    mass_kg: f64,
    /// Σ m v (kg m/s).
    momentum: DVec3,
    /// Σ m (x − com) × v (kg m²/s).
    orbital: DVec3,
    /// Σ m |v|² (2 J).
    twice_energy: f64,
    /// max |v| (m/s).
    max_speed_m_s: f32,
}

/// Adds the uniform velocity `dv` (m/s) and the rigid rotation field of `dw` (rad/s) about `com`
/// (m) to every particle: v += dv + dw × (x − com), C += `[dw]×`, and sums the new velocities
/// (the caller updates the body's largest speed from them). Nothing, and `None`, when either is
/// not finite.
fn rigid_field(body: &mut Body, dv: DVec3, dw: DVec3, com: DVec3) -> Option<VelocitySums> {
    if !(dv.is_finite() && dw.is_finite()) {
        return None;
    }
    let (dv, dw) = (dv.as_vec3a(), dw.as_vec3a());
    let skew = Mat3A::from_cols(
        Vec3A::new(0.0, dw.z, -dw.y),
        Vec3A::new(-dw.z, 0.0, dw.x),
        Vec3A::new(dw.y, -dw.x, 0.0),
    );
    let c = com.as_vec3a();
    let p = &mut body.particles;
    let mut sums = VelocitySums {
        mass_kg: 0.0,
        momentum: DVec3::ZERO,
        orbital: DVec3::ZERO,
        twice_energy: 0.0,
        max_speed_m_s: 0.0,
    };
    let mut max_speed2 = 0.0f32;
    for i in 0..p.len() {
        p.v[i] += dv + dw.cross(p.x[i] - c);
        p.c[i] += skew;
        let (mi, v) = (p.mass_kg[i] as f64, p.v[i].as_dvec3());
        sums.mass_kg += mi;
        sums.momentum += v * mi;
        sums.orbital += (p.x[i].as_dvec3() - com).cross(v) * mi;
        sums.twice_energy += mi * v.length_squared();
        max_speed2 = max_speed2.max(p.v[i].length_squared());
    }
    sums.max_speed_m_s = max_speed2.sqrt();
    Some(sums)
}
