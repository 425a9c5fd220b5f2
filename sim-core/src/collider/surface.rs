//! Surface rules for grid boundary nodes, with Coulomb friction (Stomakhin et al. 2013, section
//! 8; Hu et al. 2018's "separate" boundary).
//!
//! With v the node velocity relative to the collider and n its outward normal, vn = v·n:
//! - sticky: separate with friction [`STICKY_FRICTION`] (or the surface's own μ where that is
//!   larger): material pressed into the surface does not slip unless pulled along it harder than
//!   ten times what presses it in, and it may leave (no adhesion). The same law the rigid contact
//!   solver gives a sticky surface, so a sticky floor means one thing to every object;
//! - clamp: v = 0, no slip and no separation however the material is pulled (glue: a clamped
//!   bar's end, a fixture); an unbounded constraint, so meant for holding material in place;
//! - slip: the normal component is removed both ways (v ← v - vn n);
//! - separate: only an approaching normal component is removed (vn < 0), so material can leave.
//!
//! Coulomb friction acts on the tangential part vt when the node is pressed into the surface
//! (vn < 0): vt ← vt · max(0, 1 - μ |vn| / |vt|). Only the approaching normal velocity counts:
//! removing an outgoing vn (slip) is a constraint impulse the surface pulls with, and charging
//! friction for it over-brakes sliding (measured: a block stopped 36 % short of v0²/(2μg)).

use glam::Vec3A;

/// The friction μ of a sticky surface (f32 form of [`crate::contact::STICKY_FRICTION`]).
pub const STICKY_FRICTION: f32 = crate::contact::STICKY_FRICTION as f32;

/// How a surface treats grid velocity at its boundary nodes (PhysGaussian's boundary
/// conditions, module docs); in a scene file `"sticky"`, `"clamp"`, `"slip"` or `"separate"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Surface {
    /// No slip while pressed, up to [`STICKY_FRICTION`] times the normal impulse; free to leave.
    #[default]
    Sticky,
    /// Remove the normal component both ways.
    Slip,
    /// Remove only an approaching normal component.
    Separate,
    /// Zero velocity relative to the surface: no slip and no separation.
    Clamp,
}

impl Surface {
    /// The friction μ the rule applies for a surface of friction `mu`: sticky grips with at
    /// least [`STICKY_FRICTION`].
    #[inline]
    pub fn friction(self, mu: f32) -> f32 {
        match self {
            Self::Sticky => mu.max(STICKY_FRICTION),
            _ => mu,
        }
    }
}

/// Applies `surface` with friction coefficient `mu` to relative velocity `v` at outward normal `n`.
#[inline]
pub fn apply_surface(v: Vec3A, n: Vec3A, surface: Surface, mu: f32) -> Vec3A {
    let vn = v.dot(n);
    match surface {
        Surface::Clamp => Vec3A::ZERO,
        Surface::Slip => friction(v - vn * n, (-vn).max(0.0), mu),
        Surface::Separate | Surface::Sticky => {
            if vn < 0.0 {
                friction(v - vn * n, -vn, surface.friction(mu))
            } else {
                v
            }
        }
    }
}

/// Coulomb friction on tangential velocity `vt` for an approaching normal speed `pressed` >= 0.
#[inline]
fn friction(vt: Vec3A, pressed: f32, mu: f32) -> Vec3A {
    if mu <= 0.0 || pressed <= 0.0 {
        return vt;
    }
    let speed = vt.length();
    if speed <= mu * pressed {
        Vec3A::ZERO
    } else {
        vt * (1.0 - mu * pressed / speed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slip_plane_keeps_tangential_velocity() {
        let v = apply_surface(Vec3A::new(2.0, 0.0, -1.0), Vec3A::Z, Surface::Slip, 0.0);
        assert_eq!(v, Vec3A::new(2.0, 0.0, 0.0));
        let v = apply_surface(Vec3A::new(2.0, 0.0, 1.0), Vec3A::Z, Surface::Slip, 0.0);
        assert_eq!(v, Vec3A::new(2.0, 0.0, 0.0));
    }

    #[test]
    fn separate_lets_material_leave() {
        let v = apply_surface(Vec3A::new(2.0, 0.0, 1.0), Vec3A::Z, Surface::Separate, 0.5);
        assert_eq!(v, Vec3A::new(2.0, 0.0, 1.0));
    }

    #[test]
    fn coulomb_friction_removes_mu_times_normal_speed() {
        let v = apply_surface(Vec3A::new(2.0, 0.0, -1.0), Vec3A::Z, Surface::Separate, 0.5);
        assert!((v - Vec3A::new(1.5, 0.0, 0.0)).length() < 1e-6);
        let v = apply_surface(Vec3A::new(0.2, 0.0, -1.0), Vec3A::Z, Surface::Separate, 0.5);
        assert_eq!(v, Vec3A::ZERO);
    }

    #[test]
    fn a_clamp_stops_everything() {
        assert_eq!(
            apply_surface(Vec3A::ONE, Vec3A::Z, Surface::Clamp, 0.0),
            Vec3A::ZERO
        );
        assert_eq!(
            apply_surface(-Vec3A::ONE, Vec3A::Z, Surface::Clamp, 0.0),
            Vec3A::ZERO
        );
    }

    #[test]
    fn sticky_grips_up_to_ten_times_the_normal_impulse_and_lets_go() {
        // Pressed in at 0.1 m/s: up to 1 m/s of slip is stopped, beyond it 1 m/s is taken off.
        let v = apply_surface(Vec3A::new(0.9, 0.0, -0.1), Vec3A::Z, Surface::Sticky, 0.0);
        assert_eq!(v, Vec3A::ZERO);
        let v = apply_surface(Vec3A::new(3.0, 0.0, -0.1), Vec3A::Z, Surface::Sticky, 0.0);
        assert!((v - Vec3A::new(2.0, 0.0, 0.0)).length() < 1e-6, "{v}");
        // Leaving: no adhesion, nothing held.
        let v = apply_surface(Vec3A::new(3.0, 0.0, 0.1), Vec3A::Z, Surface::Sticky, 0.0);
        assert_eq!(v, Vec3A::new(3.0, 0.0, 0.1));
        // A surface whose own μ is larger keeps it.
        let v = apply_surface(Vec3A::new(3.0, 0.0, -0.1), Vec3A::Z, Surface::Sticky, 30.0);
        assert_eq!(v, Vec3A::ZERO);
    }
}
