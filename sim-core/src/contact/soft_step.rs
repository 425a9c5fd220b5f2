//! The soft step: a substep's contacts solved over a few smaller substeps with one soft
//! iteration and one relaxing iteration each (Catto, "Solver2D" 2024 and Box2D v3's
//! `b2SolverStep`; the TGS of rapier and of Macklin et al., "Small Steps in Physics
//! Simulation", SCA 2019).
//!
//! For a substep of dt the solver takes n = [`SolverSettings::substeps`] steps of h = dt / n.
//! Each one:
//!
//! 1. adds the bodies' external velocity change for h (gravity: [`SolverBody::external_m_s`]
//!    is spread over the steps instead of taken at once);
//! 2. warm starts: applies every point's and patch's impulse of the step before (the first
//!    step: the last substep's, divided by n);
//! 3. solves once with the soft bias: per point, the separation is the manifold's plus the
//!    bodies' motion since the substep began (anchors fixed on the bodies), s = s₀ +
//!    n·(Δp_B + ΔR_B r_B − r_B − Δp_A − ΔR_A r_A + r_A). A gap (s > 0) may close within the
//!    step, v_n ≥ −s/h (speculative contact); a penetration is pushed out by a soft constraint
//!    of stiffness ω = 2π f and damping ratio ζ (Box2D's `b2MakeSoft`): the impulse
//!    −m_n (s_m v_n + s_m b s) − s_i P with b = ω / (2ζ + hω), s_m = a₂ / (1 + a₂),
//!    s_i = 1 / (1 + a₂), a₂ = hω (2ζ + hω), the push-out speed bounded by
//!    [`SolverSettings::max_push_m_s`]; then the patch friction ([`super::patch`]);
//! 4. moves the bodies by their velocities over h (kept as Δp, ΔR);
//! 5. relaxes: the same iteration without the bias, so the push-out leaves no velocity behind.
//!
//! After the n steps one restitution pass gives an impact (approach faster than
//! [`SolverSettings::resting_speed_m_s`] at the start that took an impulse, of a pair that
//! carried none in the last substep) −e times its approach speed before the substep's gravity,
//! plus that gravity (the bounce first, then the substep's fall). A body's motion over the
//! substep is returned as velocity plus a pseudo-velocity (Δp/dt − v), which the world's
//! position half integrates.
//!
//! The soft constraint leaves a resting contact pressed by a load F into depth F / (m_n ω²)
//! (m_n its effective mass); f is a quarter of the step rate 1/h (Box2D's bound for
//! stability), twice that against immovable bodies (Box2D's static softness), so depth falls
//! with h²: [`SolverSettings::slop_m`] is left alone on top.

use glam::{DQuat, DVec3};

use super::block::MAX_BLOCK;
use super::patch::{ContactPatch, patches, share_friction};
use super::rows::{ContactPoint, Row, SolverBody, apply_pair, effective, relative};
use super::settings::SolverSettings;

/// Box2D's soft-constraint coefficients for a step of `h_s` (s): (bias rate b (1/s), mass
/// scale s_m, impulse scale s_i). A frequency of zero is a hard constraint.
fn soft(hertz: f64, damping_ratio: f64, h_s: f64) -> (f64, f64, f64) {
    if hertz.is_nan() || hertz <= 0.0 {
        return (0.0, 1.0, 0.0);
    }
    let omega = std::f64::consts::TAU * hertz;
    let a1 = 2.0 * damping_ratio + h_s * omega;
    let a2 = h_s * omega * a1;
    let a3 = 1.0 / (1.0 + a2);
    (omega / a1, a2 * a3, a3)
}

/// Per-point constants of the soft step.
struct Point {
    /// Separation at the start of the substep, less the anchors' offset along the normal (m).
    base_separation_m: f64,
    /// Normal velocity at the start (m/s), for restitution.
    approach_m_s: f64,
    /// It or its pair carried a normal impulse in the last substep: lasting contact, which
    /// takes no restitution.
    lasting: bool,
    /// Soft coefficients of its pair (bias rate, mass scale, impulse scale).
    soft: (f64, f64, f64),
    /// Normal impulse applied over the whole substep so far (N s).
    total_n_s: f64,
}

/// The solver's motion of one body since the substep began.
#[derive(Clone, Copy)]
struct Motion {
    dp_m: DVec3,
    dq: DQuat,
}

fn moved(m: &Motion, r: DVec3) -> DVec3 {
    m.dp_m + (m.dq * r - r)
}

/// The soft step of `contacts` on `bodies` over `dt_s` (module docs). On return each point
/// holds its normal impulse over the substep, each patch its friction over the substep, each
/// body its new velocities and, as pseudo-velocities, the rest of its motion.
pub(super) fn solve(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactPoint],
    dt_s: f64,
    settings: &SolverSettings,
) -> Vec<ContactPatch> {
    let n = settings.substeps.max(1);
    let h = dt_s / n as f64;
    let hertz = settings.contact_hertz.min(0.25 / h);
    let moving = soft(hertz, settings.damping_ratio, h);
    let against_immovable = soft(2.0 * hertz, settings.damping_ratio, h);
    // Bodies that take part: only they have gravity spread over the steps.
    let mut involved = vec![false; bodies.len()];
    let mut rows: Vec<Row> = Vec::with_capacity(contacts.len());
    let mut points: Vec<Point> = Vec::with_capacity(contacts.len());
    for c in contacts.iter_mut() {
        let ra = c.point_m - bodies[c.a].com_m;
        let rb = c.point_m - bodies[c.b].com_m;
        let k_n = effective(bodies, c.a, c.b, ra, rb, c.normal, c.normal);
        if !(k_n > 0.0 && k_n.is_finite()) {
            c.normal_impulse = 0.0;
            c.tangent_impulse = DVec3::ZERO;
            c.twist_impulse = 0.0;
        }
        points.push(Point {
            base_separation_m: c.separation_m,
            approach_m_s: relative(bodies, c.a, c.b, ra, rb).dot(c.normal),
            lasting: c.lasting || c.normal_impulse > 0.0,
            soft: if bodies[c.a].is_immovable() || bodies[c.b].is_immovable() {
                against_immovable
            } else {
                moving
            },
            total_n_s: 0.0,
        });
        involved[c.a] = true;
        involved[c.b] = true;
        // The last substep's impulse is this step's warm start.
        c.normal_impulse /= n as f64;
        c.tangent_impulse /= n as f64;
        c.twist_impulse /= n as f64;
        rows.push(Row::new(ra, rb, k_n));
    }
    for (b, &take_part) in bodies.iter_mut().zip(&involved) {
        if take_part {
            b.velocity_m_s -= b.external_m_s;
        }
    }
    let mut patches = patches(bodies, contacts, &mut rows, settings.blocks);
    let mut motion = vec![
        Motion {
            dp_m: DVec3::ZERO,
            dq: DQuat::IDENTITY,
        };
        bodies.len()
    ];
    let mut friction_total: Vec<(DVec3, f64)> = vec![(DVec3::ZERO, 0.0); patches.len()];
    for _ in 0..n {
        for (b, &take_part) in bodies.iter_mut().zip(&involved) {
            if take_part {
                b.velocity_m_s += b.external_m_s / n as f64;
            }
        }
        for (c, row) in contacts.iter().zip(&rows) {
            apply_pair(
                bodies,
                c.a,
                c.b,
                row.ra,
                row.rb,
                c.normal * c.normal_impulse,
            );
        }
        for patch in &patches {
            patch.warm_start_friction(bodies);
        }
        iterate(
            bodies,
            contacts,
            &rows,
            &points,
            &motion,
            &mut patches,
            h,
            settings,
            true,
        );
        for (m, b) in motion.iter_mut().zip(bodies.iter()) {
            m.dp_m += b.velocity_m_s * h;
            if b.omega_rad_s != DVec3::ZERO {
                m.dq = (DQuat::from_scaled_axis(b.omega_rad_s * h) * m.dq).normalize();
            }
        }
        iterate(
            bodies,
            contacts,
            &rows,
            &points,
            &motion,
            &mut patches,
            h,
            settings,
            false,
        );
        for (p, c) in points.iter_mut().zip(contacts.iter()) {
            p.total_n_s += c.normal_impulse;
        }
        for (t, patch) in friction_total.iter_mut().zip(&patches) {
            t.0 += patch.tangent_impulse;
            t.1 += patch.twist_impulse;
        }
    }
    restitution(bodies, contacts, &rows, &mut points, settings);
    for (c, p) in contacts.iter_mut().zip(&points) {
        c.normal_impulse = p.total_n_s;
    }
    for (patch, (t, twist)) in patches.iter_mut().zip(friction_total) {
        patch.tangent_impulse = t;
        patch.twist_impulse = twist;
    }
    share_friction(contacts, &patches);
    // The motion the velocities do not account for becomes the push-out pseudo-velocities.
    for ((b, m), &take_part) in bodies.iter_mut().zip(&motion).zip(&involved) {
        if take_part && !b.is_immovable() {
            b.push_m_s = m.dp_m / dt_s - b.velocity_m_s;
            b.push_rad_s = m.dq.to_scaled_axis() / dt_s - b.omega_rad_s;
        }
    }
    patches
}

/// One pass over the patches: normal impulses (soft with `bias`, else relaxing), then friction.
#[allow(clippy::too_many_arguments)]
fn iterate(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactPoint],
    rows: &[Row],
    points: &[Point],
    motion: &[Motion],
    patches: &mut [ContactPatch],
    h_s: f64,
    settings: &SolverSettings,
    bias: bool,
) {
    for patch in patches.iter_mut() {
        let mut laws = [Law::default(); MAX_BLOCK];
        for (law, &i) in laws.iter_mut().zip(&patch.points) {
            let (c, row, p) = (&contacts[i], &rows[i], &points[i]);
            let ds = moved(&motion[c.b], row.rb) - moved(&motion[c.a], row.ra);
            let s = p.base_separation_m + ds.dot(c.normal);
            if s > 0.0 {
                law.velocity_bias = s / h_s;
            } else if bias {
                let (rate, ms, is) = p.soft;
                let depth = (s + settings.slop_m).min(0.0);
                law.velocity_bias = (ms * rate * depth).max(-settings.max_push_m_s);
                (law.mass_scale, law.impulse_scale) = (ms, is);
            }
        }
        let len = patch.points.len();
        let uniform = laws[..len].iter().all(|l| {
            (l.mass_scale, l.impulse_scale) == (laws[0].mass_scale, laws[0].impulse_scale)
        });
        if !(uniform && solve_block(bodies, contacts, rows, patch, &laws)) {
            for (law, &i) in laws.iter().zip(&patch.points) {
                let (c, row) = (&mut contacts[i], &rows[i]);
                if !(row.k_n > 0.0 && row.k_n.is_finite()) {
                    continue;
                }
                let vn = relative(bodies, c.a, c.b, row.ra, row.rb).dot(c.normal);
                let step = -(law.mass_scale * vn + law.velocity_bias) / row.k_n
                    - law.impulse_scale * c.normal_impulse;
                let total = (c.normal_impulse + step).max(0.0);
                let delta = total - c.normal_impulse;
                c.normal_impulse = total;
                apply_pair(bodies, c.a, c.b, row.ra, row.rb, c.normal * delta);
            }
        }
        patch.solve_friction(bodies, contacts, rows);
    }
}

/// A point's normal law in one iteration: impulse −(s_m v_n + bias) / k − s_i P.
#[derive(Clone, Copy)]
struct Law {
    velocity_bias: f64,
    mass_scale: f64,
    impulse_scale: f64,
}

impl Default for Law {
    fn default() -> Self {
        Self {
            velocity_bias: 0.0,
            mass_scale: 1.0,
            impulse_scale: 0.0,
        }
    }
}

/// The patch's normal impulses in one block step (`super::block`), the soft law applied to the
/// block: Δλ = −K⁺ (s_m v_n + bias) − s_i λ; `false`, with nothing changed, when the patch has
/// no block or an impulse would turn negative (the points then step one by one).
fn solve_block(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactPoint],
    rows: &[Row],
    patch: &ContactPatch,
    laws: &[Law; MAX_BLOCK],
) -> bool {
    let Some(block) = patch.block() else {
        return false;
    };
    let mut residual = [0.0; MAX_BLOCK];
    for ((r, law), &i) in residual.iter_mut().zip(laws).zip(&patch.points) {
        let (c, row) = (&contacts[i], &rows[i]);
        let vn = relative(bodies, c.a, c.b, row.ra, row.rb).dot(c.normal);
        *r = -(law.mass_scale * vn + law.velocity_bias);
    }
    let mut step = block.step(&residual);
    for ((d, law), &i) in step.iter_mut().zip(laws).zip(&patch.points) {
        *d -= law.impulse_scale * contacts[i].normal_impulse;
        if contacts[i].normal_impulse + *d < 0.0 {
            return false;
        }
    }
    for (&i, d) in patch.points.iter().zip(step) {
        let (c, row) = (&mut contacts[i], &rows[i]);
        c.normal_impulse += d;
        apply_pair(bodies, c.a, c.b, row.ra, row.rb, c.normal * d);
    }
    true
}

/// Restitution after the steps (Box2D's `b2ApplyRestitution`): a point that approached faster
/// than the resting speed and took an impulse leaves at −e times its approach speed; the
/// passes repeat (at most [`SolverSettings::iterations`]) until they change no velocity by
/// more than [`SolverSettings::converged_m_s`], so a face landing flat on several points
/// bounces as a whole.
fn restitution(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactPoint],
    rows: &[Row],
    points: &mut [Point],
    settings: &SolverSettings,
) {
    let bouncing: Vec<usize> = (0..contacts.len())
        .filter(|&i| {
            let (c, p, row) = (&contacts[i], &points[i], &rows[i]);
            c.restitution > 0.0
                && !p.lasting
                && -p.approach_m_s > settings.resting_speed_m_s
                && p.total_n_s > 0.0
                && row.k_n > 0.0
                && row.k_n.is_finite()
        })
        .collect();
    for _ in 0..settings.iterations.max(1) {
        let mut largest = 0.0f64;
        for &i in &bouncing {
            let (c, row, p) = (&mut contacts[i], &rows[i], &mut points[i]);
            let vn = relative(bodies, c.a, c.b, row.ra, row.rb).dot(c.normal);
            // The approach before the substep's external forces, reflected; they then act on
            // the rebound (as in the sequential-impulse solver).
            let external = (bodies[c.b].external_m_s - bodies[c.a].external_m_s).dot(c.normal);
            let target = -c.restitution * (p.approach_m_s - external) + external;
            let total = (c.normal_impulse + (target - vn) / row.k_n).max(0.0);
            let delta = total - c.normal_impulse;
            c.normal_impulse = total;
            p.total_n_s += delta;
            largest = largest.max((delta * row.k_n).abs());
            apply_pair(bodies, c.a, c.b, row.ra, row.rb, c.normal * delta);
        }
        if largest <= settings.converged_m_s {
            break;
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::DMat3;

    use super::*;
    use crate::contact::ContactSolver;

    fn settings() -> SolverSettings {
        SolverSettings {
            scheme: ContactSolver::SoftStep,
            ..SolverSettings::default()
        }
    }

    /// Ground (body 0) and a 1 kg ball of radius 5 cm (body 1) at height `z_m`, its one contact
    /// point straight below.
    fn ball_on_ground(z_m: f64, vz_m_s: f64, e: f64) -> (Vec<SolverBody>, ContactPoint) {
        let ball = SolverBody::new(
            DVec3::new(0.0, 0.0, z_m),
            DVec3::new(0.0, 0.0, vz_m_s),
            DVec3::ZERO,
            1.0,
            DMat3::IDENTITY * 1000.0,
        );
        let contact = ContactPoint {
            a: 0,
            b: 1,
            point_m: DVec3::new(0.0, 0.0, z_m - 0.05),
            normal: DVec3::Z,
            separation_m: z_m - 0.05,
            restitution: e,
            friction: 0.5,
            rolling_resistance_m: 0.0,
            normal_impulse: 0.0,
            lasting: false,
            tangent_impulse: DVec3::ZERO,
            twist_impulse: 0.0,
        };
        (vec![SolverBody::immovable(DVec3::ZERO), ball], contact)
    }

    #[test]
    fn an_impact_leaves_at_e_times_its_approach_speed() {
        for e in [0.0, 0.5, 1.0] {
            let (mut bodies, c) = ball_on_ground(0.05, -2.0, e);
            solve(&mut bodies, &mut [c], 1e-3, &settings());
            let v = bodies[1].velocity_m_s.z;
            assert!((v - 2.0 * e).abs() < 1e-9, "e = {e}: {v}");
        }
    }

    #[test]
    fn an_impact_reflects_the_approach_before_the_substep_gravity() {
        // Arriving at u with the substep's g dt already in its velocity: it leaves at e u − g dt.
        let (dt, g, u) = (8.3e-3, 9.81, 0.5);
        for e in [0.25, 0.5, 1.0] {
            let (mut bodies, c) = ball_on_ground(0.05, -u - g * dt, e);
            bodies[1].external_m_s = DVec3::new(0.0, 0.0, -g * dt);
            solve(&mut bodies, &mut [c], dt, &settings());
            let v = bodies[1].velocity_m_s.z;
            assert!((v - (e * u - g * dt)).abs() < 1e-9, "e = {e}: {v}");
        }
    }

    #[test]
    fn a_gap_closes_within_the_substep_but_is_not_overshot() {
        // 3 m/s towards the ground from 1 mm away over 1 ms: it would travel 3 mm.
        let (dt, gap) = (1e-3, 1e-3);
        let (mut bodies, c) = ball_on_ground(0.05 + gap, -3.0, 0.0);
        solve(&mut bodies, &mut [c], dt, &settings());
        let b = &bodies[1];
        let travel = -(b.velocity_m_s.z + b.push_m_s.z) * dt;
        assert!(travel > 0.0 && travel <= gap + 1e-12, "{travel}");
        // Far away, nothing acts.
        let (mut bodies, c) = ball_on_ground(0.1, -0.5, 0.0);
        solve(&mut bodies, &mut [c], dt, &settings());
        assert_eq!(bodies[1].velocity_m_s.z, -0.5);
    }

    #[test]
    fn a_resting_ball_sinks_to_the_soft_contacts_depth_and_carries_its_weight() {
        // A soft contact pressed by the weight m g settles where the spring ω² holds it:
        // depth = slop + g / ω², with ω = 2π (2 f) against the immovable ground (Box2D's
        // static softness), f = min(contact_hertz, 1 / (4 h)).
        let (dt, g) = (1e-3, 9.81);
        let s = settings();
        let h = dt / s.substeps as f64;
        let omega = std::f64::consts::TAU * 2.0 * s.contact_hertz.min(0.25 / h);
        let expected = s.slop_m + g / (omega * omega);
        let (mut bodies, _) = ball_on_ground(0.05, 0.0, 0.0);
        let mut warm = 0.0;
        let mut load = 0.0;
        for _ in 0..2000 {
            let b = &mut bodies[1];
            b.velocity_m_s.z -= g * dt;
            b.external_m_s = DVec3::new(0.0, 0.0, -g * dt);
            let z = b.com_m.z;
            let (_, mut c) = ball_on_ground(z, 0.0, 0.0);
            c.normal_impulse = warm;
            let mut cs = [c];
            solve(&mut bodies, &mut cs, dt, &s);
            warm = cs[0].normal_impulse;
            load = warm;
            let b = &mut bodies[1];
            b.com_m += (b.velocity_m_s + b.push_m_s) * dt;
        }
        let depth = 0.05 - bodies[1].com_m.z;
        assert!(
            (depth - expected).abs() < 0.02 * expected,
            "{depth} against {expected}"
        );
        assert!((load - g * dt).abs() < 1e-6 * g * dt, "{load}");
        assert!(bodies[1].velocity_m_s.length() < 1e-9);
    }
}
