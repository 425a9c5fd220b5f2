//! The world's contact pass, once per substep after the velocity half of the rigid step
//! ([`crate::contact`] says which pairs come here and which are grid boundaries).
//!
//! 1. Manifolds: rigid, static and kinematic objects against each other (pairs with a rigid
//!    object in them), and rigid objects against the
//!    grid colliders and the captured background, on their surfaces
//!    ([`crate::contact::manifold`]).
//! 2. One solve of all points ([`crate::contact::solver`]), warm-started from the previous
//!    substep's impulses of the nearest point of the same pair ([`ContactCache`]).
//! 3. Rigid objects keep the solved velocities and the push-out for the position half.
//!
//! An object made solid by a command starts where its material lay, and its frozen shape's
//! collision surface (sampled on cells, up to a cell outside its particles) starts inside what
//! it touched. Pushing that overlap out lifts it and gives it energy, so each pair it is in at
//! its first contact pass keeps its overlap (`CachedPair::keeps_overlap`): its points are held
//! at v_n ≥ 0 but not pushed apart, and take no restitution, until the pair parts (two
//! objects, or an object and the background: their boxes no longer come within the margin; an
//! object and a collider: no point overlaps).
//!
//! Deformable objects never come here: against a solid they meet its boundary nodes on their
//! grid, against each other the COM-level impulse law on contact patches of `deformable_pair/`.

use std::collections::HashMap;

use glam::{DVec3, Vec3A};

use super::body::{self, Body};
use super::{ContactMemory, Env, WorldStats};
use crate::contact::geometry::{Placed, RawContact};
use crate::contact::manifold;
use crate::contact::{
    ContactPoint, SolverBody, SolverSettings, mix_friction, mix_restitution, solver,
};
use crate::scene::ObjectKind;

/// The other side of a contact point: an object, a grid collider or the background.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Other {
    /// Object index.
    Object(u32),
    /// Grid collider index.
    Collider(u32),
    /// The captured background.
    Background,
}

/// A pair across substeps: object A and the other side.
pub type PairKey = (u32, Other);

/// Accumulated impulses of the last substep's points, for warm starting (`CachedPair`). A new
/// point takes the impulses of the nearest old point of its pair within [`WARM_RADIUS_CELLS`]
/// (each old point once), scaled by the ratio of the substeps, so warm starting survives a
/// manifold that picks different surface points as the bodies move, and pairs of islands
/// stepped at different rates (`islands.rs`) keep their own substep.
#[derive(Debug, Clone, Default)]
pub struct ContactCache {
    pairs: HashMap<PairKey, CachedPair>,
}

/// One pair's entry of [`ContactCache`].
#[derive(Debug, Clone, Default)]
struct CachedPair {
    /// The substep its impulses were solved over (s).
    dt_s: f64,
    /// Whether any of its points carried a normal impulse: lasting contact, which takes no
    /// restitution.
    loaded: bool,
    /// It keeps its overlap, not pushed apart (module docs): from the first contact pass after
    /// one of its objects was made solid while they met, until the pair parts. A kept pair may
    /// have no points.
    keeps_overlap: bool,
    /// Each point in A's rest frame with its normal impulse and its share of its patch's
    /// friction.
    points: Vec<(Vec3A, Warm)>,
}

/// A point's accumulated impulses: normal (N s), its share of the patch's tangential (N s) and
/// torsional (N m s) friction.
type Warm = (f64, DVec3, f64);

/// How near, in grid cells, an old point must be to warm-start a new one.
pub const WARM_RADIUS_CELLS: f32 = 0.5;

impl ContactCache {
    /// Takes the impulses of the nearest unclaimed old point of `pair` within `radius_m` of
    /// `local` (A's rest frame).
    /// `dt_s`: the new substep (s); the impulses come scaled by it over the old one.
    fn take(&mut self, pair: PairKey, local: Vec3A, radius_m: f32, dt_s: f64) -> Option<Warm> {
        let cached = self.pairs.get_mut(&pair)?;
        let ratio = if cached.dt_s > 0.0 {
            dt_s / cached.dt_s
        } else {
            1.0
        };
        let old = &mut cached.points;
        let (i, d2) = old
            .iter()
            .enumerate()
            .map(|(i, (x, _))| (i, (*x - local).length_squared()))
            .min_by(|a, b| a.1.total_cmp(&b.1))?;
        if d2 > radius_m * radius_m {
            return None;
        }
        let (p_n, p_t, twist) = old.swap_remove(i).1;
        Some((p_n * ratio, p_t * ratio, twist * ratio))
    }

    /// Whether `pair` carried a normal impulse at any point in the last substep.
    fn carried_load(&self, pair: PairKey) -> bool {
        self.pairs.get(&pair).is_some_and(|p| p.loaded)
    }

    /// Whether `pair` keeps its overlap ([`CachedPair::keeps_overlap`]).
    fn keeps_overlap(&self, pair: PairKey) -> bool {
        self.pairs.get(&pair).is_some_and(|p| p.keeps_overlap)
    }

    /// Moves the pairs for which `keep` is false into a cache of their own (island stepping
    /// keeps another island's pairs aside while it solves its own).
    pub(super) fn split_off(&mut self, keep: impl Fn(PairKey) -> bool) -> ContactCache {
        let (mine, others) = std::mem::take(&mut self.pairs)
            .into_iter()
            .partition(|(key, _)| keep(*key));
        self.pairs = mine;
        ContactCache { pairs: others }
    }

    /// Adds `other`'s pairs back (they are disjoint from this cache's).
    pub(super) fn absorb(&mut self, other: ContactCache) {
        self.pairs.extend(other.pairs);
    }
}

/// One contact of the last substep, for diagnostics and tests.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactReport {
    /// Object A.
    pub a: u32,
    /// The other side.
    pub b: Other,
    /// Point (m).
    pub point_m: DVec3,
    /// Normal from A to B.
    pub normal: DVec3,
    /// Separation (m), negative when penetrating.
    pub separation_m: f64,
    /// Normal impulse on B (N s).
    pub normal_impulse_n_s: f64,
}

/// Whether two solids may exchange impulses: one must be an awake rigid object, or a moving
/// kinematic object against a sleeping rigid one (which it wakes); two immovable or sleeping
/// objects cannot.
fn may_touch(a: &body::Body, b: &body::Body) -> bool {
    let dynamic = |x: &body::Body| x.kind == ObjectKind::Rigid && !x.sleeping;
    let wakes = |x: &body::Body, y: &body::Body| {
        x.kind == ObjectKind::Kinematic && x.is_moving() && y.kind == ObjectKind::Rigid
    };
    dynamic(a) || dynamic(b) || wakes(a, b) || wakes(b, a)
}

fn overlaps(a: (Vec3A, Vec3A), b: (Vec3A, Vec3A), margin: f32) -> bool {
    (a.0 - margin).cmple(b.1).all() && (b.0 - margin).cmple(a.1).all()
}

/// The pairs (i < j) whose boxes `bounds` (m) come within `margin` (m) of each other, in
/// (i, j) order: sweep and prune along x (Baraff 1992; the broad phase of Bullet and Box2D
/// v2), O(n log n + pairs) instead of every pair.
pub(crate) fn broad_phase(bounds: &[Option<(Vec3A, Vec3A)>], margin: f32) -> Vec<(usize, usize)> {
    let mut order: Vec<usize> = (0..bounds.len()).filter(|&k| bounds[k].is_some()).collect();
    let lo = |k: usize| bounds[k].map_or(f32::INFINITY, |b| b.0.x);
    order.sort_unstable_by(|&a, &b| lo(a).total_cmp(&lo(b)).then(a.cmp(&b)));
    let mut pairs = Vec::new();
    for (s, &i) in order.iter().enumerate() {
        let Some(bi) = bounds[i] else { continue };
        for &j in &order[s + 1..] {
            let Some(bj) = bounds[j] else { continue };
            if bj.0.x - margin > bi.1.x {
                break;
            }
            if overlaps(bi, bj, margin) {
                pairs.push((i.min(j), i.max(j)));
            }
        }
    }
    pairs.sort_unstable();
    pairs
}

/// Body `b` as the solver sees it: an awake rigid object moves (with gravity `gravity_m_s2`
/// over `dt_s` as its external velocity change), a kinematic object moves as driven with
/// infinite mass, anything else does not.
fn solver_body(b: &Body, gravity_m_s2: Vec3A, dt_s: f64) -> SolverBody {
    if b.kind == ObjectKind::Rigid && !b.sleeping {
        let mut s = SolverBody::new(
            b.rigid.com_m,
            b.rigid.velocity_m_s,
            b.rigid.omega_rad_s,
            1.0 / b.rigid.mass_kg.max(f64::MIN_POSITIVE),
            super::measure::inverse_or_zero(b.rigid_world_inertia()),
        );
        s.external_m_s = gravity_m_s2.as_dvec3() * dt_s;
        s
    } else if b.kind == ObjectKind::Kinematic {
        SolverBody::new(
            b.rigid.com_m,
            b.rigid.velocity_m_s,
            b.rigid.omega_rad_s,
            0.0,
            glam::DMat3::ZERO,
        )
    } else {
        let mut s = SolverBody::immovable(DVec3::ZERO);
        s.com_m = b.rigid.com_m;
        s
    }
}

/// Steps 1-3 of the module docs for a substep of `dt_s`: the solids of `bodies` against each
/// other, the colliders and the background, warm-started from `memory`, which keeps this
/// substep's impulses and contact points.
pub(super) fn solve(
    env: &Env,
    bodies: &mut [Body],
    memory: &mut ContactMemory,
    stats: &mut WorldStats,
    dt_s: f64,
) {
    let n = bodies.len();
    for (k, b) in bodies.iter_mut().enumerate() {
        if env.stepping(k) {
            b.supports.clear();
        }
    }
    let dx = env.settings.grid_dx_m as f32;
    // Speculative margin: points within a cell are contacts (the gap may close).
    let margin = dx;
    let mut raw: Vec<(usize, Other, RawContact)> = Vec::new();
    let placed: Vec<Option<Placed<'_>>> = (0..n).map(|k| env.placed(bodies, k)).collect();
    let bounds: Vec<Option<(Vec3A, Vec3A)>> =
        placed.iter().map(|p| p.map(|p| p.bounds_m)).collect();
    let background_placed = env.background.placed();
    // Whether a pair's boxes still come within the margin (never for a collider: its points
    // are exact, [`manifold::against_collider`]).
    let near = |(a, other): PairKey| {
        let Some(ba) = bounds[a as usize] else {
            return false;
        };
        match other {
            Other::Object(j) => bounds[j as usize].is_some_and(|bj| overlaps(ba, bj, margin)),
            Other::Background => background_placed
                .as_ref()
                .is_some_and(|bg| overlaps(ba, bg.bounds_m, margin)),
            Other::Collider(_) => false,
        }
    };
    let mut candidates: Vec<PairKey> = Vec::new();
    for (i, j) in broad_phase(&bounds, margin) {
        let (bi, bj) = (&bodies[i], &bodies[j]);
        let (Some(a), Some(b)) = (&placed[i], &placed[j]) else {
            continue;
        };
        if !may_touch(bi, bj) {
            continue;
        }
        candidates.push((i as u32, Other::Object(j as u32)));
        let points = manifold::between(a, b, margin);
        raw.extend(points.into_iter().map(|c| (i, Other::Object(j as u32), c)));
    }
    // Rigid objects against colliders and the background.
    for (k, (b, a)) in bodies.iter().zip(&placed).enumerate() {
        let Some(a) = a else { continue };
        if b.kind != ObjectKind::Rigid || b.sleeping {
            continue;
        }
        for (ci, collider) in env.colliders.iter().enumerate() {
            let pts = manifold::against_collider(a, collider, env.time_s, margin);
            raw.extend(pts.into_iter().map(|c| (k, Other::Collider(ci as u32), c)));
        }
        if let Some(bg) = background_placed
            && overlaps(a.bounds_m, bg.bounds_m, margin)
        {
            candidates.push((k as u32, Other::Background));
            let pts = manifold::between(a, &bg, margin);
            raw.extend(pts.into_iter().map(|c| (k, Other::Background, c)));
        }
    }
    let poses: Vec<Option<crate::contact::Pose>> =
        placed.iter().map(|p| p.map(|p| p.pose)).collect();
    // The pairs that keep their overlap (module docs): those of an object made solid since its
    // last contact pass and those that kept it in the last substep, until they part.
    let made_solid = |k: usize| memory.made_solid.contains(&k);
    let kept_before = |(a, other): PairKey| {
        made_solid(a as usize)
            || matches!(other, Other::Object(j) if made_solid(j as usize))
            || memory.cache.keeps_overlap((a, other))
    };
    // A pair may overlap where none of its points shows it: a shape made solid while wrapped
    // round another (a jelly draped over a box) holds the other's surface past the middle of
    // its thin parts, where points face away ([`manifold`]), until a turn brings one back at
    // its full depth. So a pair of objects (or an object and the background) stays kept while
    // their boxes come within the margin, with or without points; a pair with a collider,
    // whose points are exact, while any point overlaps.
    let mut keeps: HashMap<PairKey, bool> = HashMap::new();
    for (a, other, c) in &raw {
        let key = (*a as u32, *other);
        let kept = kept_before(key) && (near(key) || c.separation_m < 0.0);
        *keeps.entry(key).or_default() |= kept;
    }
    let hidden: Vec<PairKey> = candidates
        .iter()
        .copied()
        .filter(|key| !keeps.contains_key(key) && near(*key) && kept_before(*key))
        .collect();
    let hidden_pairs = |dt_s: f64| {
        hidden.iter().map(move |key| {
            let pair = CachedPair {
                dt_s,
                keeps_overlap: true,
                ..CachedPair::default()
            };
            (*key, pair)
        })
    };
    // Consumed by the first pass that sees it (a static object is seen by every island's).
    memory
        .made_solid
        .retain(|&k| k < n && !env.present(k, &bodies[k]));
    if raw.is_empty() {
        memory.cache.pairs = hidden_pairs(dt_s).collect();
        memory.last.clear();
        return;
    }
    // A moving object wakes a sleeping one it touches; a still one leans on it as on an
    // immovable support (both join one island once awake, `sleep.rs`).
    for (a, other, _) in &raw {
        if let Other::Object(b) = other {
            let b = *b as usize;
            if bodies[b].sleeping && bodies[*a].is_moving() {
                bodies[b].wake_on_contact();
            } else if bodies[*a].sleeping && bodies[b].is_moving() {
                bodies[*a].wake_on_contact();
            }
        }
    }
    // Solver bodies: objects first, then colliders, then the background.
    let mut solver_bodies: Vec<SolverBody> = (0..n)
        .map(|k| solver_body(&bodies[k], env.gravity_m_s2, dt_s))
        .collect();
    let collider0 = solver_bodies.len();
    for c in env.colliders {
        solver_bodies.push(SolverBody::immovable(c.velocity_at(env.time_s).as_dvec3()));
    }
    let background = solver_bodies.len();
    solver_bodies.push(SolverBody::immovable(DVec3::ZERO));
    let local = |a: usize, x: Vec3A| poses[a].map_or(x, |p| p.to_rest(x));
    let mut cache = std::mem::take(&mut memory.cache);
    let mut points: Vec<ContactPoint> = raw
        .iter()
        .map(|(a, other, c)| {
            let ba = &bodies[*a];
            let (b, friction, restitution) = match other {
                Other::Object(j) => {
                    let bj = &bodies[*j as usize];
                    (
                        *j as usize,
                        mix_friction(ba.friction, bj.friction) as f64,
                        mix_restitution(ba.restitution, bj.restitution) as f64,
                    )
                }
                Other::Collider(ci) => {
                    let col = &env.colliders[*ci as usize];
                    let mu = match col.surface {
                        crate::collider::Surface::Sticky | crate::collider::Surface::Clamp => {
                            crate::contact::STICKY_FRICTION
                        }
                        _ => mix_friction(ba.friction, col.friction) as f64,
                    };
                    (collider0 + *ci as usize, mu, ba.restitution as f64)
                }
                Other::Background => (
                    background,
                    mix_friction(ba.friction, env.background.friction) as f64,
                    ba.restitution as f64,
                ),
            };
            let rolling_resistance_m = match other {
                Other::Object(j) => ba
                    .rolling_resistance_m
                    .max(bodies[*j as usize].rolling_resistance_m),
                Other::Collider(_) | Other::Background => ba.rolling_resistance_m,
            } as f64;
            let warm = cache.take(
                (*a as u32, *other),
                local(*a, c.point_m),
                WARM_RADIUS_CELLS * dx,
                dt_s,
            );
            let (p_n, p_t, twist) = warm.unwrap_or((0.0, DVec3::ZERO, 0.0));
            // A point of a pair that keeps its overlap is touching, not pushed apart, and the
            // pair, in contact from the start, takes no restitution.
            let kept = keeps[&(*a as u32, *other)];
            let s = c.separation_m as f64;
            ContactPoint {
                a: *a,
                b,
                point_m: c.point_m.as_dvec3(),
                normal: c.normal.as_dvec3(),
                separation_m: if kept { s.max(0.0) } else { s },
                restitution,
                friction,
                lasting: kept || cache.carried_load((*a as u32, *other)),
                normal_impulse: p_n,
                tangent_impulse: p_t,
                twist_impulse: twist,
                rolling_resistance_m,
            }
        })
        .collect();
    let settings = SolverSettings {
        scheme: env.settings.contact_solver,
        resting_speed_m_s: 2.0 * env.gravity_m_s2.length() as f64 * dt_s,
        ..SolverSettings::default()
    };
    let patches = solver::solve(&mut solver_bodies, &mut points, dt_s, &settings);
    stats.contact_impulses += points.iter().filter(|p| p.normal_impulse > 0.0).count() as u64;
    let mut pairs: HashMap<PairKey, CachedPair> = HashMap::new();
    for ((a, other, c), p) in raw.iter().zip(&points) {
        let key = (*a as u32, *other);
        let pair = pairs.entry(key).or_insert_with(|| CachedPair {
            dt_s,
            keeps_overlap: keeps[&key],
            ..CachedPair::default()
        });
        pair.loaded |= p.normal_impulse > 0.0;
        pair.points.push((
            local(*a, c.point_m),
            (p.normal_impulse, p.tangent_impulse, p.twist_impulse),
        ));
    }
    pairs.extend(hidden_pairs(dt_s));
    memory.cache = ContactCache { pairs };
    memory.last = raw
        .iter()
        .zip(&points)
        .map(|((a, other, c), p)| ContactReport {
            a: *a as u32,
            b: *other,
            point_m: p.point_m,
            normal: p.normal,
            separation_m: c.separation_m as f64,
            normal_impulse_n_s: p.normal_impulse,
        })
        .collect();
    for (a, other, _) in &raw {
        bodies[*a].stats.contacts += 1;
        if let Other::Object(j) = other {
            bodies[*j as usize].stats.contacts += 1;
        }
    }
    // Write back: impulses received (normal at each point, friction at its patch's anchor),
    // then the rigid objects' new velocities and push-out.
    for p in &points {
        let on_b = p.normal * p.normal_impulse + p.tangent_impulse;
        for (k, sign) in [(p.a, -1.0), (p.b, 1.0)] {
            if k < n {
                bodies[k].stats.impulse_total_n_s += on_b.length();
                bodies[k].record_contact(p.normal * p.normal_impulse * sign, p.point_m);
            }
        }
    }
    for patch in &patches {
        for (k, sign) in [(patch.a, -1.0), (patch.b, 1.0)] {
            if k < n {
                let b = &mut bodies[k];
                b.record_contact(patch.tangent_impulse * sign, patch.anchor_m);
                b.stats.frame_angular_impulse_n_m_s += patch.normal * patch.twist_impulse * sign;
            }
        }
    }
    record_supports(bodies, &solver_bodies, &points);
    for (k, s) in solver_bodies.iter().enumerate().take(n) {
        if !env.stepping(k) {
            continue;
        }
        let b = &mut bodies[k];
        if b.kind == ObjectKind::Rigid && !b.sleeping {
            b.rigid.velocity_m_s = s.velocity_m_s;
            b.rigid.omega_rad_s = s.omega_rad_s;
            b.push = (s.push_m_s, s.push_rad_s);
        }
    }
}

/// Each awake rigid object's loaded points against immovable solver bodies (colliders, the
/// background, static, kinematic and sleeping objects), as the supports the deformable grids it
/// meets next substep hold it on ([`crate::contact::coupling::Support`]).
fn record_supports(bodies: &mut [Body], solver_bodies: &[SolverBody], points: &[ContactPoint]) {
    let n = bodies.len();
    let immovable = |k: usize| {
        let s = &solver_bodies[k];
        s.inverse_mass == 0.0 && s.inverse_inertia == glam::DMat3::ZERO
    };
    for p in points.iter().filter(|p| p.normal_impulse > 0.0) {
        // The normal runs from a to b: out of a support a, into a support b.
        for (k, other, normal) in [(p.a, p.b, -p.normal), (p.b, p.a, p.normal)] {
            if k >= n || !immovable(other) || immovable(k) {
                continue;
            }
            let b = &mut bodies[k];
            if b.kind != ObjectKind::Rigid || b.sleeping {
                continue;
            }
            let s = &solver_bodies[other];
            b.supports.push(crate::contact::coupling::Support {
                r_m: p.point_m - solver_bodies[k].com_m,
                normal,
                velocity_m_s: s.velocity_m_s + s.omega_rad_s.cross(p.point_m - s.com_m),
                friction: p.friction,
            });
        }
    }
}
