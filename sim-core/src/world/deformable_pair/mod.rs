//! Contact between two deformable objects (method `com`): the paper's stage 2 (eqs. 3-6), an
//! impulse law at the COM level, applied per contact patch (docs/design/com-layer.md maps one to the
//! other).
//!
//! Broad phase: bounding spheres (eq. 3: |c_i - c_j| <= r_i + r_j) and boxes. Narrow phase
//! ([`narrow`]): the overlap of the two objects' occupied grid cells, grouped into patches of at
//! most 5 cells across. Each patch has its own contact zone (each object's particles in its
//! cells), contact point and normal n (from A to B): from the midpoint of the two zones'
//! centroids, each object's outward normal there (the least-variance direction of its particles
//! within 3 cells) and curvature, combined so that the flatter surface decides the normal and
//! the point lies where the two surfaces' osculating spheres touch. So a plank across a trough,
//! a peg against both sides of a hole, or any non-convex pair gets one normal per place of
//! contact rather than one for the whole pair; a head-on impact of two spheres is one patch on
//! the axis.
//!
//! Response ([`law`]): the patches of a pair are solved together by sequential impulses (Catto
//! 2005) on the two objects' rigid-level dynamics, 8 sweeps over the patches, each with an
//! accumulated, clamped normal impulse (λ >= 0) and Coulomb friction in an isotropic cone
//! (|j_t| <= μ λ). A patch approaching faster than 2 g dt is an impact and its target is the
//! restitution law's separation speed −e v_n (for a single patch this is the impulse law
//! j_n = −(1 + e) v_n / k_n); a slower one is resting contact with target 0 and, where the
//! patch's footprint is flat (two faces, not a ball on a slab, which rolls), a couple that keeps
//! the relative spin at zero with its pressure centre inside the footprint. Every
//! patch's impulse J (on B, −J on A) acts at its point, so linear and angular momentum are both
//! conserved; the particles receive all of a body's patch impulses at once through
//! [`super::coherence::apply_contact_impulses`], each patch's zone kick on its own particles.
//!
//! Resting patches are warm-started: the impulse a resting patch needed in one substep is
//! applied again at the start of the next, before P2G, so the load reaches the grids in the
//! velocities the positions are advanced with, and a grid boundary under the lower object takes
//! it. The end-of-substep solve then only corrects it (it may pull back, down to zero normal
//! impulse). Without it, the impulse arrives after the positions moved and a resting object
//! sinks into the one below by g dt² per substep (g dt per second: 2.6 mm/s at dt = 0.27 ms).
//! A warm impulse counts towards the clamped total of the patch nearest to where it acted.

mod law;
mod narrow;

use std::collections::BTreeMap;

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use super::body::Body;
use super::coherence::{self, Kick};
use super::measure::{BodyState, RigidFit, measure_with_fit};
use super::{Env, WorldStats};
use crate::contact::SolverBody;
use crate::contact::{mix_friction, mix_restitution};
use crate::scene::{Method, ObjectKind};
use law::{Accumulated, PatchLaw, patch_impulse};
use narrow::{broad_phase, narrow_phase};

/// The most sequential-impulse sweeps over a pair's patches per substep (Box2D's default
/// velocity iterations); a single patch is solved by the first, and a second finds nothing left.
const ITERATIONS: usize = 8;

/// A resting patch's impulse over one substep, applied again at the start of the next (warm
/// starting; module docs).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct RestingPatch {
    /// Body index of A.
    pub a: usize,
    /// Body index of B (> a).
    pub b: usize,
    /// Accumulated impulse on B (−it on A) over a substep of `dt_s`.
    pub impulse: Accumulated,
    /// The substep it was accumulated over (s); a substep of another length scales it.
    pub dt_s: f64,
    /// Where it acts (m).
    pub point_m: DVec3,
    /// A's particles in the patch's cells.
    pub zone_a: Vec<u32>,
    /// B's particles in the patch's cells.
    pub zone_b: Vec<u32>,
}

/// The kicks on A and B of a patch's impulse `c` (on B; −it on A) at `point` (m), their zones
/// `zones`.
fn pair_kicks(c: Accumulated, point: DVec3, zones: [&[u32]; 2]) -> [Kick<'_>; 2] {
    [(-1.0, zones[0]), (1.0, zones[1])].map(|(sign, zone)| Kick {
        impulse_n_s: c.linear_n_s * sign,
        couple_n_m_s: c.angular_n_m_s * sign,
        point_m: point,
        zone,
    })
}

/// Applies the resting patches of the last substep (`patches`), their impulses scaled to `dt`
/// (s), to `bodies` before this substep's MPM step (module docs), all of a body's at once. Only
/// for method `com`.
pub(in crate::world) fn warm_start(bodies: &mut [Body], patches: &[RestingPatch], dt: f64) {
    let pairs = patches;
    let mut by_body: BTreeMap<usize, Vec<Kick<'_>>> = BTreeMap::new();
    for p in pairs {
        let c = p.impulse.scaled(dt / p.dt_s);
        let [on_a, on_b] = pair_kicks(c, p.point_m, [&p.zone_a, &p.zone_b]);
        by_body.entry(p.a).or_default().push(on_a);
        by_body.entry(p.b).or_default().push(on_b);
    }
    for (k, kicks) in &by_body {
        kick_deformable(bodies, *k, kicks, None);
    }
}

/// Applies `kicks` to deformable body `k` when it is awake. A kick whose zone names
/// particles the body no longer has (a command changed them since) is dropped.
/// `measured` is the body's state and rigid fit when the caller has them for its particles
/// as they are.
fn kick_deformable(
    bodies: &mut [Body],
    k: usize,
    kicks: &[Kick<'_>],
    measured: Option<(BodyState, RigidFit)>,
) {
    let Some(b) = bodies.get_mut(k) else {
        return;
    };
    b.leave_device();
    let n = b.particles.len() as u32;
    if b.sleeping || kicks.is_empty() {
        return;
    }
    let valid = |kick: &Kick<'_>| kick.zone.iter().all(|&i| i < n);
    let kept: Vec<Kick<'_>>;
    let kicks = if kicks.iter().all(valid) {
        kicks
    } else {
        kept = kicks.iter().filter(|k| valid(k)).copied().collect();
        &kept
    };
    b.stats.impulse_total_n_s += kicks.iter().map(|k| k.impulse_n_s.length()).sum::<f64>();
    coherence::apply_contact_impulses(b, kicks, measured);
}

/// Every pair of deformable objects of `bodies`, one of them awake, through the broad and
/// narrow phase; the patches of a pair in contact get the impulse law's impulses (module docs),
/// warm-started from and kept in `resting_patches`. Only for method `com`: the baselines couple
/// deformable objects on their grids.
pub(in crate::world) fn resolve(
    env: &Env,
    bodies: &mut [Body],
    resting_patches: &mut Vec<RestingPatch>,
    stats: &mut WorldStats,
    dt: f64,
) {
    if env.settings.method != Method::Com {
        return;
    }
    let ids: Vec<usize> = (0..bodies.len())
        .filter(|&k| bodies[k].kind == ObjectKind::Deformable && env.stepping(k))
        .collect();
    if ids.len() < 2 {
        return;
    }
    let resting = 2.0 * env.gravity_m_s2.length() as f64 * dt;
    // Bounds for the broad phase (one pass per object); the full state (inertia, angular
    // momentum) only for objects of a pair that passes it, once per substep.
    let bounds: Vec<BodyState> = ids
        .par_iter()
        .map(|&k| bodies[k].measured_bounds())
        .collect();
    // The narrow phase and the impulses read the particles of both objects of a pair that
    // passes the broad phase: from the host.
    for x in 0..ids.len() {
        for y in x + 1..ids.len() {
            let dx = bodies[ids[x]].dx_m().max(bodies[ids[y]].dx_m());
            if broad_phase(&bounds[x], &bounds[y], dx as f64) {
                bodies[ids[x]].leave_device();
                bodies[ids[y]].leave_device();
            }
        }
    }
    let warm = std::mem::take(resting_patches);
    // Each object's state and rigid fit, as its particles are now (None once an impulse
    // changed them).
    let mut full: Vec<Option<(BodyState, RigidFit)>> = vec![None; ids.len()];
    for x in 0..ids.len() {
        for y in x + 1..ids.len() {
            let (i, j) = (ids[x], ids[y]);
            let (bi, bj) = (&bodies[i], &bodies[j]);
            // Objects on grids of different cells meet at the coarser one's.
            let dx = bi.dx_m().max(bj.dx_m());
            if !(bi.is_active() || bj.is_active())
                || !broad_phase(&bounds[x], &bounds[y], dx as f64)
            {
                continue;
            }
            for (z, k) in [(x, i), (y, j)] {
                if full[z].is_none() {
                    let b = &bodies[k];
                    full[z] = Some(measure_with_fit(&b.particles, b.dx_m()));
                }
            }
            let (Some((si, fit_i)), Some((sj, fit_j))) = (full[x], full[y]) else {
                continue;
            };
            let Some(manifold) = narrow_phase(bi, &si, bj, &sj, dx) else {
                continue;
            };
            let moving = [bi.is_moving(), bj.is_moving()];
            bodies[i].stats.contacts += 1;
            bodies[j].stats.contacts += 1;
            for (k, other_moving) in [(i, moving[1]), (j, moving[0])] {
                if bodies[k].sleeping && other_moving {
                    bodies[k].wake_on_contact();
                }
            }
            let warm_here: Vec<&RestingPatch> =
                warm.iter().filter(|w| (w.a, w.b) == (i, j)).collect();
            let solved = solve_pair(
                [&bodies[i], &bodies[j]],
                [&si, &sj],
                &manifold,
                &warm_here,
                dt,
                resting,
            );
            let (mut on_a, mut on_b) = (Vec::new(), Vec::new());
            for (c, p) in solved.changes.iter().zip(&manifold.patches) {
                if *c != Accumulated::default() {
                    let [ka, kb] = pair_kicks(*c, p.point_m, [&p.zone_a, &p.zone_b]);
                    on_a.push(ka);
                    on_b.push(kb);
                }
            }
            if !on_a.is_empty() {
                stats.contact_impulses += on_a.len() as u64;
                kick_deformable(bodies, i, &on_a, Some((si, fit_i)));
                kick_deformable(bodies, j, &on_b, Some((sj, fit_j)));
                // Their velocities changed: a later pair re-measures them.
                full[x] = None;
                full[y] = None;
            }
            let both_asleep = bodies[i].sleeping && bodies[j].sleeping;
            for (p, (total, rests)) in manifold
                .patches
                .into_iter()
                .zip(solved.totals.into_iter().zip(solved.resting))
            {
                if rests && total.linear_n_s.dot(p.normal) > 0.0 && !both_asleep {
                    resting_patches.push(RestingPatch {
                        a: i,
                        b: j,
                        impulse: total,
                        dt_s: dt,
                        point_m: p.point_m,
                        zone_a: p.zone_a,
                        zone_b: p.zone_b,
                    });
                }
            }
        }
    }
}

/// Solves the patches of the pair `pair` [A, B] (states `states`) together: at most 8
/// sequential-impulse sweeps on their rigid-level dynamics (module docs), starting from the
/// warm impulses `warm` already applied this substep, each counted in the patch nearest to
/// it.
fn solve_pair(
    pair: [&Body; 2],
    states: [&BodyState; 2],
    manifold: &narrow::Manifold,
    warm: &[&RestingPatch],
    dt: f64,
    resting_speed_m_s: f64,
) -> Solved {
    let [bi, bj] = pair;
    // Each object as a rigid body; a sleeping one is an immovable support.
    let dynamics = |b: &Body, s: &BodyState| {
        if b.sleeping {
            return SolverBody::new(s.com_m, DVec3::ZERO, DVec3::ZERO, 0.0, DMat3::ZERO);
        }
        SolverBody::new(
            s.com_m,
            s.velocity_m_s,
            s.angular_velocity(),
            b.inverse_mass(s),
            b.inverse_inertia(s),
        )
    };
    let (mut da, mut db) = (dynamics(bi, states[0]), dynamics(bj, states[1]));
    let e = mix_restitution(bi.restitution, bj.restitution) as f64;
    let mu = mix_friction(bi.friction, bj.friction) as f64;
    let patches = &manifold.patches;
    let approach: Vec<f64> = patches
        .iter()
        .map(|p| {
            let v_rel = db.velocity_at(p.point_m - db.com_m) - da.velocity_at(p.point_m - da.com_m);
            v_rel.dot(p.normal)
        })
        .collect();
    let resting: Vec<bool> = approach.iter().map(|&v| v >= -resting_speed_m_s).collect();
    let footprints = resting
        .iter()
        .any(|&r| r)
        .then(|| manifold.footprints(bi, bj));
    let mut start = vec![Accumulated::default(); patches.len()];
    for w in warm {
        let nearest = (0..patches.len()).min_by(|&p, &q| {
            let d = |k: usize| (patches[k].point_m - w.point_m).length_squared();
            d(p).total_cmp(&d(q))
        });
        if let Some(k) = nearest {
            start[k] = start[k].plus(w.impulse.scaled(dt / w.dt_s));
        }
    }
    let mut totals = start.clone();
    for _ in 0..ITERATIONS {
        let mut changed = false;
        for (k, p) in patches.iter().enumerate() {
            let law = PatchLaw {
                point_m: p.point_m,
                normal: p.normal,
                target_vn_m_s: if resting[k] { 0.0 } else { -e * approach[k] },
                friction: mu,
                footprint: footprints.as_ref().filter(|_| resting[k]).map(|f| &f[k]),
            };
            if let Some(d) = patch_impulse(&da, &db, &law, totals[k]) {
                da.apply(p.point_m - da.com_m, -d.linear_n_s);
                da.apply_angular(-d.angular_n_m_s);
                db.apply(p.point_m - db.com_m, d.linear_n_s);
                db.apply_angular(d.angular_n_m_s);
                totals[k] = totals[k].plus(d);
                // Converged when no patch changes by more than a millionth of its total.
                let size = |a: Accumulated| a.linear_n_s.length() + a.angular_n_m_s.length();
                changed |= size(d) > 1e-6 * size(totals[k]);
            }
        }
        if !changed {
            break;
        }
    }
    let changes = totals
        .iter()
        .zip(&start)
        .map(|(t, s)| t.plus(s.scaled(-1.0)))
        .collect();
    Solved {
        changes,
        totals,
        resting,
    }
}

/// A pair's patches after [`solve_pair`], in the manifold's order.
struct Solved {
    /// The impulse each patch adds this substep (on B; −it on A).
    changes: Vec<Accumulated>,
    /// Each patch's accumulated impulse over the substep, warm part included.
    totals: Vec<Accumulated>,
    /// Whether each patch is resting contact (else an impact).
    resting: Vec<bool>,
}
