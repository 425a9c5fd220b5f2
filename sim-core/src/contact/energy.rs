//! The energy a contact solve may add, which [`super::solver::solve`] checks: the kinetic
//! energy of the movable bodies over the step and the work of the driven ones.

use glam::DVec3;

use super::patch::ContactPatch;
use super::rows::{ContactPoint, SolverBody};

/// How much kinetic energy a solve may add, as a fraction, before [`super::solver::solve`]
/// takes it for a gain: a bounce at e = 1 keeps it only to round-off and the iterations'
/// tolerance.
pub(super) const ENERGY_TOLERANCE: f64 = 1e-3;

/// How much of ½ m |Δv_ext|² a solve may add beyond it ([`step_energy_j`]) before
/// [`super::solver::solve`] takes it for a gain: the iterations leave a slowly converging
/// stack a little more (a settled 10-box stack up to 1.8 % of it, 27 % in its first substeps).
pub(super) const EXTERNAL_TOLERANCE: f64 = 0.5;

/// The work (J) the driven bodies (immovable and moving: kinematic objects, moving colliders)
/// did on the others through a solve's impulses: each impulse on a driven body, reversed, dotted
/// with that body's velocity where it acts (normal impulses at their points, a patch's
/// tangential impulse at its anchor, its torsional and rolling impulses with the body's spin).
/// Zero where nothing is driven.
pub(super) fn drive_work_j(
    bodies: &[SolverBody],
    contacts: &[ContactPoint],
    patches: &[ContactPatch],
) -> f64 {
    let driven = |k: usize| {
        let b = &bodies[k];
        b.is_immovable() && (b.velocity_m_s != DVec3::ZERO || b.omega_rad_s != DVec3::ZERO)
    };
    // The work body k does when it receives `linear` at `point` and `angular`: −P · v(point).
    let work = |k: usize, linear: DVec3, point: DVec3, angular: DVec3| {
        let b = &bodies[k];
        -(linear.dot(b.velocity_at(point - b.com_m)) + angular.dot(b.omega_rad_s))
    };
    let mut total = 0.0;
    for c in contacts {
        let on_b = c.normal * c.normal_impulse;
        if driven(c.b) {
            total += work(c.b, on_b, c.point_m, DVec3::ZERO);
        }
        if driven(c.a) {
            total += work(c.a, -on_b, c.point_m, DVec3::ZERO);
        }
    }
    for p in patches {
        let angular = p.normal * p.twist_impulse + p.rolling_impulse;
        if driven(p.b) {
            total += work(p.b, p.tangent_impulse, p.anchor_m, angular);
        }
        if driven(p.a) {
            total += work(p.a, -p.tangent_impulse, p.anchor_m, -angular);
        }
    }
    total
}

/// The kinetic energy (J) of the movable bodies with the substep's external velocity change
/// taken out of their velocities: ½ m |v − Δv_ext|² + ½ ω·I ω.
///
/// A substep adds Δv_ext (gravity), solves contact and then moves the bodies with the solved
/// velocities, so it changes ½ m v² + m g z by K(v_after − Δv_ext) − K(v_before − Δv_ext)
/// − ½ m |Δv_ext|² (`external_energy_j`), not by K(v_after) − K(v_before): an exact solve with
/// zero targets changes it by −½ |Δv + Δv_ext|² in the mass metric (Δv the contact's), never
/// up, while K(v_after) ≤ K(v_before) still lets a solve that turns a body upwards by Δv_z add
/// m g dt Δv_z.
pub(super) fn step_energy_j(bodies: &[SolverBody]) -> f64 {
    bodies
        .iter()
        .filter(|b| b.inverse_mass > 0.0)
        .map(|b| body_kinetic_j(b, b.velocity_m_s - b.external_m_s))
        .sum()
}

/// ½ m |Δv_ext|² of the movable bodies (J): see [`step_energy_j`].
pub(super) fn external_energy_j(bodies: &[SolverBody]) -> f64 {
    bodies
        .iter()
        .filter(|b| b.inverse_mass > 0.0)
        .map(|b| 0.5 * b.external_m_s.length_squared() / b.inverse_mass)
        .sum()
}

/// Kinetic energy of the movable bodies (J): ½ m v² + ½ ω·I ω (the solver tests compare it).
#[cfg(test)]
pub(super) fn kinetic_energy_j(bodies: &[SolverBody]) -> f64 {
    bodies
        .iter()
        .filter(|b| b.inverse_mass > 0.0)
        .map(|b| body_kinetic_j(b, b.velocity_m_s))
        .sum()
}

/// ½ m |v|² + ½ ω·I ω of movable body `b` moving at `v` (J).
fn body_kinetic_j(b: &SolverBody, v: DVec3) -> f64 {
    let spin = if b.inverse_inertia.determinant() > 0.0 {
        b.omega_rad_s
            .dot(b.inverse_inertia.inverse() * b.omega_rad_s)
    } else {
        0.0
    };
    0.5 * (v.length_squared() / b.inverse_mass + spin)
}
