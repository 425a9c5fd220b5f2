//! Surface rules for grid boundary nodes, with Coulomb friction (Stomakhin et al. 2013, section
//! 8; Hu et al. 2018's "separate" boundary).
//!
//! With v the node velocity relative to the collider and n its outward normal, vn = v·n:
//! - sticky: v = 0;
//! - slip: the normal component is removed both ways (v ← v - vn n);
//! - separate: only an approaching normal component is removed (vn < 0), so material can leave.
//!
//! Coulomb friction acts on the tangential part vt when the node is pressed into the surface
//! (vn < 0): vt ← vt · max(0, 1 - μ |vn| / |vt|). Only the approaching normal velocity counts:
//! removing an outgoing vn (slip) is a constraint impulse the surface pulls with, and charging
//! friction for it over-brakes sliding (measured: a block stopped 36 % short of v0²/(2μg)).

use glam::Vec3A;

/// How a surface treats grid velocity at its boundary nodes (PhysGaussian's boundary
/// conditions); in a scene file `"sticky"`, `"slip"` or `"separate"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Surface {
    /// Zero velocity relative to the collider.
    #[default]
    Sticky,
    /// Remove the normal component both ways.
    Slip,
    /// Remove only an approaching normal component.
    Separate,
}

/// Applies `surface` with friction coefficient `mu` to relative velocity `v` at outward normal `n`.
#[inline]
pub fn apply_surface(v: Vec3A, n: Vec3A, surface: Surface, mu: f32) -> Vec3A {
    let vn = v.dot(n);
    match surface {
        Surface::Sticky => Vec3A::ZERO,
        Surface::Slip => friction(v - vn * n, (-vn).max(0.0), mu),
        Surface::Separate => {
            if vn < 0.0 {
                friction(v - vn * n, -vn, mu)
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
    fn sticky_stops_everything() {
        assert_eq!(
            apply_surface(Vec3A::ONE, Vec3A::Z, Surface::Sticky, 0.0),
            Vec3A::ZERO
        );
    }
}
