//! The two-body contact between one grid node (or particle) of a deformable object and a
//! movable solid: the impulse that gives their relative velocity at the contact the surface
//! rule's answer, shared between the two by their effective mass (Hu et al. 2018, MLS-MPM
//! section 6, two-way rigid coupling; the impulse of a contact point between two bodies as in
//! Mirtich 1996 and every sequential-impulse solver).
//!
//! For a node of mass m at offset r from the solid's COM, with solid mass M and world inverse
//! inertia I⁻¹, an impulse j on the node changes their relative velocity by K j with
//! K x = x / m + x / M + (I⁻¹ (r × x)) × r, so the scalar effective mass along a direction d is
//! 1 / k(d) with k(d) = 1/m + 1/M + (r × d)·I⁻¹(r × d). Against an immovable solid K = 1/m and
//! the impulse is the node's own momentum change, the one-way boundary rule.
//!
//! Many nodes touch one solid in a substep. They are solved node by node against the solid's
//! velocity at the start of a sweep, each seeing its share w_i = m_i / Σ m of the solid's mass
//! and inertia (mass splitting, Tonge et al. 2012, "Mass splitting for jitter-free parallel
//! rigid body simulation"), and the solid's velocity takes the sum of their impulses after the
//! sweep (Jacobi over nodes, as a GPU runs it). One sweep is exact for a single node and for
//! equal nodes on a flat face; otherwise sweeps converge from below (the split solid is lighter
//! than the whole, so no node is over-pushed): they run until no velocity changes by more than
//! [`COUPLING_CONVERGED_M_S`], at most [`COUPLING_SWEEPS`] of them.
//!
//! The surface rules as impulses (compare [`crate::collider::apply_surface`]): with v the
//! relative velocity and v_n = v·n,
//! - separate and sticky: an approaching v_n < 0 takes the normal impulse −v_n / k(n);
//! - slip: v_n takes −v_n / k(n) both ways;
//! - clamp: the whole v is removed, j = −K⁻¹ v;
//! - friction (separate, sticky and slip): after the normal impulse, the tangential relative
//!   velocity v_t takes an impulse of at most μ times the approaching normal impulse,
//!   max(−v_n, 0) / k(n), toward stopping it, |v_t| / k(t) at most; sticky's μ is at least
//!   [`crate::collider::surface::STICKY_FRICTION`].

use glam::{DMat3, DVec3, Vec3A};

use crate::collider::Surface;

/// Most Jacobi sweeps of a two-way grid boundary solve.
pub const COUPLING_SWEEPS: usize = 64;

/// A two-way solve stops once no node's (or particle's) velocity changed by more than this in a
/// sweep (m/s). Each sweep leaves a node approaching a solid at M / (M + Σ m) of what it had,
/// and what is left creeps on: four sweeps left a 324 g jelly on a 37.5 g box sinking into it
/// by 1 % of each substep's gravity, which rocked it off the box within seconds. A 5 g lid on a
/// jelly, the slowest case, steps 1.3 times as long as with four sweeps (1e-6: 1.6 times).
pub const COUPLING_CONVERGED_M_S: f32 = 1e-5;

/// Gauss–Seidel passes of [`Hold::apply`] over a solid's support points.
pub const SUPPORT_PASSES: usize = 4;

/// A point where a movable solid leans on an immovable one (a floor, a static shelf, a
/// kinematic object), from the last contact pass that loaded it.
///
/// A solid lighter than the material pressing on it gives way within the coupling's sweeps
/// unless they see what holds it: a 37.5 g box under a 324 g jelly, both on a floor, was pushed
/// down and tilted by every substep's weight of the jelly, which the floor only answered after
/// the grid had moved on, so the jelly crept into the box on one side and slid off it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Support {
    /// The point's offset from the solid's COM (m, world frame).
    pub r_m: DVec3,
    /// Unit normal out of the support, into the solid.
    pub normal: DVec3,
    /// The support's velocity at the point (m/s).
    pub velocity_m_s: DVec3,
    /// Coulomb friction μ of the pair.
    pub friction: f64,
}

/// A solid's hold on its [`Support`]s over one two-way solve: the normal and friction impulse
/// each point has given so far, clamped as accumulated totals (as in [`super::solver`]), so the
/// friction over the whole solve stays within μ times its normal impulse.
#[derive(Debug, Clone, Default)]
pub struct Hold {
    /// Per support: accumulated normal impulse (N s, ≥ 0) and friction impulse (N s).
    impulses: Vec<(f64, DVec3)>,
}

impl Hold {
    /// No impulse yet at any of `supports`.
    pub fn new(supports: &[Support]) -> Self {
        Self {
            impulses: vec![(0.0, DVec3::ZERO); supports.len()],
        }
    }

    /// Holds a solid's COM velocity `v` (m/s) and angular velocity `w` (rad/s), of inverse
    /// mass `inverse_mass` (1/kg) and world inverse inertia `inverse_inertia` (1/(kg m²)), on
    /// `supports` (those `self` was made for): at each, a normal impulse raises an approaching
    /// normal velocity relative to the support to zero, and friction brings the tangential one
    /// toward zero within μ times the point's normal impulse ([`SUPPORT_PASSES`] Gauss–Seidel
    /// passes). What the grid's nodes see of the solid within a substep; the contact solver
    /// then settles the solid's own velocity on its supports with the reaction the nodes gave.
    pub fn apply(
        &mut self,
        v: &mut DVec3,
        w: &mut DVec3,
        inverse_mass: f64,
        inverse_inertia: DMat3,
        supports: &[Support],
    ) {
        let push = |v: &mut DVec3, w: &mut DVec3, r: DVec3, j: DVec3| {
            *v += j * inverse_mass;
            *w += inverse_inertia * r.cross(j);
        };
        for _ in 0..SUPPORT_PASSES {
            for (s, (normal, tangent)) in supports.iter().zip(self.impulses.iter_mut()) {
                let n = s.normal;
                let relative = |v: &DVec3, w: &DVec3| *v + w.cross(s.r_m) - s.velocity_m_s;
                let rn = s.r_m.cross(n);
                let k = inverse_mass + rn.dot(inverse_inertia * rn);
                if !(k > 0.0 && k.is_finite()) {
                    continue;
                }
                let total = (*normal - relative(v, w).dot(n) / k).max(0.0);
                push(v, w, s.r_m, n * (total - *normal));
                *normal = total;
                let u = relative(v, w);
                let ut = u - n * u.dot(n);
                let speed = ut.length();
                if speed <= 0.0 {
                    continue;
                }
                let t = ut / speed;
                let rt = s.r_m.cross(t);
                let kt = inverse_mass + rt.dot(inverse_inertia * rt);
                let limit = s.friction * *normal;
                let mut next = *tangent - t * (speed / kt);
                if next.length() > limit {
                    next *= limit / next.length();
                }
                push(v, w, s.r_m, next - *tangent);
                *tangent = next;
            }
        }
    }
}

/// A movable solid as one node's contact sees it: the inverse mass (1/kg) and world inverse
/// inertia (1/(kg m²)) of its share of the solid (already divided by the node's share w).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolidShare {
    /// 1 / (w M) (1/kg).
    pub inverse_mass: f64,
    /// I⁻¹ / w, world frame (1/(kg m²)).
    pub inverse_inertia: DMat3,
}

impl SolidShare {
    /// K x: the change of relative velocity (node minus solid) an impulse `x` (N s) on a node of
    /// inverse mass `inv_m` at offset `r` (m) makes.
    fn response(&self, inv_m: f64, r: DVec3, x: DVec3) -> DVec3 {
        x * (inv_m + self.inverse_mass) + (self.inverse_inertia * r.cross(x)).cross(r)
    }

    /// k(d) = d · K d for a unit direction `d`.
    fn along(&self, inv_m: f64, r: DVec3, d: DVec3) -> f64 {
        let rd = r.cross(d);
        inv_m + self.inverse_mass + rd.dot(self.inverse_inertia * rd)
    }

    /// K as a matrix.
    fn matrix(&self, inv_m: f64, r: DVec3) -> DMat3 {
        DMat3::from_cols(
            self.response(inv_m, r, DVec3::X),
            self.response(inv_m, r, DVec3::Y),
            self.response(inv_m, r, DVec3::Z),
        )
    }
}

/// The impulse (N s) on a node of mass `mass_kg` at offset `r_m` from the solid's COM, whose
/// velocity relative to the solid's surface there is `v_rel` (m/s), at the solid's outward
/// normal `n`, for `surface` with friction `mu` against `solid` (module docs). Zero for no mass
/// or a non-finite answer.
pub fn node_impulse(
    v_rel: Vec3A,
    n: Vec3A,
    mass_kg: f32,
    r_m: Vec3A,
    solid: &SolidShare,
    surface: Surface,
    mu: f32,
) -> Vec3A {
    if mass_kg <= 0.0 {
        return Vec3A::ZERO;
    }
    let (v, n, r) = (v_rel.as_dvec3(), n.as_dvec3(), r_m.as_dvec3());
    let inv_m = 1.0 / mass_kg as f64;
    let vn = v.dot(n);
    let j = match surface {
        Surface::Clamp => {
            let k = solid.matrix(inv_m, r);
            if k.determinant().abs() > 0.0 {
                -(k.inverse() * v)
            } else {
                DVec3::ZERO
            }
        }
        Surface::Slip | Surface::Separate | Surface::Sticky => {
            if surface != Surface::Slip && vn >= 0.0 {
                return Vec3A::ZERO;
            }
            let mu = surface.friction(mu);
            let kn = solid.along(inv_m, r, n);
            let jn = -vn / kn;
            let pressed = (-vn).max(0.0) / kn;
            let mut j = n * jn;
            let after = v + solid.response(inv_m, r, j);
            let vt = after - n * after.dot(n);
            let speed = vt.length();
            if mu > 0.0 && pressed > 0.0 && speed > 0.0 {
                let t = vt / speed;
                let stop = speed / solid.along(inv_m, r, t);
                j -= t * stop.min(mu as f64 * pressed);
            }
            j
        }
    };
    if j.is_finite() {
        j.as_vec3a()
    } else {
        Vec3A::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collider::apply_surface;

    const IMMOVABLE: SolidShare = SolidShare {
        inverse_mass: 0.0,
        inverse_inertia: DMat3::ZERO,
    };

    #[test]
    fn against_an_immovable_solid_the_impulse_is_the_one_way_rule() {
        let m = 0.3f32;
        for surface in [
            Surface::Separate,
            Surface::Slip,
            Surface::Sticky,
            Surface::Clamp,
        ] {
            for v in [
                Vec3A::new(0.2, -0.1, -0.5),
                Vec3A::new(2.0, 0.5, -0.1),
                Vec3A::new(0.3, 0.0, 0.4),
            ] {
                let j = node_impulse(
                    v,
                    Vec3A::Z,
                    m,
                    Vec3A::new(0.1, 0.0, -0.2),
                    &IMMOVABLE,
                    surface,
                    0.5,
                );
                let want = apply_surface(v, Vec3A::Z, surface, 0.5);
                assert!(
                    (v + j / m - want).length() < 1e-6,
                    "{surface:?} {v}: {} vs {want}",
                    v + j / m
                );
            }
        }
    }

    #[test]
    fn a_node_and_a_free_solid_meet_at_their_common_velocity() {
        // A solid of mass M at 1 m/s into a node of mass m at rest, through the COM: they leave
        // together at M / (m + M) (perfectly inelastic), kinetic energy M / (m + M) of before.
        for ratio in [0.5, 1.0, 2.0, 3.0] {
            let big_m = 1.0;
            let m = (ratio * big_m) as f32;
            let solid = SolidShare {
                inverse_mass: 1.0 / big_m,
                inverse_inertia: DMat3::IDENTITY * 10.0,
            };
            let v_rel = Vec3A::new(0.0, 0.0, -1.0);
            let j = node_impulse(
                v_rel,
                Vec3A::Z,
                m,
                Vec3A::new(0.0, 0.0, 0.05),
                &solid,
                Surface::Separate,
                0.5,
            );
            let v_node = j.as_dvec3() / m as f64;
            let v_solid = DVec3::new(0.0, 0.0, 1.0) - j.as_dvec3() / big_m;
            let common = big_m / (m as f64 + big_m);
            assert!((v_node.z - common).abs() < 1e-6, "{ratio}: node {v_node}");
            assert!(
                (v_solid.z - common).abs() < 1e-6,
                "{ratio}: solid {v_solid}"
            );
            let energy =
                0.5 * (m as f64 * v_node.length_squared() + big_m * v_solid.length_squared());
            assert!((energy / (0.5 * big_m) - common).abs() < 1e-6);
        }
    }
}
