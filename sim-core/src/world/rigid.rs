//! Rigid objects skip MPM and integrate as rigid bodies, semi-implicit Euler in the order of
//! Box2D and rapier: velocities first (gravity, the reaction of deformable objects' grids), then
//! the contact solver ([`crate::contact::solver`]), then positions with the solved velocities
//! plus the solver's push-out pseudo-velocities.
//!
//! Rotation keeps the angular momentum L = I(R) ω, not ω: between impulses L is constant in the
//! world frame and ω = I(R)⁻¹ L follows the orientation, so an asymmetric body precesses and
//! tumbles (the intermediate-axis instability) instead of spinning about a fixed axis. The
//! orientation advances by the exponential map at the midpoint angular velocity (R_½ = exp(ω dt/2)
//! R, ω_½ = I(R_½)⁻¹ L, R' = exp(ω_½ dt) R), second order, with |L| exact.

use glam::{DMat3, DQuat, DVec3};

use super::body::Body;
use super::measure::inverse_or_zero;

/// The world inertia R I0 Rᵀ of rest inertia `i0` at orientation `q`.
fn world_inertia(q: DQuat, i0: DMat3) -> DMat3 {
    let r = DMat3::from_quat(q);
    r * i0 * r.transpose()
}

/// Velocity half of a rigid step: gravity `gravity` (m/s²) over `dt_s`, plus an impulse
/// (N s) and an angular impulse about the COM (N m s).
pub fn integrate_velocity(
    body: &mut Body,
    gravity: DVec3,
    dt_s: f64,
    impulse_n_s: DVec3,
    angular_impulse_n_m_s: DVec3,
) {
    let inv_i = inverse_or_zero(body.rigid_world_inertia());
    let rs = &mut body.rigid;
    rs.velocity_m_s += gravity * dt_s + impulse_n_s / rs.mass_kg.max(f64::MIN_POSITIVE);
    rs.omega_rad_s += inv_i * angular_impulse_n_m_s;
}

/// Position half of a rigid step over `dt_s`: the COM moves with v + `push_m_s`, the orientation
/// with ω + `push_rad_s` keeping L (module docs). Only the pose moves: the Gaussians are placed
/// from it when a frame is published.
pub fn integrate_position(body: &mut Body, dt_s: f64, push_m_s: DVec3, push_rad_s: DVec3) {
    let rs = &mut body.rigid;
    rs.com_m += (rs.velocity_m_s + push_m_s) * dt_s;
    let i0 = rs.inertia_rest;
    let q = rs.orientation.as_dquat();
    let l = world_inertia(q, i0) * rs.omega_rad_s;
    let omega_at = |q: DQuat| inverse_or_zero(world_inertia(q, i0)) * l;
    let half =
        (DQuat::from_scaled_axis((rs.omega_rad_s + push_rad_s) * (0.5 * dt_s)) * q).normalize();
    let w_half = omega_at(half) + push_rad_s;
    let q1 = (DQuat::from_scaled_axis(w_half * dt_s) * q).normalize();
    rs.orientation = q1.as_quat();
    // A degenerate inertia (a line of particles) has no I⁻¹: keep ω.
    if inverse_or_zero(i0) != DMat3::ZERO {
        rs.omega_rad_s = omega_at(q1);
    }
    body.max_speed_m_s = body.rigid_speed_m_s();
}
