//! One contact solver for every contact point of a substep: sequential impulses with accumulated
//! clamping and warm starting (Catto, "Iterative Dynamics with Temporal Coherence", GDC 2005;
//! the scheme of Box2D and rapier).
//!
//! Per point: the normal impulse P_n ≥ 0 drives the relative normal velocity v_n (B relative to
//! A along n, A to B) to its target; friction is an isotropic Coulomb cone |P_t| ≤ μ P_n solved
//! in the tangent plane with its 2×2 effective mass. Bodies' velocities are updated after every
//! point, so a body with several contacts is never over-pushed. Targets:
//! - impact (−v_n above the resting speed, the surfaces touching within the substep, e > 0):
//!   −e v_n;
//! - speculative (separation s > 0): v_n ≥ −s/dt, the gap may close but not overshoot;
//! - otherwise 0.
//!
//! Position error is removed by split impulses (Catto 2006; Box2D 2.x "position correction"
//! and Bullet's split impulse): a second, separate set of pseudo-velocities drives a penetrating
//! point out at β (depth − slop)/dt. Pseudo-velocities move positions for one substep and are
//! then dropped, so pushing out adds no kinetic energy and resting objects neither sink nor jump.

use glam::{DMat3, DVec3};

/// A body as the solver sees it. Immovable bodies (static objects, colliders) have zero inverse
/// mass and inertia.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverBody {
    /// COM (m).
    pub com_m: DVec3,
    /// COM velocity (m/s).
    pub velocity_m_s: DVec3,
    /// Angular velocity (rad/s).
    pub omega_rad_s: DVec3,
    /// 1/m (1/kg).
    pub inverse_mass: f64,
    /// World I⁻¹ about the COM (1/(kg m²)).
    pub inverse_inertia: DMat3,
    /// Split-impulse pseudo-velocity (m/s).
    pub push_m_s: DVec3,
    /// Split-impulse pseudo angular velocity (rad/s).
    pub push_rad_s: DVec3,
}

impl SolverBody {
    /// A body that nothing moves, with surface velocity `velocity_m_s` (moving colliders).
    pub fn immovable(velocity_m_s: DVec3) -> Self {
        Self::new(DVec3::ZERO, velocity_m_s, DVec3::ZERO, 0.0, DMat3::ZERO)
    }

    /// A body with the given state.
    pub fn new(
        com_m: DVec3,
        velocity_m_s: DVec3,
        omega_rad_s: DVec3,
        inverse_mass: f64,
        inverse_inertia: DMat3,
    ) -> Self {
        Self {
            com_m,
            velocity_m_s,
            omega_rad_s,
            inverse_mass,
            inverse_inertia,
            push_m_s: DVec3::ZERO,
            push_rad_s: DVec3::ZERO,
        }
    }

    fn velocity_at(&self, r: DVec3) -> DVec3 {
        self.velocity_m_s + self.omega_rad_s.cross(r)
    }

    fn push_at(&self, r: DVec3) -> DVec3 {
        self.push_m_s + self.push_rad_s.cross(r)
    }

    fn apply(&mut self, r: DVec3, p: DVec3) {
        self.velocity_m_s += p * self.inverse_mass;
        self.omega_rad_s += self.inverse_inertia * r.cross(p);
    }

    fn apply_push(&mut self, r: DVec3, p: DVec3) {
        self.push_m_s += p * self.inverse_mass;
        self.push_rad_s += self.inverse_inertia * r.cross(p);
    }

    /// d·(I⁻¹ (r × e)) × r + 1/m: the response along d to a unit impulse along e at r.
    fn response(&self, r: DVec3, d: DVec3, e: DVec3) -> f64 {
        if self.inverse_mass == 0.0 {
            return 0.0;
        }
        self.inverse_mass * d.dot(e) + d.dot((self.inverse_inertia * r.cross(e)).cross(r))
    }
}

/// One contact point between bodies `a` and `b`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactPoint {
    /// Body indices into the solver's body slice.
    pub a: usize,
    /// Second body.
    pub b: usize,
    /// Contact point (m).
    pub point_m: DVec3,
    /// Unit normal from A to B.
    pub normal: DVec3,
    /// Separation along the normal (m): negative when penetrating.
    pub separation_m: f64,
    /// Restitution e of the pair.
    pub restitution: f64,
    /// Coulomb friction μ of the pair (infinite: no sliding).
    pub friction: f64,
    /// Accumulated normal impulse on B (N s); warm-start value on entry.
    pub normal_impulse: f64,
    /// Accumulated tangential impulse on B (N s), in the tangent plane; warm start on entry.
    pub tangent_impulse: DVec3,
}

/// Solver settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverSettings {
    /// Velocity iterations.
    pub iterations: usize,
    /// Split-impulse iterations.
    pub push_iterations: usize,
    /// Fraction of the penetration removed per substep (β).
    pub baumgarte: f64,
    /// Penetration left alone (m).
    pub slop_m: f64,
    /// Approach speeds below this are resting contact (m/s): no restitution.
    pub resting_speed_m_s: f64,
    /// Largest push-out speed (m/s).
    pub max_push_m_s: f64,
}

impl Default for SolverSettings {
    fn default() -> Self {
        Self {
            iterations: 60,
            push_iterations: 6,
            baumgarte: 0.2,
            slop_m: 5e-5,
            resting_speed_m_s: 0.0,
            max_push_m_s: 0.5,
        }
    }
}

/// Per-point constants of one solve.
struct Row {
    ra: DVec3,
    rb: DVec3,
    k_n: f64,
    tangents: [DVec3; 2],
    /// Inverse of the 2×2 tangent effective mass, row-major.
    k_t_inv: [f64; 4],
    target_vn: f64,
    push_target: f64,
    push_impulse: f64,
}

fn relative(bodies: &[SolverBody], c: &ContactPoint, row: &Row) -> DVec3 {
    bodies[c.b].velocity_at(row.rb) - bodies[c.a].velocity_at(row.ra)
}

fn apply_pair(bodies: &mut [SolverBody], c: &ContactPoint, row: &Row, p: DVec3) {
    bodies[c.a].apply(row.ra, -p);
    bodies[c.b].apply(row.rb, p);
}

fn effective(
    bodies: &[SolverBody],
    c: &ContactPoint,
    ra: DVec3,
    rb: DVec3,
    d: DVec3,
    e: DVec3,
) -> f64 {
    bodies[c.a].response(ra, d, e) + bodies[c.b].response(rb, d, e)
}

/// Solves `contacts` on `bodies` for a substep of `dt_s`: warm start from each point's stored
/// impulses, then the velocity iterations, then the split-impulse iterations. On return each
/// point holds its accumulated impulses (for the next substep's warm start) and each body its new
/// velocities and pseudo-velocities.
pub fn solve(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactPoint],
    dt_s: f64,
    settings: &SolverSettings,
) {
    let mut rows: Vec<Row> = Vec::with_capacity(contacts.len());
    for c in contacts.iter_mut() {
        let ra = c.point_m - bodies[c.a].com_m;
        let rb = c.point_m - bodies[c.b].com_m;
        let n = c.normal;
        let k_n = effective(bodies, c, ra, rb, n, n);
        let (t0, t1) = n.any_orthonormal_pair();
        let k00 = effective(bodies, c, ra, rb, t0, t0);
        let k01 = effective(bodies, c, ra, rb, t0, t1);
        let k11 = effective(bodies, c, ra, rb, t1, t1);
        let det = k00 * k11 - k01 * k01;
        let k_t_inv = if det > 1e-12 * (k00 * k11).max(f64::MIN_POSITIVE) {
            [k11 / det, -k01 / det, -k01 / det, k00 / det]
        } else {
            [0.0; 4]
        };
        let mut row = Row {
            ra,
            rb,
            k_n,
            tangents: [t0, t1],
            k_t_inv,
            target_vn: 0.0,
            push_target: 0.0,
            push_impulse: 0.0,
        };
        let vn = relative(bodies, c, &row).dot(n);
        let s = c.separation_m;
        row.target_vn = if s > 0.0 { -s / dt_s } else { 0.0 };
        // An impact within this substep bounces now (a gap closed first would leave only the
        // slower remaining approach to restitution); with e = 0 the gap just closes.
        let touches = s <= 0.0 || -vn * dt_s >= s;
        if touches && -vn > settings.resting_speed_m_s && c.restitution > 0.0 {
            row.target_vn = row.target_vn.max(-c.restitution * vn);
        }
        if s < -settings.slop_m {
            row.push_target =
                (settings.baumgarte * (-s - settings.slop_m) / dt_s).min(settings.max_push_m_s);
        }
        if !(k_n > 0.0 && k_n.is_finite()) {
            c.normal_impulse = 0.0;
            c.tangent_impulse = DVec3::ZERO;
        }
        // Warm start: the stored impulses, the tangential part projected on the new plane.
        c.tangent_impulse -= n * c.tangent_impulse.dot(n);
        let p = n * c.normal_impulse + c.tangent_impulse;
        apply_pair(bodies, c, &row, p);
        rows.push(row);
    }
    for _ in 0..settings.iterations {
        for (c, row) in contacts.iter_mut().zip(&rows) {
            if row.k_n <= 0.0 || !row.k_n.is_finite() {
                continue;
            }
            let n = c.normal;
            // Friction first (Box2D order), within the cone of the current normal impulse.
            if row.k_t_inv != [0.0; 4] {
                let vt = relative(bodies, c, row);
                let (a, b) = (vt.dot(row.tangents[0]), vt.dot(row.tangents[1]));
                let k = row.k_t_inv;
                let d = -(row.tangents[0] * (k[0] * a + k[1] * b)
                    + row.tangents[1] * (k[2] * a + k[3] * b));
                let mut total = c.tangent_impulse + d;
                let limit = c.friction * c.normal_impulse;
                let len = total.length();
                if len > limit {
                    total = if limit > 0.0 {
                        total * (limit / len)
                    } else {
                        DVec3::ZERO
                    };
                }
                let delta = total - c.tangent_impulse;
                c.tangent_impulse = total;
                apply_pair(bodies, c, row, delta);
            }
            let vn = relative(bodies, c, row).dot(n);
            let total = (c.normal_impulse + (row.target_vn - vn) / row.k_n).max(0.0);
            let delta = total - c.normal_impulse;
            c.normal_impulse = total;
            apply_pair(bodies, c, row, n * delta);
        }
    }
    for _ in 0..settings.push_iterations {
        for (c, row) in contacts.iter().zip(rows.iter_mut()) {
            if row.push_target <= 0.0 || row.k_n <= 0.0 || !row.k_n.is_finite() {
                continue;
            }
            let n = c.normal;
            let vn = (bodies[c.b].push_at(row.rb) - bodies[c.a].push_at(row.ra)).dot(n);
            let total = (row.push_impulse + (row.push_target - vn) / row.k_n).max(0.0);
            let delta = total - row.push_impulse;
            row.push_impulse = total;
            bodies[c.a].apply_push(row.ra, -n * delta);
            bodies[c.b].apply_push(row.rb, n * delta);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ball(z: f64, vz: f64) -> SolverBody {
        SolverBody::new(
            DVec3::new(0.0, 0.0, z),
            DVec3::new(0.0, 0.0, vz),
            DVec3::ZERO,
            1.0,
            DMat3::IDENTITY * 10.0,
        )
    }

    fn ground_contact(e: f64, separation_m: f64) -> ContactPoint {
        ContactPoint {
            a: 0,
            b: 1,
            point_m: DVec3::ZERO,
            normal: DVec3::Z,
            separation_m,
            restitution: e,
            friction: 0.5,
            normal_impulse: 0.0,
            tangent_impulse: DVec3::ZERO,
        }
    }

    #[test]
    fn an_impact_follows_the_restitution_law() {
        for e in [0.0, 0.5, 1.0] {
            let mut bodies = [SolverBody::immovable(DVec3::ZERO), ball(0.0, -2.0)];
            let mut c = [ground_contact(e, 0.0)];
            solve(&mut bodies, &mut c, 1e-3, &SolverSettings::default());
            assert!((bodies[1].velocity_m_s.z - 2.0 * e).abs() < 1e-9, "e = {e}");
            assert!((c[0].normal_impulse - (1.0 + e) * 2.0).abs() < 1e-9);
        }
    }

    #[test]
    fn a_gap_may_close_but_not_overshoot() {
        let dt = 1e-3;
        let mut bodies = [SolverBody::immovable(DVec3::ZERO), ball(0.0, -3.0)];
        let mut c = [ground_contact(0.0, 1e-3)];
        solve(&mut bodies, &mut c, dt, &SolverSettings::default());
        assert!((bodies[1].velocity_m_s.z + 1.0).abs() < 1e-9);
        // A far gap does nothing.
        let mut bodies = [SolverBody::immovable(DVec3::ZERO), ball(0.0, -0.5)];
        let mut c = [ground_contact(0.0, 1e-2)];
        solve(&mut bodies, &mut c, dt, &SolverSettings::default());
        assert_eq!(bodies[1].velocity_m_s.z, -0.5);
    }

    #[test]
    fn friction_is_an_isotropic_cone() {
        // Sliding diagonally at 1 m/s, pressed by an impulse of 1 N s, mu = 0.5: the friction
        // impulse is 0.5 N s against the sliding direction, whatever the tangent basis.
        let mut b = ball(0.0, -1.0);
        b.velocity_m_s = DVec3::new(0.6, 0.8, -1.0);
        b.inverse_inertia = DMat3::ZERO;
        let mut bodies = [SolverBody::immovable(DVec3::ZERO), b];
        let mut c = [ground_contact(0.0, 0.0)];
        solve(&mut bodies, &mut c, 1e-3, &SolverSettings::default());
        let v = bodies[1].velocity_m_s;
        assert!(v.z.abs() < 1e-9);
        assert!((v.x - 0.3).abs() < 1e-9 && (v.y - 0.4).abs() < 1e-9, "{v}");
        assert!((c[0].tangent_impulse.length() - 0.5).abs() < 1e-9);
    }

    #[test]
    fn penetration_is_pushed_out_without_velocity() {
        let mut bodies = [SolverBody::immovable(DVec3::ZERO), ball(0.0, 0.0)];
        let mut c = [ground_contact(0.0, -1e-3)];
        let s = SolverSettings::default();
        solve(&mut bodies, &mut c, 1e-3, &s);
        assert_eq!(bodies[1].velocity_m_s, DVec3::ZERO);
        let expected = s.baumgarte * (1e-3 - s.slop_m) / 1e-3;
        assert!((bodies[1].push_m_s.z - expected).abs() < 1e-9);
    }

    #[test]
    fn warm_starting_keeps_a_resting_impulse() {
        // A resting box pressed by gravity: the stored impulse of the last substep alone holds it.
        let mut bodies = [SolverBody::immovable(DVec3::ZERO), ball(0.0, -9.81e-3)];
        let mut c = [ground_contact(0.0, 0.0)];
        c[0].normal_impulse = 9.81e-3;
        let s = SolverSettings {
            iterations: 0,
            ..Default::default()
        };
        solve(&mut bodies, &mut c, 1e-3, &s);
        assert!(bodies[1].velocity_m_s.z.abs() < 1e-12);
    }
}
