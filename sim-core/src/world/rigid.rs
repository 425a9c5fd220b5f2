//! Rigid objects skip MPM: semi-implicit Euler on the COM; rotation keeps the angular momentum
//! L = I(R) ω rather than ω, so between impulses ω = I(R)⁻¹ L follows the orientation and an
//! asymmetric body precesses and tumbles (the intermediate-axis instability). The orientation
//! advances by the exponential map at the midpoint angular velocity (R_½ = exp(ω dt/2) R,
//! ω_½ = I(R_½)⁻¹ L, R' = exp(ω_½ dt) R): second order, |L| exact. Contacts with the grid
//! colliders are resolved with the same impulse law as object contacts (the collider is immovable) plus a positional push-out along
//! the contact normal. Sticky surfaces stop all tangential sliding; slip and separate ones use
//! Coulomb friction with the larger of the surface's and the object's coefficient.
//!
//! Collider contact is a manifold: every penetrating particle (the deepest [`MAX_CONTACTS`]) is a
//! contact point, solved point by point with accumulated, clamped impulses for up to
//! [`ITERATIONS`] passes (sequential impulses, Gauss-Seidel, as in Catto's Box2D solver; the same
//! restitution, resting threshold and friction as the object impulse law). One impulse at the
//! averaged point would leave a box on a jittered lattice rocking between its lowest particles.

use glam::{DMat3, DQuat, DVec3};

use super::body::{Body, inverse_or_zero};
use crate::collider::{Collider, Surface};

/// Most contact points per collider and substep.
pub const MAX_CONTACTS: usize = 128;
/// Most sequential-impulse passes over a manifold.
pub const ITERATIONS: usize = 10;

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
    // Free rotation keeps L = I(R) ω, not ω (module docs).
    let i0 = rs.inertia_rest;
    let q = rs.orientation.as_dquat();
    let l = world_inertia(q, i0) * rs.omega_rad_s;
    let omega_at = |q: DQuat| inverse_or_zero(world_inertia(q, i0)) * l;
    let half = (DQuat::from_scaled_axis(rs.omega_rad_s * (0.5 * dt_s)) * q).normalize();
    let q1 = (DQuat::from_scaled_axis(omega_at(half) * dt_s) * q).normalize();
    rs.orientation = q1.as_quat();
    // A degenerate inertia (a line of particles) has no inverse: ω stays.
    if inverse_or_zero(i0) != DMat3::ZERO {
        rs.omega_rad_s = omega_at(q1);
    }
    body.sync_rigid_particles();
    let mut touched = 0;
    let resting = 2.0 * gravity.length() * dt_s;
    let mut points: Vec<(f32, usize, DVec3, DVec3)> = Vec::new();
    for collider in colliders {
        points.clear();
        let mut n_sum = DVec3::ZERO;
        let mut depth = 0.0f64;
        for (i, (x, &mi)) in body
            .particles
            .x
            .iter()
            .zip(&body.particles.mass_kg)
            .enumerate()
        {
            if let Some((normal, d)) = collider.penetration(*x, time_s) {
                points.push((d, i, x.as_dvec3(), normal.as_dvec3()));
                n_sum += normal.as_dvec3() * mi as f64;
                depth = depth.max(d as f64);
            }
        }
        let Some(n_push) = n_sum.try_normalize() else {
            continue;
        };
        touched += 1;
        if points.len() > MAX_CONTACTS {
            // Deepest first, index breaks ties: the same set for any thread count.
            points.select_nth_unstable_by(MAX_CONTACTS, |a, b| {
                b.0.total_cmp(&a.0).then(a.1.cmp(&b.1))
            });
            points.truncate(MAX_CONTACTS);
            points.sort_unstable_by_key(|p| p.1);
        }
        let inverse_inertia = inverse_or_zero(body.rigid_world_inertia());
        let wall_velocity = collider.velocity_at(time_s).as_dvec3();
        let mu = match collider.surface {
            Surface::Sticky => f64::INFINITY,
            _ => collider.friction.max(body.friction) as f64,
        };
        solve_manifold(
            body,
            &points,
            wall_velocity,
            inverse_inertia,
            body.restitution as f64,
            mu,
            resting,
        );
        body.rigid.com_m += n_push * depth;
        body.sync_rigid_particles();
    }
    touched
}

/// The world inertia R I0 Rᵀ of rest inertia `i0` at orientation `q`.
fn world_inertia(q: DQuat, i0: DMat3) -> DMat3 {
    let r = DMat3::from_quat(q);
    r * i0 * r.transpose()
}

/// One contact point of a manifold with its accumulated impulses (N·s).
struct ManifoldPoint {
    r: DVec3,
    n: DVec3,
    t: [DVec3; 2],
    k_n: f64,
    k_t: [f64; 2],
    target_vn: f64,
    p_n: f64,
    p_t: [f64; 2],
}

/// Sequential impulses with accumulated clamping (Catto, "Iterative dynamics with temporal
/// coherence", GDC 2005): per point the normal impulse stays >= 0 and drives the normal velocity
/// to its target (−e·vn for an impact, 0 for resting contact below `resting` m/s), friction
/// stays within μ times it (unbounded for μ = ∞, a sticky surface).
fn solve_manifold(
    body: &mut Body,
    points: &[(f32, usize, DVec3, DVec3)],
    wall_velocity: DVec3,
    inverse_inertia: DMat3,
    e: f64,
    mu: f64,
    resting: f64,
) {
    let rs = &mut body.rigid;
    let inv_m = 1.0 / rs.mass_kg;
    let k = |r: DVec3, d: DVec3| inv_m + d.dot((inverse_inertia * r.cross(d)).cross(r));
    let rel = |rs: &super::body::RigidState, r: DVec3| {
        rs.velocity_m_s + rs.omega_rad_s.cross(r) - wall_velocity
    };
    let mut manifold: Vec<ManifoldPoint> = points
        .iter()
        .filter_map(|&(_, _, x, n)| {
            let r = x - rs.com_m;
            let vn = rel(rs, r).dot(n);
            let (t0, t1) = n.any_orthonormal_pair();
            let k_n = k(r, n);
            (k_n > 0.0 && k_n.is_finite()).then(|| ManifoldPoint {
                r,
                n,
                t: [t0, t1],
                k_n,
                k_t: [k(r, t0), k(r, t1)],
                target_vn: if -vn > resting { -e * vn } else { 0.0 },
                p_n: 0.0,
                p_t: [0.0; 2],
            })
        })
        .collect();
    for _ in 0..ITERATIONS {
        let mut change = 0.0f64;
        for c in &mut manifold {
            let vn = rel(rs, c.r).dot(c.n);
            let p_n = (c.p_n + (c.target_vn - vn) / c.k_n).max(0.0);
            let mut j = c.n * (p_n - c.p_n);
            change = change.max((p_n - c.p_n).abs());
            c.p_n = p_n;
            rs.velocity_m_s += j * inv_m;
            rs.omega_rad_s += inverse_inertia * c.r.cross(j);
            for a in 0..2 {
                if c.k_t[a] <= 0.0 {
                    continue;
                }
                let vt = rel(rs, c.r).dot(c.t[a]);
                // A point that does not press has no friction, even on a sticky surface.
                let limit = if c.p_n > 0.0 { mu * c.p_n } else { 0.0 };
                let p_t = (c.p_t[a] - vt / c.k_t[a]).clamp(-limit, limit);
                j = c.t[a] * (p_t - c.p_t[a]);
                change = change.max((p_t - c.p_t[a]).abs());
                c.p_t[a] = p_t;
                rs.velocity_m_s += j * inv_m;
                rs.omega_rad_s += inverse_inertia * c.r.cross(j);
            }
        }
        if change == 0.0 {
            break;
        }
    }
}
