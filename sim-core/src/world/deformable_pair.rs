//! Contact between two deformable objects (method `com`): the paper's stage 2 (eqs. 3-6), one
//! impulse per pair and substep at the COM level, written as the standard impulse law
//! (docs/com-layer.md maps one to the other).
//!
//! Broad phase: bounding spheres (eq. 3: |c_i - c_j| <= r_i + r_j) and boxes. Narrow phase: the
//! overlap of the two objects' occupied grid cells. The contact zone of each object is its
//! particles in cells the other occupies; the contact point is the midpoint of the two zones'
//! centroids, and the normal n (from A to B) is the difference of the objects' outward normals
//! there, each the least-variance direction of that object's particles within 3 cells of the
//! point ([`surface_normal`]). Means over the overlap keep a head-on impact on its axis, which
//! the restitution law needs to 1 %.
//!
//! Response, for approaching pairs only (v_rel·n < 0, v_rel = v_B - v_A at the contact point):
//! j_n = -(1 + e) v_rel·n / (1/m_A + 1/m_B + n·[(I_A⁻¹ (r_A × n)) × r_A + (I_B⁻¹ (r_B × n)) × r_B]),
//! Coulomb friction j_t <= μ j_n against the tangential velocity, impulse J = j_n n + j_t t on B and
//! -J on A, at the contact point, so linear and angular momentum are both conserved; the
//! particles receive it through [`super::coherence::apply_impulse`].
//!
//! Resting contact (approach slower than 2 g dt) is solved as a sequential impulse with an
//! accumulated, clamped impulse (Catto 2005) and warm starting: the impulse a resting pair needed
//! in one substep is applied again at the start of the next, before P2G, so the load reaches the
//! grids in the velocities the positions are advanced with, and a grid boundary under the lower
//! object takes it. The end-of-substep step then only corrects it (it may pull back, down to
//! zero normal impulse; friction stays in the Coulomb cone). Without it, the impulse arrives after
//! the positions moved and a resting object sinks into the one below by g dt² per substep
//! (g dt per second: 2.6 mm/s at dt = 0.27 ms).

use glam::{DMat3, DVec3, IVec3};
use rayon::prelude::*;

use super::body::{Body, BodyState, measure, measure_bounds};
use super::{World, coherence};
use crate::contact::{mix_friction, mix_restitution};
use crate::scene::{Method, ObjectKind};

/// A detected contact between bodies `a` and `b`.
#[derive(Debug, Clone, PartialEq)]
pub struct Contact {
    /// Unit normal from A to B.
    pub normal: DVec3,
    /// Contact point (m).
    pub point_m: DVec3,
    /// A's particles in cells B occupies.
    pub zone_a: Vec<u32>,
    /// B's particles in cells A occupies.
    pub zone_b: Vec<u32>,
    /// What [`Contact::footprint`] needs: each body's particles near the overlap, and the cells
    /// each occupies inside it (sorted).
    near: [Vec<u32>; 2],
    cells: [Vec<[i32; 3]>; 2],
    /// The overlap of the two boxes grown by a cell (m), and 1 / cell size (1/m).
    overlap_m: (DVec3, DVec3),
    inv_cell: f32,
}

impl Contact {
    /// Where this contact may press when it rests: A's and B's particles within a cell of a
    /// cell the other occupies (where the two touch or are about to; the zones are only where
    /// they already overlap), as offsets in the contact plane. Computed on demand: impacts do
    /// not need it.
    pub fn footprint(&self, a: &Body, b: &Body) -> Footprint {
        let (lo, hi) = self.overlap_m;
        let (inv_h, point, n) = (self.inv_cell, self.point_m, self.normal);
        let mut offsets_m = Vec::new();
        for (body, near, other) in [
            (a, &self.near[0], &self.cells[1]),
            (b, &self.near[1], &self.cells[0]),
        ] {
            offsets_m.extend(near.iter().filter_map(|&i| {
                let x = body.particles.x[i as usize];
                let xd = x.as_dvec3();
                if !(xd.cmpge(lo).all() && xd.cmple(hi).all()) {
                    return None;
                }
                let c = cell(x, inv_h);
                let touches = (0..27).any(|k| {
                    let d = IVec3::new(k % 3 - 1, (k / 3) % 3 - 1, k / 9 - 1);
                    other.binary_search(&(c + d).to_array()).is_ok()
                });
                let d = xd - point;
                touches.then(|| d - n * d.dot(n))
            }));
        }
        Footprint { offsets_m }
    }
}

#[inline]
fn cell(x: glam::Vec3A, inv_h: f32) -> IVec3 {
    (x * inv_h).floor().as_ivec3()
}

/// Broad phase: bounding spheres and boxes (expanded by `margin_m`) overlap.
pub fn broad_phase(a: &BodyState, b: &BodyState, margin_m: f64) -> bool {
    let d = (a.com_m - b.com_m).length();
    if d > a.radius_m + b.radius_m + margin_m {
        return false;
    }
    let m = DVec3::splat(margin_m);
    (a.aabb_m.0 - m).cmple(b.aabb_m.1).all() && (b.aabb_m.0 - m).cmple(a.aabb_m.1).all()
}

/// Narrow phase on occupied cells of size `cell_m`; `None` when no cell is shared.
pub fn narrow_phase(
    a: &Body,
    sa: &BodyState,
    b: &Body,
    sb: &BodyState,
    cell_m: f32,
) -> Option<Contact> {
    let inv_h = 1.0 / cell_m;
    // Only particles inside the boxes' overlap (grown by a cell) can share a cell, and the
    // normal below looks 3 cells around the contact point (which lies in that grown overlap):
    // one pass per body keeps the particles of the overlap grown by 4 cells, and everything
    // after works on those.
    let lo = sa.aabb_m.0.max(sb.aabb_m.0) - DVec3::splat(cell_m as f64);
    let hi = sa.aabb_m.1.min(sb.aabb_m.1) + DVec3::splat(cell_m as f64);
    let (lo3, hi3) = (
        (lo - DVec3::splat(3.0 * cell_m as f64)).as_vec3a(),
        (hi + DVec3::splat(3.0 * cell_m as f64)).as_vec3a(),
    );
    let near = |body: &Body| -> Vec<u32> {
        (0..body.particles.len() as u32)
            .filter(|&i| {
                let x = body.particles.x[i as usize];
                x.cmpge(lo3).all() && x.cmple(hi3).all()
            })
            .collect()
    };
    let (near_a, near_b) = (near(a), near(b));
    if near_a.is_empty() || near_b.is_empty() {
        return None;
    }
    let inside = |x: glam::Vec3A| {
        let x = x.as_dvec3();
        x.cmpge(lo).all() && x.cmple(hi).all()
    };
    // Occupied cells as a sorted, deduplicated list (binary search; no hashing).
    let cells_of = |body: &Body, near: &[u32]| -> Vec<[i32; 3]> {
        let mut c: Vec<[i32; 3]> = near
            .iter()
            .map(|&i| body.particles.x[i as usize])
            .filter(|x| inside(*x))
            .map(|x| cell(x, inv_h).to_array())
            .collect();
        c.sort_unstable();
        c.dedup();
        c
    };
    let cells_b = cells_of(b, &near_b);
    if cells_b.is_empty() {
        return None;
    }
    let zone = |body: &Body, near: &[u32], other: &[[i32; 3]]| -> Vec<u32> {
        near.iter()
            .copied()
            .filter(|&i| {
                let x = body.particles.x[i as usize];
                inside(x) && other.binary_search(&cell(x, inv_h).to_array()).is_ok()
            })
            .collect()
    };
    let zone_a = zone(a, &near_a, &cells_b);
    if zone_a.is_empty() {
        return None;
    }
    let cells_a = cells_of(a, &near_a);
    let zone_b = zone(b, &near_b, &cells_a);
    if zone_b.is_empty() {
        return None;
    }
    let centroid = |body: &Body, z: &[u32]| {
        let mut m = 0.0;
        let mut mx = DVec3::ZERO;
        for &i in z {
            let mi = body.particles.mass_kg[i as usize] as f64;
            m += mi;
            mx += body.particles.x[i as usize].as_dvec3() * mi;
        }
        mx / m.max(f64::MIN_POSITIVE)
    };
    let ca = centroid(a, &zone_a);
    let cb = centroid(b, &zone_b);
    let point = (ca + cb) * 0.5;
    // Each object's outward surface normal near the contact point, from its particles within
    // 3 cells of it ([`surface_normal`]). Robust even when the zones hold a handful of particles
    // (zone centroids alone are not).
    let reach_m = 3.0 * cell_m as f64;
    let outward = |body: &Body, near: &[u32]| surface_normal(body, near, point, reach_m);
    let normal = match (outward(a, &near_a), outward(b, &near_b)) {
        (Some(na), Some(nb)) => (na - nb).try_normalize(),
        (Some(na), None) => Some(na),
        (None, Some(nb)) => Some(-nb),
        (None, None) => None,
    }
    .or_else(|| (cb - ca).try_normalize())
    .or_else(|| (sb.com_m - sa.com_m).try_normalize())
    .unwrap_or(DVec3::Z);
    Some(Contact {
        normal,
        point_m: point,
        zone_a,
        zone_b,
        near: [near_a, near_b],
        cells: [cells_a, cells_b],
        overlap_m: (lo, hi),
        inv_cell: inv_h,
    })
}

/// The outward normal of `body`'s surface near `point` (m), from its particles among `near`
/// within `reach_m` of it; `None` when none is that close.
///
/// The particles of a surface patch, or of the solid cap behind it, vary least across the
/// surface: the normal is the least-variance direction of their mass-weighted covariance
/// (principal component analysis, as in Hoppe et al. 1992, "Surface reconstruction from
/// unorganized points"), turned to point from their centroid towards `point`. Captured objects are
/// often open shells (a donut scanned on a plate has no underside), so the direction from the
/// centroid alone leans towards wherever the capture has surface. Fewer than four particles,
/// or a spread with no clear thin direction (smallest variance above half the middle one: a
/// point deep inside, a line of particles), fall back to the direction from the centroid.
pub fn surface_normal(body: &Body, near: &[u32], point: DVec3, reach_m: f64) -> Option<DVec3> {
    let reach2 = reach_m * reach_m;
    let close = || {
        near.iter()
            .map(|&i| {
                let i = i as usize;
                (
                    body.particles.x[i].as_dvec3(),
                    body.particles.mass_kg[i] as f64,
                )
            })
            .filter(|(x, _)| (*x - point).length_squared() <= reach2)
    };
    let (mut m, mut mx, mut count) = (0.0, DVec3::ZERO, 0usize);
    for (x, mi) in close() {
        m += mi;
        mx += x * mi;
        count += 1;
    }
    if m <= 0.0 || !m.is_finite() {
        return None;
    }
    let centroid = mx / m;
    let from_centroid = (point - centroid).try_normalize();
    if count < 4 {
        return from_centroid;
    }
    let mut cov = DMat3::ZERO;
    for (x, mi) in close() {
        let d = x - centroid;
        cov += super::body::outer(d, d) * (mi / m);
    }
    let svd = crate::math::svd3(glam::Mat3A::from(cov.as_mat3()));
    let (s1, s2) = (svd.sigma.y as f64, svd.sigma.z as f64);
    let thin = s2 <= 0.5 * s1; // false for NaN too
    if !thin {
        return from_centroid;
    }
    let n = svd.v.z_axis.as_dvec3().try_normalize()?;
    let out = from_centroid.unwrap_or(n);
    Some(if n.dot(out) < 0.0 { -n } else { n })
}

/// Per-body quantities the impulse law needs.
#[derive(Debug, Clone, Copy)]
pub struct Dynamics {
    /// COM (m).
    pub com_m: DVec3,
    /// COM velocity (m/s).
    pub velocity_m_s: DVec3,
    /// Angular velocity (rad/s).
    pub omega_rad_s: DVec3,
    /// 1/m (zero: immovable).
    pub inverse_mass: f64,
    /// I⁻¹ about the COM (zero: immovable).
    pub inverse_inertia: DMat3,
}

impl Dynamics {
    fn point_velocity(&self, p: DVec3) -> DVec3 {
        self.velocity_m_s + self.omega_rad_s.cross(p - self.com_m)
    }

    fn effective(&self, p: DVec3, dir: DVec3) -> f64 {
        let r = p - self.com_m;
        self.inverse_mass + dir.dot((self.inverse_inertia * r.cross(dir)).cross(r))
    }
}

/// The impulse on B (−it on A) for an impact at `point` with normal `n` (A to B), restitution
/// `e` and friction `mu`; `None` when the bodies are not approaching there. Slow approaches are
/// resting contact ([`resting_impulse`]), so gravity's per-substep velocity does not make
/// resting objects bounce.
pub fn impulse(
    a: &Dynamics,
    b: &Dynamics,
    point: DVec3,
    n: DVec3,
    e: f64,
    mu: f64,
) -> Option<DVec3> {
    let v_rel = b.point_velocity(point) - a.point_velocity(point);
    let vn = v_rel.dot(n);
    if vn >= 0.0 {
        return None;
    }
    let k_n = a.effective(point, n) + b.effective(point, n);
    if k_n <= 0.0 || !k_n.is_finite() {
        return None;
    }
    let jn = -(1.0 + e) * vn / k_n;
    let vt = v_rel - n * vn;
    let mut j = n * jn;
    if let Some(t) = vt.try_normalize() {
        let k_t = a.effective(point, t) + b.effective(point, t);
        if k_t > 0.0 {
            // Sticking needs |vt| / k_t; Coulomb caps it at mu j_n.
            let jt = (vt.length() / k_t).min(mu * jn);
            j -= t * jt;
        }
    }
    j.is_finite().then_some(j)
}

/// Where a resting contact may press: the in-plane offsets (m) from the contact point of the
/// particles where the two objects touch ([`Contact::footprint`]). The centre of pressure must
/// lie inside it, which bounds the couple a flat contact can carry (a box standing off-centre on
/// another is held; one hanging past the edge tips).
#[derive(Debug, Clone, Default)]
pub struct Footprint {
    offsets_m: Vec<DVec3>,
}

impl Footprint {
    /// How far the footprint reaches from the point along unit `u` (m, >= 0).
    fn reach_m(&self, u: DVec3) -> f64 {
        self.offsets_m.iter().map(|d| d.dot(u)).fold(0.0, f64::max)
    }

    /// Mean distance from the point (m): the arm of torsional friction (2/3 R for a disc).
    fn mean_arm_m(&self) -> f64 {
        if self.offsets_m.is_empty() {
            return 0.0;
        }
        self.offsets_m.iter().map(|d| d.length()).sum::<f64>() / self.offsets_m.len() as f64
    }
}

/// A resting contact's accumulated impulse on B (−it on A): the force part `linear_n_s` (N s)
/// at the contact point and the couple `angular_n_m_s` (N m s) of a pressure centre away from it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Accumulated {
    /// Impulse at the contact point (N s).
    pub linear_n_s: DVec3,
    /// Couple (N m s).
    pub angular_n_m_s: DVec3,
}

impl Accumulated {
    fn scaled(self, f: f64) -> Self {
        Self {
            linear_n_s: self.linear_n_s * f,
            angular_n_m_s: self.angular_n_m_s * f,
        }
    }
}

/// One sequential-impulse step (Catto 2005) of a resting contact: the change of its accumulated
/// impulse `acc` that brings the relative velocity at `point` to zero along `n` (A to B) and the
/// relative angular velocity to zero, keeping the normal impulse λ = acc·n >= 0, its tangential
/// part in the Coulomb cone (|j_t| <= μ λ), the pressure centre inside `footprint` and the twist
/// within torsional friction (|h·n| <= μ λ × the footprint's mean arm). `None` when nothing
/// changes.
pub fn resting_impulse(
    a: &Dynamics,
    b: &Dynamics,
    point: DVec3,
    n: DVec3,
    mu: f64,
    footprint: &Footprint,
    acc: Accumulated,
) -> Option<Accumulated> {
    let v_rel = b.point_velocity(point) - a.point_velocity(point);
    let vn = v_rel.dot(n);
    let k_n = a.effective(point, n) + b.effective(point, n);
    if k_n <= 0.0 || !k_n.is_finite() {
        return None;
    }
    let j = acc.linear_n_s;
    let lam_old = j.dot(n).max(0.0);
    let lam = (lam_old - vn / k_n).max(0.0);
    let jt_old = j - n * j.dot(n);
    let mut jt = jt_old;
    let vt = v_rel - n * vn;
    if let Some(t) = vt.try_normalize() {
        let k_t = a.effective(point, t) + b.effective(point, t);
        if k_t > 0.0 {
            jt -= t * (vt.length() / k_t);
        }
    }
    if jt.length() > mu * lam {
        jt = jt.normalize_or_zero() * (mu * lam);
    }
    let dj = n * (lam - lam_old) + (jt - jt_old);
    // The couple, against the relative spin left after the force change.
    let (ra, rb) = (point - a.com_m, point - b.com_m);
    let w_rel = (b.omega_rad_s + b.inverse_inertia * rb.cross(dj))
        - (a.omega_rad_s - a.inverse_inertia * ra.cross(dj));
    let k_w = a.inverse_inertia + b.inverse_inertia;
    let mut h = acc.angular_n_m_s;
    if k_w.determinant().abs() > 0.0 {
        h -= k_w.inverse() * w_rel;
    }
    let (h_n, h_t) = (n * h.dot(n), h - n * h.dot(n));
    let twist_max = mu * lam * footprint.mean_arm_m();
    let h_n = if h_n.length() > twist_max {
        h_n.normalize_or_zero() * twist_max
    } else {
        h_n
    };
    // Pressure centre d with d × (λ n) = h_t, so d = n × h_t / λ, kept inside the footprint.
    let h_t = if lam > 0.0 {
        let d = n.cross(h_t) / lam;
        let reach = d.try_normalize().map_or(0.0, |u| footprint.reach_m(u));
        let d = if d.length() > reach {
            d.normalize_or_zero() * reach
        } else {
            d
        };
        d.cross(n) * lam
    } else {
        DVec3::ZERO
    };
    let change = Accumulated {
        linear_n_s: dj,
        angular_n_m_s: h_n + h_t - acc.angular_n_m_s,
    };
    (change.linear_n_s.is_finite()
        && change.angular_n_m_s.is_finite()
        && change != Accumulated::default())
    .then_some(change)
}

/// A resting deformable pair's impulse over one substep, applied again at the start of the
/// next (warm starting; module docs).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct RestingPair {
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
    /// A's particles in cells B occupied.
    pub zone_a: Vec<u32>,
    /// B's particles in cells A occupied.
    pub zone_b: Vec<u32>,
}

impl World {
    /// Applies the resting pairs' impulses of the last substep, scaled to `dt` (s), before this
    /// substep's MPM step (module docs). Only for method `com`.
    pub(super) fn warm_start_deformable_pairs(&mut self, dt: f64) {
        let pairs = std::mem::take(&mut self.resting_pairs);
        for p in &pairs {
            let acc = p.impulse.scaled(dt / p.dt_s);
            self.apply_to_pair([p.a, p.b], acc, p.point_m, [&p.zone_a, &p.zone_b]);
        }
        self.resting_pairs = pairs;
    }

    /// Applies `acc` to B and its opposite to A at `point`, to whichever of `bodies` [A, B] is
    /// awake, `zones` being their particles near the point. A zone naming particles its body no
    /// longer has (a command changed them since) gets nothing.
    fn apply_to_pair(
        &mut self,
        bodies: [usize; 2],
        acc: Accumulated,
        point: DVec3,
        zones: [&[u32]; 2],
    ) {
        let (j, h) = (acc.linear_n_s, acc.angular_n_m_s);
        if !(j.is_finite() && h.is_finite()) {
            return;
        }
        for ((k, sign), zone) in bodies.into_iter().zip([-1.0, 1.0]).zip(zones) {
            let Some(b) = self.bodies.get_mut(k) else {
                continue;
            };
            let n = b.particles.len() as u32;
            if b.sleeping || zone.iter().any(|&i| i >= n) {
                continue;
            }
            b.impulse_total_n_s += j.length();
            coherence::apply_contact_impulse(b, j * sign, h * sign, point, zone);
        }
    }

    /// Every pair of deformable objects, one of them awake, through the broad and narrow phase;
    /// an approaching contact gets the impulse law's impulse (module docs). Only for method
    /// `com`: the baselines couple deformable objects on their grids.
    pub(super) fn resolve_deformable_pairs(&mut self, dt: f64) {
        if self.settings.method != Method::Com {
            return;
        }
        let ids: Vec<usize> = (0..self.bodies.len())
            .filter(|&k| self.bodies[k].kind == ObjectKind::Deformable && self.stepping(k))
            .collect();
        if ids.len() < 2 {
            return;
        }
        let resting = 2.0 * self.gravity_m_s2.length() as f64 * dt;
        // Bounds for the broad phase (one pass per object); the full state (inertia, angular
        // momentum) only for objects of a pair that passes it, once per substep.
        let bounds: Vec<BodyState> = ids
            .par_iter()
            .map(|&k| measure_bounds(&self.bodies[k].particles, self.bodies[k].dx_m()))
            .collect();
        let warm = std::mem::take(&mut self.resting_pairs);
        let mut full: Vec<Option<BodyState>> = vec![None; ids.len()];
        for x in 0..ids.len() {
            for y in x + 1..ids.len() {
                let (i, j) = (ids[x], ids[y]);
                let (bi, bj) = (&self.bodies[i], &self.bodies[j]);
                // Objects on grids of different cells meet at the coarser one's.
                let dx = bi.dx_m().max(bj.dx_m());
                if !(bi.is_active() || bj.is_active())
                    || !broad_phase(&bounds[x], &bounds[y], dx as f64)
                {
                    continue;
                }
                for (z, k) in [(x, i), (y, j)] {
                    if full[z].is_none() {
                        let b = &self.bodies[k];
                        full[z] = Some(measure(&b.particles, b.dx_m()));
                    }
                }
                let (Some(si), Some(sj)) = (full[x], full[y]) else {
                    continue;
                };
                let Some(c) = narrow_phase(bi, &si, bj, &sj, dx) else {
                    continue;
                };
                let moving = [bi.is_moving(), bj.is_moving()];
                self.bodies[i].contacts += 1;
                self.bodies[j].contacts += 1;
                for (k, other_moving) in [(i, moving[1]), (j, moving[0])] {
                    if self.bodies[k].sleeping && other_moving {
                        self.bodies[k].wake_on_contact();
                    }
                }
                let dynamics = |b: &Body, s: &BodyState| Dynamics {
                    com_m: s.com_m,
                    velocity_m_s: if b.sleeping {
                        DVec3::ZERO
                    } else {
                        s.velocity_m_s
                    },
                    omega_rad_s: if b.sleeping {
                        DVec3::ZERO
                    } else {
                        s.angular_velocity()
                    },
                    inverse_mass: if b.sleeping { 0.0 } else { b.inverse_mass(s) },
                    inverse_inertia: if b.sleeping {
                        DMat3::ZERO
                    } else {
                        b.inverse_inertia(s)
                    },
                };
                let (bi, bj) = (&self.bodies[i], &self.bodies[j]);
                let (da, db) = (dynamics(bi, &si), dynamics(bj, &sj));
                let e = mix_restitution(bi.restitution, bj.restitution) as f64;
                let mu = mix_friction(bi.friction, bj.friction) as f64;
                let v_rel = db.point_velocity(c.point_m) - da.point_velocity(c.point_m);
                let (change, carry) = if v_rel.dot(c.normal) < -resting {
                    let j = impulse(&da, &db, c.point_m, c.normal, e, mu);
                    let change = j.map(|j| Accumulated {
                        linear_n_s: j,
                        angular_n_m_s: DVec3::ZERO,
                    });
                    (change, None)
                } else {
                    // Resting: correct the impulse this substep already carries.
                    let acc = warm
                        .iter()
                        .find(|w| (w.a, w.b) == (i, j))
                        .map_or(Accumulated::default(), |w| w.impulse.scaled(dt / w.dt_s));
                    let footprint = c.footprint(bi, bj);
                    let change =
                        resting_impulse(&da, &db, c.point_m, c.normal, mu, &footprint, acc);
                    let total = change.map_or(acc, |d| Accumulated {
                        linear_n_s: acc.linear_n_s + d.linear_n_s,
                        angular_n_m_s: acc.angular_n_m_s + d.angular_n_m_s,
                    });
                    let carried =
                        total.linear_n_s.dot(c.normal) > 0.0 && !(bi.sleeping && bj.sleeping);
                    (change, carried.then_some(total))
                };
                if let Some(change) = change {
                    self.stats.contact_impulses += 1;
                    self.apply_to_pair([i, j], change, c.point_m, [&c.zone_a, &c.zone_b]);
                    for k in [i, j] {
                        let b = &mut self.bodies[k];
                        if !b.sleeping {
                            b.max_speed_m_s =
                                b.particles.v.iter().map(|v| v.length()).fold(0.0, f32::max);
                        }
                    }
                    // Their velocities changed: a later pair re-measures them.
                    full[x] = None;
                    full[y] = None;
                }
                if let Some(total) = carry {
                    self.resting_pairs.push(RestingPair {
                        a: i,
                        b: j,
                        impulse: total,
                        dt_s: dt,
                        point_m: c.point_m,
                        zone_a: c.zone_a,
                        zone_b: c.zone_b,
                    });
                }
            }
        }
    }
}
