//! One contact solver for every contact point of a substep: sequential impulses with accumulated
//! clamping and warm starting (Catto, "Iterative Dynamics with Temporal Coherence", GDC 2005;
//! the scheme of Box2D and rapier).
//!
//! Per point: the normal impulse P_n ≥ 0 drives the relative normal velocity v_n (B relative to
//! A along n, A to B) to its target. Bodies' velocities are updated after every step, so a body
//! with several contacts is never over-pushed. A flat patch (normals within [`BLOCK_COS`]) steps
//! all its points' normal impulses at once ([`super::block`]) while they all stay in contact.
//!
//! Friction is solved per patch, not per point: the points of one pair whose normals agree
//! within [`PATCH_COS`] share one isotropic Coulomb cone |P_t| ≤ μ Σ P_n in the tangent plane,
//! anchored at their centre of pressure (the P_n-weighted centre of the last substep) with its
//! 2×2 effective mass, and one torsional friction about the normal limited by μ Σ P_n d_i (d_i
//! each point's distance from the anchor in the plane: the most that sliding points can resist
//! a spin with). This is the friction anchor of PhysX and Box2D v3's rolling and twist
//! resistance. Per-point friction would follow each point's share of the normal load, and that
//! split is statically indeterminate when more than three points carry a flat face: an uneven
//! split gives a sliding box a spurious spin about the normal, and a spinning box brakes less.
//! A pair with rolling resistance b (`rolling_resistance_m`) also gets, per patch, a couple in
//! the tangent plane against the relative rolling, clamped to b Σ P_n.
//!
//! Normal targets:
//! - impact (−v_n above the resting speed, the surfaces touching within the substep, e > 0,
//!   and its pair new: no normal impulse carried over from the last substep): −e v_n;
//! - speculative (separation s > 0): v_n ≥ −s/dt, the gap may close but not overshoot;
//! - otherwise 0.
//!
//! Position error is removed by split impulses (Catto 2006; Box2D 2.x "position correction"
//! and Bullet's split impulse): a second, separate set of pseudo-velocities drives a penetrating
//! point out at β (depth − slop)/dt. Pseudo-velocities move positions for one substep and are
//! then dropped, so pushing out adds no kinetic energy and resting objects neither sink nor jump.
//! An impact that bounces across a gap s (the surfaces meeting within the substep) is pulled
//! back by (1 + e) s the same way, to where an exact bounce leaves it.

use glam::DVec3;

use super::energy::{
    ENERGY_TOLERANCE, EXTERNAL_TOLERANCE, drive_work_j, external_energy_j, step_energy_j,
};
pub use super::patch::{BLOCK_COS, PATCH_COS};
use super::patch::{ContactPatch, patches, share_friction};
use super::rows::{ContactPoint, Row, SolverBody, apply_pair, effective, relative};
use super::settings::{ContactSolver, SolverSettings};

/// Solves `contacts` on `bodies` for a substep of `dt_s`: warm start from each point's stored
/// impulses, then the velocity iterations, then the split-impulse iterations. On return each
/// point holds its accumulated impulses (for the next substep's warm start), each body its new
/// velocities and pseudo-velocities, and the returned patches the friction as it acted.
///
/// Contact never adds energy: where the solve leaves the bodies more energy over the step than
/// they came with (kinetic, with the substep's gravity taken out of the velocities:
/// `energy::step_energy_j`) plus the work the driven (immovable, moving) bodies did
/// on them through its impulses, the substep is solved again from zero impulses with e = 0. Two
/// things can add it. Per-point restitution (each
/// point's Newton target −e v_n) is exact for one point but not for simultaneous impacts at
/// several (Baraff 1989, "Analytical methods for dynamic simulation of non-penetrating rigid
/// bodies"; Stewart 2000, "Rigid-body dynamics with friction and impact", section 5): a body
/// landing on points whose normals disagree, or whose spin turns one point's approach into
/// another's separation, can leave faster than it came (measured: a solid of a frozen
/// jelly's shape landing at 1.2 m/s left at 1.5 m/s, its spin from 12 to 36 rad/s). And
/// warm starting: the last substep's impulses, applied first, are more than this substep
/// needs when a light body is squeezed between a heavy one and a support (a 4.5 g box under a
/// 267 g solid), and the iterations, slow at such mass ratios, leave part of the excess.
/// Projected Gauss–Seidel from zero impulses with zero targets only lowers the kinetic
/// energy: each of its steps lowers the kinetic energy after the impulses, which the contact
/// problem minimises over v_n ≥ 0 (Moreau 1988, "Unilateral contact and dry friction in finite
/// freedom dynamics"). Against one driven body the same holds in its frame, where a dissipative
/// impulse P changes the kinetic energy by at most P · u, u the driven point's velocity (for a
/// body of mass m at v stopped against a wall at u: ½ m (u² − v²) ≤ m (u − v) · u).
pub fn solve(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactPoint],
    dt_s: f64,
    settings: &SolverSettings,
) -> Vec<ContactPatch> {
    let scheme = |bodies: &mut [SolverBody], contacts: &mut [ContactPoint]| match settings.scheme {
        ContactSolver::SoftStep => super::soft_step::solve(bodies, contacts, dt_s, settings),
        ContactSolver::SequentialImpulses => sequential_impulses(bodies, contacts, dt_s, settings),
    };
    if contacts.is_empty() {
        return scheme(bodies, contacts);
    }
    // The bodies as they came, to solve again from. The schemes change only the contacts'
    // impulses, which a second solve starts from zero anyway.
    let start = bodies.to_vec();
    let patches = scheme(bodies, contacts);
    let allowed = step_energy_j(&start) * (1.0 + ENERGY_TOLERANCE)
        + external_energy_j(&start) * (1.0 + EXTERNAL_TOLERANCE)
        + drive_work_j(bodies, contacts, &patches).max(0.0);
    if step_energy_j(bodies) <= allowed {
        return patches;
    }
    bodies.copy_from_slice(&start);
    let restitution: Vec<f64> = contacts.iter().map(|c| c.restitution).collect();
    for c in contacts.iter_mut() {
        c.restitution = 0.0;
        c.normal_impulse = 0.0;
        c.tangent_impulse = DVec3::ZERO;
        c.twist_impulse = 0.0;
    }
    let patches = scheme(bodies, contacts);
    for (c, e) in contacts.iter_mut().zip(restitution) {
        c.restitution = e;
    }
    patches
}

fn sequential_impulses(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactPoint],
    dt_s: f64,
    settings: &SolverSettings,
) -> Vec<ContactPatch> {
    let mut rows: Vec<Row> = Vec::with_capacity(contacts.len());
    for c in contacts.iter_mut() {
        let ra = c.point_m - bodies[c.a].com_m;
        let rb = c.point_m - bodies[c.b].com_m;
        let n = c.normal;
        let k_n = effective(bodies, c.a, c.b, ra, rb, n, n);
        let mut row = Row::new(ra, rb, k_n);
        let vn = relative(bodies, c.a, c.b, ra, rb).dot(n);
        let s = c.separation_m;
        row.target_vn = if s > 0.0 { -s / dt_s } else { 0.0 };
        // An impact within this substep bounces now (a gap closed first would leave only the
        // slower remaining approach to restitution); with e = 0 the gap just closes. A point
        // of a pair that already carried load in the last substep is lasting contact, not an
        // impact: a body driven into another that cannot give way (a kinematic pusher wedging
        // a box against a grippy floor) approaches again every substep, and bouncing each time
        // pumps energy in.
        let touches = s <= 0.0 || -vn * dt_s >= s;
        let lasting = c.lasting || c.normal_impulse > 0.0;
        if touches && !lasting && -vn > settings.resting_speed_m_s && c.restitution > 0.0 {
            // The law reflects the approach before this substep's external forces, which then
            // act on the rebound: reflecting v_n after them would return a falling body
            // (1 + e) g dt faster than it came.
            let external = (bodies[c.b].external_m_s - bodies[c.a].external_m_s).dot(n);
            row.target_vn = row
                .target_vn
                .max(-c.restitution * (vn - external) + external);
            row.bounce_gap_m = s.max(0.0);
        }
        if s < -settings.slop_m {
            row.push_target =
                (settings.baumgarte * (-s - settings.slop_m) / dt_s).min(settings.max_push_m_s);
        }
        if !(k_n > 0.0 && k_n.is_finite()) {
            c.normal_impulse = 0.0;
            c.tangent_impulse = DVec3::ZERO;
            c.twist_impulse = 0.0;
        }
        apply_pair(bodies, c.a, c.b, ra, rb, n * c.normal_impulse);
        rows.push(row);
    }
    let mut patches = patches(bodies, contacts, &mut rows, true);
    for patch in &patches {
        patch.warm_start_friction(bodies);
    }
    let mut v_rel: Vec<DVec3> = Vec::new();
    for _ in 0..settings.iterations {
        for patch in patches.iter_mut() {
            // Friction first (Box2D order), within the cone of the current normal impulses.
            patch.solve_friction(bodies, contacts, &rows);
            if !patch.solve_normal_block(bodies, contacts, &rows) {
                for &i in &patch.points {
                    solve_normal_point(bodies, &mut contacts[i], &rows[i]);
                }
            }
        }
        if settings.converged_m_s > 0.0
            && converged(bodies, contacts, &rows, &mut v_rel, settings.converged_m_s)
        {
            break;
        }
    }
    // A point that bounced across a gap s leaves from where it would have struck: exactly, the
    // surfaces meet after s/u of the substep (u the approach speed) and part at e u for the
    // rest, so they end e (u dt − s) apart, not s + e u dt; the bounce velocity moves them
    // (1 + e) s too far apart, and lifting a body that far against gravity gains energy. The
    // split impulses pull such a point back by that much, as a pseudo-velocity (negative push
    // target), leaving the velocities to the restitution law.
    for (c, row) in contacts.iter().zip(rows.iter_mut()) {
        if row.bounce_gap_m > 0.0 && c.normal_impulse > 0.0 {
            row.push_target = -(1.0 + c.restitution) * row.bounce_gap_m / dt_s;
        }
    }
    for _ in 0..settings.push_iterations {
        for (c, row) in contacts.iter().zip(rows.iter_mut()) {
            if row.push_target == 0.0 || row.k_n <= 0.0 || !row.k_n.is_finite() {
                continue;
            }
            let n = c.normal;
            let vn = (bodies[c.b].push_at(row.rb) - bodies[c.a].push_at(row.ra)).dot(n);
            let step = row.push_impulse + (row.push_target - vn) / row.k_n;
            // A push only pushes and a pull only pulls.
            let total = if row.push_target > 0.0 {
                step.max(0.0)
            } else {
                step.min(0.0)
            };
            let delta = total - row.push_impulse;
            row.push_impulse = total;
            bodies[c.a].apply_push(row.ra, -n * delta);
            bodies[c.b].apply_push(row.rb, n * delta);
        }
    }
    share_friction(contacts, &patches);
    patches
}

/// Whether no point's relative velocity moved by more than `tol_m_s` (m/s) since the last
/// call, whose velocities `last` holds (empty on the first call: not converged).
fn converged(
    bodies: &[SolverBody],
    contacts: &[ContactPoint],
    rows: &[Row],
    last: &mut Vec<DVec3>,
    tol_m_s: f64,
) -> bool {
    let now = contacts
        .iter()
        .zip(rows)
        .map(|(c, r)| relative(bodies, c.a, c.b, r.ra, r.rb));
    if last.len() != contacts.len() {
        *last = now.collect();
        return false;
    }
    let mut done = true;
    for (old, new) in last.iter_mut().zip(now) {
        done &= (new - *old).length() <= tol_m_s;
        *old = new;
    }
    done
}

/// One sequential-impulse step of one point's normal impulse, with accumulated clamping.
fn solve_normal_point(bodies: &mut [SolverBody], c: &mut ContactPoint, row: &Row) {
    if row.k_n <= 0.0 || !row.k_n.is_finite() {
        return;
    }
    let n = c.normal;
    let vn = relative(bodies, c.a, c.b, row.ra, row.rb).dot(n);
    let total = (c.normal_impulse + (row.target_vn - vn) / row.k_n).max(0.0);
    let delta = total - c.normal_impulse;
    c.normal_impulse = total;
    apply_pair(bodies, c.a, c.b, row.ra, row.rb, n * delta);
}

#[cfg(test)]
mod tests {
    use glam::DMat3;

    use super::*;
    use crate::contact::energy::kinetic_energy_j;

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
            lasting: false,
            tangent_impulse: DVec3::ZERO,
            twist_impulse: 0.0,
            rolling_resistance_m: 0.0,
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
    fn an_impact_reflects_the_approach_before_the_substep_gravity() {
        // A ball arriving at u, its velocity already holding the substep's g dt: it leaves at
        // e u, then falls for the substep, so e u − g dt; reflecting u + g dt instead would
        // return it (1 + e) g dt faster, and at e = 1 faster than it came.
        let (dt, g, u) = (8.3e-3, 9.81, 0.5);
        for e in [0.25, 0.5, 1.0] {
            let mut ball = ball(0.0, -u - g * dt);
            ball.external_m_s = DVec3::new(0.0, 0.0, -g * dt);
            let mut bodies = [SolverBody::immovable(DVec3::ZERO), ball];
            let mut c = [ground_contact(e, 0.0)];
            solve(&mut bodies, &mut c, dt, &SolverSettings::default());
            let vz = bodies[1].velocity_m_s.z;
            assert!((vz - (e * u - g * dt)).abs() < 1e-9, "e = {e}: {vz}");
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
    fn a_bounce_across_a_gap_ends_where_an_exact_bounce_does() {
        // A ball s above the ground approaching at u strikes after s/u and rises at e u for the
        // rest of the substep: it ends e (u dt − s) above, moving at e u. Its position moves by
        // velocity plus push over the substep.
        let (dt, u) = (1e-3, 3.0);
        for e in [0.0, 0.25, 0.5, 1.0] {
            for s in [2e-4, 1e-3, 2.5e-3] {
                let mut bodies = [SolverBody::immovable(DVec3::ZERO), ball(0.0, -u)];
                let mut c = [ground_contact(e, s)];
                solve(&mut bodies, &mut c, dt, &SolverSettings::default());
                let b = &bodies[1];
                let expected_v = if e > 0.0 { e * u } else { -s / dt };
                assert!(
                    (b.velocity_m_s.z - expected_v).abs() < 1e-9,
                    "e {e}, s {s}: {b:?}"
                );
                let gap = s + (b.velocity_m_s.z + b.push_m_s.z) * dt;
                assert!(
                    (gap - e * (u * dt - s)).abs() < 1e-12,
                    "e {e}, s {s}: gap {gap}"
                );
            }
        }
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

    /// Contacts of `body` (index 1) on the ground plane z = 0 (index 0) at `points` (x, y).
    fn on_ground(points: &[(f64, f64)], mu: f64) -> Vec<ContactPoint> {
        points
            .iter()
            .map(|&(x, y)| ContactPoint {
                point_m: DVec3::new(x, y, 0.0),
                friction: mu,
                ..ground_contact(0.0, 0.0)
            })
            .collect()
    }

    #[test]
    fn an_uneven_manifold_slides_without_spin() {
        // A box face on the ground sampled at five points that are not symmetric about its COM:
        // the split of the normal impulse between them is indeterminate, but the friction is
        // the Coulomb law μ Σ P_n against the sliding direction and makes no spin about z.
        let (mu, dt, g) = (0.3, 1e-3, 9.81);
        let mut b = ball(0.05, -g * dt);
        b.velocity_m_s.x = 1.0;
        let mut bodies = [SolverBody::immovable(DVec3::ZERO), b];
        let pts = [
            (-0.05, -0.05),
            (0.05, -0.044),
            (0.0, -0.001),
            (0.02, 0.019),
            (-0.04, 0.049),
        ];
        let mut c = on_ground(&pts, mu);
        let patches = solve(&mut bodies, &mut c, dt, &SolverSettings::default());
        assert_eq!(patches.len(), 1);
        let load: f64 = c.iter().map(|p| p.normal_impulse).sum();
        let v = bodies[1].velocity_m_s;
        let w = bodies[1].omega_rad_s;
        // Friction tips the box, so the normal impulses converge over the iterations (to 0.1 %
        // in 60); the friction is clamped to μ times their sum at each iteration.
        assert!((load - g * dt).abs() < 1e-3 * g * dt, "load {load}");
        assert!((1.0 - v.x - mu * load).abs() < 1e-3 * mu * load, "{v}");
        assert!(v.y.abs() < 1e-6 && w.z.abs() < 1e-6, "{v} {w}");
        // The points' shares sum to the patch's friction.
        let shares: DVec3 = c.iter().map(|p| p.tangent_impulse).sum();
        assert!((shares - patches[0].tangent_impulse).length() < 1e-15);
    }

    #[test]
    fn torsional_friction_is_limited_by_the_patch_radius() {
        // A body spinning at 10 rad/s about z, pressed on the ground by 1 N s at four points
        // 0.1 m from its axis, μ = 0.5: the twist impulse is at most μ P_n r = 0.05 N m s,
        // and I_zz = 0.1 kg m² loses 0.5 rad/s; a slow spin stops.
        for (spin, expected) in [(10.0, 9.5), (0.2, 0.0)] {
            let mut b = ball(0.05, -1.0);
            b.omega_rad_s.z = spin;
            let mut bodies = [SolverBody::immovable(DVec3::ZERO), b];
            let mut c = on_ground(&[(0.1, 0.0), (0.0, 0.1), (-0.1, 0.0), (0.0, -0.1)], 0.5);
            solve(&mut bodies, &mut c, 1e-3, &SolverSettings::default());
            let w = bodies[1].omega_rad_s;
            // The normal impulses (and so the limit) converge over the iterations: to 1e-6 here.
            assert!((w.z - expected).abs() < 1e-5, "{spin}: {w}");
            assert!(bodies[1].velocity_m_s.length() < 1e-5);
        }
    }

    #[test]
    fn a_pair_with_two_normals_gets_two_patches() {
        // A peg against a floor and a wall at once: each face its own friction patch.
        let mut bodies = [SolverBody::immovable(DVec3::ZERO), ball(0.05, -1.0)];
        let mut c = on_ground(&[(0.1, 0.0), (-0.1, 0.0)], 0.5);
        c.push(ContactPoint {
            normal: DVec3::X,
            point_m: DVec3::new(-0.05, 0.0, 0.05),
            ..c[0]
        });
        let patches = solve(&mut bodies, &mut c, 1e-3, &SolverSettings::default());
        let sizes: Vec<usize> = patches.iter().map(|p| p.points.len()).collect();
        assert_eq!(sizes, [2, 1]);
    }

    /// The corners of a 10 cm face about its centre (m).
    const CORNERS: [(f64, f64); 4] = [(-0.05, -0.05), (0.05, -0.05), (0.05, 0.05), (-0.05, 0.05)];

    /// The ground (body 0) and `n` 1 kg, 10 cm cubes (I⁻¹ = 600) stacked on it, falling at
    /// `vz_m_s`, each on the one below by its four corners (μ = 0.5, e = 0).
    fn column(n: usize, vz_m_s: f64) -> (Vec<SolverBody>, Vec<ContactPoint>) {
        let mut bodies = vec![SolverBody::immovable(DVec3::ZERO)];
        let mut c = Vec::new();
        for k in 0..n {
            let z = 0.05 + 0.1 * k as f64;
            let mut b = ball(z, vz_m_s);
            b.inverse_inertia = DMat3::IDENTITY * 600.0;
            bodies.push(b);
            for (x, y) in CORNERS {
                c.push(ContactPoint {
                    a: k,
                    b: k + 1,
                    point_m: DVec3::new(x, y, z - 0.05),
                    ..ground_contact(0.0, 0.0)
                });
            }
        }
        (bodies, c)
    }

    #[test]
    fn a_column_solved_cold_does_not_lean() {
        // Ten boxes of 1 kg, 10 cm, each on the one below by its four corners, μ = 0.5, one
        // substep from cold. Point by point, each corner's impulse tilts its box for a moment,
        // friction at the face (below the COM) answers the tilt, and the column leaves the
        // solve leaning: about 2e-4 m/s sideways whatever the iteration count. Solved as a block
        // per face, nothing moves sideways or turns (to round-off).
        let (n, dt, g) = (10, 1e-3, 9.81);
        let (mut bodies, mut c) = column(n, -g * dt);
        solve(&mut bodies, &mut c, dt, &SolverSettings::default());
        for (k, b) in bodies.iter().enumerate().skip(1) {
            let sideways = b.velocity_m_s.truncate().length();
            assert!(sideways < 1e-12, "box {k}: {sideways} m/s sideways");
            assert!(b.omega_rad_s.length() < 1e-10, "box {k}: {}", b.omega_rad_s);
        }
    }

    #[test]
    fn a_tipping_box_lifts_off_one_edge() {
        // A 1 kg, 10 cm cube (I⁻¹ = 600) turning at 1 rad/s about y on its four corners, e = 0,
        // μ = 0: the edge at x = +5 cm comes down at 5 cm/s and the block step would pull on the
        // other edge, so the points fall back to one-by-one steps. The known answer: an impulse
        // P = 0.02 N s on the falling edge (2.5 P = 0.05 m/s), leaving v_z = 0.02 m/s,
        // ω_y = 1 − 30 P = 0.4 rad/s, and nothing on the rising edge. The iterations stop once
        // one moves no point by more than 1e-8 m/s: to within that of the answer (ω at the
        // 5 cm edge: 1e-7 rad/s is 5e-9 m/s).
        let mut b = ball(0.05, 0.0);
        b.inverse_inertia = DMat3::IDENTITY * 600.0;
        b.omega_rad_s = DVec3::Y;
        let mut bodies = [SolverBody::immovable(DVec3::ZERO), b];
        let mut c = on_ground(&CORNERS, 0.0);
        solve(&mut bodies, &mut c, 1e-3, &SolverSettings::default());
        let (v, w) = (bodies[1].velocity_m_s, bodies[1].omega_rad_s);
        assert!(
            (v.z - 0.02).abs() < 1e-8 && (w.y - 0.4).abs() < 1e-7,
            "{v} {w}"
        );
        for p in &c {
            let expected = if p.point_m.x > 0.0 { 0.01 } else { 0.0 };
            assert!((p.normal_impulse - expected).abs() < 1e-8, "{p:?}");
        }
    }

    #[test]
    fn each_contact_of_a_column_carries_the_weight_above_it() {
        // Ten boxes of 1 kg, 10 cm, each on the one below by its four corners, at rest: every
        // substep gravity gives them −g dt, and the contact under box k must carry the 10 − k
        // boxes from it up, (10 − k) g dt, however the four corners share it.
        let (n, dt, g) = (10, 1e-3, 9.81);
        let (mut bodies, mut c) = column(n, -g * dt);
        // Cold, the iterations leave the bottom contact short; warm starting carries the rest
        // over the next substeps, as in the world.
        for _ in 0..10 {
            for b in bodies.iter_mut().skip(1) {
                b.velocity_m_s = DVec3::new(0.0, 0.0, -g * dt);
                b.omega_rad_s = DVec3::ZERO;
            }
            solve(&mut bodies, &mut c, dt, &SolverSettings::default());
        }
        for k in 0..n {
            let load: f64 = c[4 * k..4 * k + 4].iter().map(|p| p.normal_impulse).sum();
            let expected = (n - k) as f64 * g * dt;
            assert!(
                (load - expected).abs() < 1e-3 * expected,
                "box {k}: {load} {expected}"
            );
        }
    }

    /// A spinning bar landing in a V groove at e = 1 (its ends on the groove's two faces, the
    /// normals 42° from vertical): the spin has one end arriving and the other leaving its face;
    /// the first end's bounce drives the second into its face, which bounces it too, and the
    /// bar leaves with more energy than it came with.
    fn spinning_landing(ground_velocity_m_s: DVec3) -> (Vec<SolverBody>, Vec<ContactPoint>) {
        let bar = SolverBody::new(
            DVec3::ZERO,
            DVec3::new(0.0, 0.0, -1.0),
            DVec3::new(0.0, 20.0, 0.0),
            1.0,
            DMat3::IDENTITY * 100.0,
        );
        let ends = [-1.0, 1.0].map(|side: f64| ContactPoint {
            point_m: DVec3::new(0.1 * side, 0.0, 0.0),
            normal: DVec3::new(-0.9 * side, 0.0, 1.0).normalize(),
            friction: 0.0,
            ..ground_contact(1.0, 0.0)
        });
        (
            vec![SolverBody::immovable(ground_velocity_m_s), bar],
            ends.to_vec(),
        )
    }

    #[test]
    fn contact_adds_no_energy_beyond_what_a_driven_body_does() {
        let dt = 1e-3;
        let settings = SolverSettings::default();
        let (bodies, _) = spinning_landing(DVec3::ZERO);
        let before = kinetic_energy_j(&bodies);
        // Without the energy check, the per-point law gains.
        let (mut bodies, mut c) = spinning_landing(DVec3::ZERO);
        sequential_impulses(&mut bodies, &mut c, dt, &settings);
        let unchecked = kinetic_energy_j(&bodies);
        assert!(unchecked > 1.03 * before, "{unchecked} vs {before}");
        // Checked, on a still ground and on one sliding along the groove (frictionless, so it
        // does no work on the bar), the bar leaves with no more than it came with.
        for ground in [DVec3::ZERO, DVec3::new(0.0, 0.5, 0.0)] {
            let (mut bodies, mut c) = spinning_landing(ground);
            solve(&mut bodies, &mut c, dt, &settings);
            let after = kinetic_energy_j(&bodies);
            println!(
                "ground at {ground}: {before:.4} J -> {after:.4} J (unchecked {unchecked:.4} J)"
            );
            assert!(
                after <= before * (1.0 + ENERGY_TOLERANCE),
                "{ground}: {after} vs {before}"
            );
            // It still left the ground.
            assert!(bodies[1].velocity_m_s.z > 0.0);
        }
        // A ground rising under the bar does work on it, each normal impulse times the
        // ground's velocity along its normal: the bound grows by that work (unchecked, the bar
        // gains more than that).
        let ground = DVec3::new(0.0, 0.0, 0.5);
        let work_j = |c: &[ContactPoint]| -> f64 {
            c.iter()
                .map(|c| c.normal_impulse * c.normal.dot(ground))
                .sum()
        };
        let (mut unchecked_bodies, mut c) = spinning_landing(ground);
        sequential_impulses(&mut unchecked_bodies, &mut c, dt, &settings);
        let unchecked = kinetic_energy_j(&unchecked_bodies);
        assert!(unchecked > before * (1.0 + ENERGY_TOLERANCE) + work_j(&c));
        let (mut bodies, mut c) = spinning_landing(ground);
        solve(&mut bodies, &mut c, dt, &settings);
        let work = work_j(&c);
        let after = kinetic_energy_j(&bodies);
        println!("rising ground: {before:.4} J -> {after:.4} J, its work {work:.4} J");
        assert!(
            after <= before * (1.0 + ENERGY_TOLERANCE) + work,
            "{after} vs {before} + {work}"
        );
    }

    #[test]
    fn a_light_box_squeezed_under_a_heavy_one_gains_no_energy_over_the_step() {
        // A 0.5 kg box on a 6.5 g box on the ground, both still, on an 8.3 ms substep; the
        // last substep's impulses (warm start) are three times what holding them takes, as
        // after stopping a sideways throw. The iterations, slow at a mass ratio of 77, leave
        // the heavy box rising: its kinetic energy is below what it came with, but the step
        // (kick, solve, move) gains (`step_energy_j`); solved again, it does not.
        let (dt, g) = (8.3e-3, 9.81);
        let make = || {
            let mut bodies = vec![SolverBody::immovable(DVec3::ZERO)];
            for (mass, z) in [(0.0065, 0.01), (0.5, 0.05)] {
                let mut b = SolverBody::new(
                    DVec3::new(0.0, 0.0, z),
                    DVec3::new(0.0, 0.0, -g * dt),
                    DVec3::ZERO,
                    1.0 / mass,
                    DMat3::IDENTITY / (mass * 1e-3),
                );
                b.external_m_s = DVec3::new(0.0, 0.0, -g * dt);
                bodies.push(b);
            }
            let mut contacts = Vec::new();
            for (a, b, z, load_kg) in [(0, 1, 0.0, 0.5065), (1, 2, 0.02, 0.5)] {
                for (x, y) in [(-0.01, -0.01), (0.01, -0.01), (-0.01, 0.01), (0.01, 0.01)] {
                    contacts.push(ContactPoint {
                        a,
                        b,
                        point_m: DVec3::new(x, y, z),
                        lasting: true,
                        normal_impulse: 3.0 * load_kg * g * dt / 4.0,
                        ..ground_contact(0.0, 0.0)
                    });
                }
            }
            (bodies, contacts)
        };
        let settings = SolverSettings::default();
        let (start, _) = make();
        let allowed = step_energy_j(&start) * (1.0 + ENERGY_TOLERANCE)
            + external_energy_j(&start) * (1.0 + EXTERNAL_TOLERANCE);
        let (mut unchecked, mut c) = make();
        sequential_impulses(&mut unchecked, &mut c, dt, &settings);
        assert!(kinetic_energy_j(&unchecked) < kinetic_energy_j(&start));
        assert!(step_energy_j(&unchecked) > 2.0 * allowed);
        let (mut bodies, mut c) = make();
        solve(&mut bodies, &mut c, dt, &settings);
        let after = step_energy_j(&bodies);
        assert!(after <= allowed, "{after} J vs {allowed} J");
    }

    #[test]
    fn rolling_resistance_slows_a_rolling_ball_at_five_sevenths_g_b_over_r() {
        // A 1 kg ball of radius 0.5 m (I = 2/5 m R² = 0.1 kg m²) rolling at 1 m/s on the
        // ground, one contact below its COM, b = 0.05 m: a = b m g R / (I + m R²) =
        // (5/7) g b / R = 0.7007 m/s², and it keeps rolling (v = ω R). Without b it keeps its
        // speed.
        let (radius, g, dt) = (0.5, 9.81, 1e-3);
        for b in [0.05, 0.0] {
            let mut bodies = [SolverBody::immovable(DVec3::ZERO), ball(radius, 0.0)];
            bodies[1].velocity_m_s.x = 1.0;
            bodies[1].omega_rad_s.y = 1.0 / radius;
            let settings = SolverSettings {
                resting_speed_m_s: 2.0 * g * dt,
                push_iterations: 0,
                ..SolverSettings::default()
            };
            for _ in 0..200 {
                bodies[1].velocity_m_s.z -= g * dt;
                let mut c = vec![ContactPoint {
                    point_m: DVec3::new(bodies[1].com_m.x, 0.0, 0.0),
                    rolling_resistance_m: b,
                    ..ground_contact(0.0, 0.0)
                }];
                solve(&mut bodies, &mut c, dt, &settings);
                bodies[1].com_m.x += bodies[1].velocity_m_s.x * dt;
            }
            let v = bodies[1].velocity_m_s.x;
            let expected = 1.0 - 5.0 / 7.0 * g * b / radius * 0.2;
            assert!(
                (v - expected).abs() < 1e-3,
                "b = {b}: {v} against {expected}"
            );
            assert!((bodies[1].omega_rad_s.y * radius - v).abs() < 1e-6);
        }
    }
}
