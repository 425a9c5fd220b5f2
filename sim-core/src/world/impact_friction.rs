//! Coulomb's bound on the friction of a deformable object's impact against a solid: the
//! friction part of the restitution law (`impact.rs`).
//!
//! The grid's friction at each node is bounded by μ times that node's normal impulse, but over an
//! impact the grid's normal impulse includes the nearly elastic rebound that the restitution
//! law then removes: friction acted on about 2 a of normal impulse per unit mass where the
//! impact keeps (1 + e) a, so an oblique impact lost up to twice the sliding speed Coulomb's
//! law allows (a jelly cube thrown at (1, 0, −1) m/s onto a plane with μ = 0.3 and e = 0 left at
//! 0.46 m/s; a rigid one leaves at 0.7). When the law acts, the friction impulse the object
//! received over the contact, across the contact normal n, is held to μ times the normal
//! impulse it keeps, |J_t| ≤ μ J_n (Coulomb's law for impulses: Stronge 2000, "Impact
//! Mechanics"). The excess goes back at the contact point along the sliding
//! direction, so the object's spin and a movable solid's motion follow as from a rigid contact
//! impulse, and never so much that
//! - the object's COM slides faster relative to the solid's contact point than at first touch
//!   (friction only ever slowed the sliding down), or
//! - the law as a whole gives energy: the kinetic energy the given-back impulse adds is at most
//!   what the normal part removed.

use glam::{DMat3, DVec3};

/// One body's side of the contact: what an impulse at `arm_m` from its COM does to it. An
/// immovable solid has zero inverse mass and inertia.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Side {
    /// 1/m (1/kg).
    pub(super) inverse_mass: f64,
    /// World-frame I⁻¹ about the COM (1/(kg m²)).
    pub(super) inverse_inertia: DMat3,
    /// COM velocity (m/s).
    pub(super) velocity_m_s: DVec3,
    /// Angular velocity (rad/s).
    pub(super) omega_rad_s: DVec3,
    /// The contact point's offset from the COM (m).
    pub(super) arm_m: DVec3,
}

impl Side {
    /// The velocity of the contact point (m/s): v + ω × r.
    pub(super) fn point_velocity(&self) -> DVec3 {
        self.velocity_m_s + self.omega_rad_s.cross(self.arm_m)
    }

    /// The contact point's velocity change along unit `d` per unit impulse along `d` there
    /// (1/kg): 1/m + (r × d)·I⁻¹(r × d).
    pub(super) fn inverse_mass_along(&self, d: DVec3) -> f64 {
        let arm = self.arm_m.cross(d);
        self.inverse_mass + arm.dot(self.inverse_inertia * arm)
    }
}

/// The friction impulse the law gives back to the object (N s; the solid takes its opposite at
/// the contact point): of the grid's friction impulse `friction_n_s` over the contact, the part
/// across unit contact normal `normal` beyond `mu` times the normal impulse the object keeps,
/// `kept_n_s` (N s), along the sliding direction, capped as the module docs say.
/// `touch_velocity_m_s` is the object's COM velocity relative to the solid's contact point at
/// first touch, `object` and `solid` are the two after the law's normal part, and
/// `energy_room_j` (J) the kinetic energy that part removed. Zero where nothing is owed, or where
/// `mu` is infinite (a clamp).
pub(super) fn give_back(
    (friction_n_s, normal): (DVec3, DVec3),
    kept_n_s: f64,
    mu: f64,
    (object, solid): (&Side, &Side),
    touch_velocity_m_s: DVec3,
    energy_room_j: f64,
) -> DVec3 {
    let across = friction_n_s - normal * normal.dot(friction_n_s);
    let Some(slide) = (-across).try_normalize() else {
        return DVec3::ZERO;
    };
    let owed = across.length() - mu * kept_n_s.max(0.0);
    if owed.is_nan() || owed <= 0.0 {
        return DVec3::ZERO;
    }
    // No faster than it came: the object's COM against the solid's contact point.
    let u_com = (object.velocity_m_s - solid.point_velocity()).dot(slide);
    let k_com = object.inverse_mass + solid.inverse_mass_along(slide);
    let room = (touch_velocity_m_s.dot(slide) - u_com).max(0.0) / k_com;
    // No energy gained: P u + P² k / 2 ≤ the normal part's removal, at the contact point.
    let u = (object.point_velocity() - solid.point_velocity()).dot(slide);
    let k = object.inverse_mass_along(slide) + solid.inverse_mass_along(slide);
    let energy = (-u + (u * u + 2.0 * k * energy_room_j.max(0.0)).sqrt()) / k;
    let p = owed.min(room).min(energy);
    if p > 0.0 && p.is_finite() {
        slide * p
    } else {
        DVec3::ZERO
    }
}

/// `side` after impulse `j_n_s` (N s) at its contact point.
pub(super) fn after(side: &Side, j_n_s: DVec3) -> Side {
    Side {
        velocity_m_s: side.velocity_m_s + j_n_s * side.inverse_mass,
        omega_rad_s: side.omega_rad_s + side.inverse_inertia * side.arm_m.cross(j_n_s),
        ..*side
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What goes back to a 1 kg point-like object sliding along +x at 0.4 m/s on an immovable
    /// floor (normal +z) after a friction impulse of `friction_x` N s along x and a kept normal
    /// impulse of 1 N s, at friction `mu`, having touched at (`touch_x`, 0, −1) m/s, with
    /// `room_j` J of energy removed by the normal part.
    fn given_back(friction_x: f64, mu: f64, touch_x: f64, room_j: f64) -> DVec3 {
        let side = |inverse_mass: f64, v: f64| Side {
            inverse_mass,
            inverse_inertia: DMat3::ZERO,
            velocity_m_s: DVec3::new(v, 0.0, 0.0),
            omega_rad_s: DVec3::ZERO,
            arm_m: DVec3::ZERO,
        };
        give_back(
            (DVec3::new(friction_x, 0.0, 0.0), DVec3::Z),
            1.0,
            mu,
            (&side(1.0, 0.4), &side(0.0, 0.0)),
            DVec3::new(touch_x, 0.0, -1.0),
            room_j,
        )
    }

    #[test]
    fn friction_beyond_mu_times_the_kept_normal_impulse_goes_back() {
        // Came at (1, 0, −1), left sliding at 0.4 after a friction impulse of 0.6 N s: μ = 0.3
        // allows 0.3, so 0.3 goes back along +x.
        let j = given_back(-0.6, 0.3, 1.0, 10.0);
        assert!((j - DVec3::new(0.3, 0.0, 0.0)).length() < 1e-12, "{j}");
        // Within Coulomb's bound nothing goes back, nor for a clamp.
        assert_eq!(given_back(-0.2, 0.3, 1.0, 10.0), DVec3::ZERO);
        assert_eq!(given_back(-0.6, f64::INFINITY, 1.0, 10.0), DVec3::ZERO);
    }

    #[test]
    fn it_never_slides_faster_than_it_came_nor_gains_energy() {
        // The touch slid at 0.5: from 0.4, at most 0.1 goes back, whatever μ allows.
        let j = given_back(-0.6, 0.0, 0.5, 10.0);
        assert!((j.x - 0.1).abs() < 1e-12, "{j}");
        // With 0.05 J of room: 0.4 P + P² / 2 = 0.05, P = 0.1099.
        let j = given_back(-0.6, 0.0, 1.0, 0.05);
        let gained = 0.5 * ((0.4 + j.x).powi(2) - 0.4f64.powi(2));
        assert!((gained - 0.05).abs() < 1e-12, "{j} {gained}");
    }

    #[test]
    fn an_impulse_off_the_com_turns_the_body() {
        // A 1 kg body of inertia 0.1 kg m² about every axis, pushed along +x 0.1 m below its
        // COM, turns about −y: r × j = (0, 0, −0.1) × (1, 0, 0) = (0, −0.1, 0).
        let body = Side {
            inverse_mass: 1.0,
            inverse_inertia: DMat3::from_diagonal(DVec3::splat(10.0)),
            velocity_m_s: DVec3::ZERO,
            omega_rad_s: DVec3::ZERO,
            arm_m: DVec3::new(0.0, 0.0, -0.1),
        };
        let moved = after(&body, DVec3::X);
        assert_eq!(moved.velocity_m_s, DVec3::X);
        assert!((moved.omega_rad_s - DVec3::new(0.0, -1.0, 0.0)).length() < 1e-12);
        // Its point's velocity change per unit impulse: 1/m + r_z² / I = 1 + 0.01 · 10.
        assert!((body.inverse_mass_along(DVec3::X) - 1.1).abs() < 1e-12);
        assert!((moved.point_velocity() - DVec3::new(1.1, 0.0, 0.0)).length() < 1e-12);
    }
}
