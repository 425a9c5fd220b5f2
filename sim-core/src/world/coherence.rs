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
//! A contact impulse ([`apply_contact_impulse`]) may change the object's rigid-level kinetic
//! energy as the restitution law says, and no more: when the zone kick raises the kinetic energy
//! of the particles' motion relative to their rigid fit (v − v_com − ω × r, with ω from the
//! orbital angular momentum and inertia, so it carries no momentum or angular momentum), that
//! relative motion is scaled back to the energy it had before. Without it, a kick of J/2 over a
//! zone of mass M_z adds up to ½ |J/2|² / M_z at once (6 % of the kinetic energy in a head-on
//! impact of two jelly spheres at e = 1), which MPM's transfers then mostly dissipate.

use glam::{DVec3, Mat3A, Vec3A};

use super::body::{Body, inertia_from_second_moments, inverse_or_zero, measure};

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

/// [`apply_impulse`] for a contact: afterwards the kinetic energy of the particles' motion
/// relative to their rigid fit is no larger than before (see the module docs). Momentum and
/// angular momentum are those of [`apply_impulse`] (the relative motion carries none).
pub fn apply_contact_impulse(body: &mut Body, j: DVec3, h: DVec3, point: DVec3, zone: &[u32]) {
    if zone.is_empty() {
        // Uniform and rigid fields only: the relative motion is unchanged.
        apply_impulse(body, j, h, point, zone);
        return;
    }
    let before = RigidFit::of(&body.particles);
    apply_impulse(body, j, h, point, zone);
    let after = RigidFit::of(&body.particles);
    if !(after.relative_energy_j > before.relative_energy_j && after.relative_energy_j > 0.0) {
        return;
    }
    let alpha = (before.relative_energy_j.max(0.0) / after.relative_energy_j).sqrt() as f32;
    let (com, v_com, omega) = (
        after.com_m.as_vec3a(),
        after.velocity_m_s.as_vec3a(),
        after.omega_rad_s.as_vec3a(),
    );
    if !(com.is_finite() && v_com.is_finite() && omega.is_finite()) {
        return;
    }
    let p = &mut body.particles;
    for i in 0..p.len() {
        let rigid = v_com + omega.cross(p.x[i] - com);
        p.v[i] = rigid + (p.v[i] - rigid) * alpha;
    }
}

/// The particles' rigid fit: COM, COM velocity and ω = I⁻¹ L from the orbital angular momentum
/// and inertia (Σ m r × v, Σ m (|r|² 1 − r rᵀ); no APIC spin), and the kinetic energy of the
/// motion relative to it, ½ Σ m |v|² − ½ M |v_com|² − ½ ω · L (J).
struct RigidFit {
    com_m: DVec3,
    velocity_m_s: DVec3,
    omega_rad_s: DVec3,
    relative_energy_j: f64,
}

impl RigidFit {
    fn of(p: &crate::mpm::Particles) -> Self {
        let (mut m, mut mx, mut mv) = (0.0f64, DVec3::ZERO, DVec3::ZERO);
        for i in 0..p.len() {
            let mi = p.mass_kg[i] as f64;
            m += mi;
            mx += p.x[i].as_dvec3() * mi;
            mv += p.v[i].as_dvec3() * mi;
        }
        if m <= 0.0 {
            return Self {
                com_m: DVec3::ZERO,
                velocity_m_s: DVec3::ZERO,
                omega_rad_s: DVec3::ZERO,
                relative_energy_j: 0.0,
            };
        }
        let (com, vel) = (mx / m, mv / m);
        let (mut l, mut diag, mut off, mut energy) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO, 0.0);
        for i in 0..p.len() {
            let mi = p.mass_kg[i] as f64;
            let r = p.x[i].as_dvec3() - com;
            let v = p.v[i].as_dvec3() - vel;
            l += r.cross(v) * mi;
            let mr = r * mi;
            diag += mr * r;
            off += DVec3::new(mr.x * r.y, mr.x * r.z, mr.y * r.z);
            energy += 0.5 * mi * v.length_squared();
        }
        let omega = inverse_or_zero(inertia_from_second_moments(diag, off, 0.0)) * l;
        Self {
            com_m: com,
            velocity_m_s: vel,
            omega_rad_s: omega,
            relative_energy_j: energy - 0.5 * omega.dot(l),
        }
    }
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
