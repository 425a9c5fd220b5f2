//! Contact patches: the points of one pair whose normals agree, with their friction (one
//! Coulomb cone at the centre of pressure, one torsional friction and the pair's rolling
//! resistance) and, on a flat face, their normal impulses as one block ([`super::block`]). The
//! solver's module docs give the rules.

use glam::DVec3;

use super::block::{MAX_BLOCK, NormalBlock};
use super::rows::{ContactPoint, Row, SolverBody, apply_pair, apply_twist, effective, relative};

/// Points of one pair whose normals meet within this cosine (about 18°) share a friction patch.
pub const PATCH_COS: f64 = 0.95;

/// A patch's normal impulses are solved as a block when all its points' normals lie within
/// this cosine (about 2.6°) of the patch normal: a flat face on a flat face. Points of a curved
/// or rough contact (a level set on captured ground) that lie close together with different
/// normals make K ill-conditioned, and an exact step then trades large impulses between them.
pub const BLOCK_COS: f64 = 0.999;

/// The points of one pair that share a normal: their friction as solved, and their normal
/// impulses' block ([`NormalBlock`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ContactPatch {
    /// Body A.
    pub a: usize,
    /// Body B.
    pub b: usize,
    /// Indices of its points in the contact slice.
    pub points: Vec<usize>,
    /// Unit normal from A to B: the mean of its points' normals.
    pub normal: DVec3,
    /// Where the tangential impulse acts (m): the centre of pressure.
    pub anchor_m: DVec3,
    /// Tangential impulse on B (N s).
    pub tangent_impulse: DVec3,
    /// Torsional impulse on B about `normal` (N m s).
    pub twist_impulse: f64,
    /// Rolling-resistance angular impulse on B, in the tangent plane (N m s).
    pub(super) rolling_impulse: DVec3,
    /// Coulomb friction μ of the pair.
    friction: f64,
    /// Rolling resistance b of the pair (m).
    rolling_resistance_m: f64,
    ra: DVec3,
    rb: DVec3,
    tangents: [DVec3; 2],
    /// Inverse of the 2×2 tangent effective mass, row-major.
    k_t_inv: [f64; 4],
    /// Inverse of the torsional effective inertia (kg m²).
    k_twist_inv: f64,
    /// Inverse of the 2×2 rolling effective inertia in the tangent plane, row-major (kg m²).
    k_roll_inv: [f64; 4],
    /// The points' normal impulses as one block; `None` for a single point, normals that
    /// disagree or a degenerate K.
    block: Option<NormalBlock>,
}

/// The normal velocity at a point (arm `ri`, normal `ni`) of `body` from a unit impulse along
/// `nj` at arm `rj`: 1/m ni·nj + (ri × ni)·I⁻¹(rj × nj).
fn coupling(body: &SolverBody, ri: DVec3, ni: DVec3, rj: DVec3, nj: DVec3) -> f64 {
    if body.inverse_mass == 0.0 {
        return 0.0;
    }
    body.inverse_mass * ni.dot(nj) + ri.cross(ni).dot(body.inverse_inertia * rj.cross(nj))
}

/// The block of `points`' normal impulses, when there are at least two, each has a valid
/// effective mass and a normal within [`BLOCK_COS`] of `normal`.
fn normal_block(
    bodies: &[SolverBody],
    contacts: &[ContactPoint],
    rows: &[Row],
    points: &[usize],
    normal: DVec3,
) -> Option<NormalBlock> {
    if points.iter().any(|&i| {
        !(rows[i].k_n > 0.0 && rows[i].k_n.is_finite())
            || contacts[i].normal.dot(normal) < BLOCK_COS
    }) {
        return None;
    }
    let len = points.len();
    if !(2..=MAX_BLOCK).contains(&len) {
        return None;
    }
    let mut k = [0.0; MAX_BLOCK * MAX_BLOCK];
    for (r, &i) in points.iter().enumerate() {
        for (col, &j) in points.iter().enumerate() {
            let (ci, cj) = (&contacts[i], &contacts[j]);
            k[r * len + col] =
                coupling(&bodies[ci.a], rows[i].ra, ci.normal, rows[j].ra, cj.normal)
                    + coupling(&bodies[ci.b], rows[i].rb, ci.normal, rows[j].rb, cj.normal);
        }
    }
    NormalBlock::new(&k[..len * len], len)
}

/// Groups `contacts` into friction patches (module docs) and builds each one's constants.
pub(super) fn patches(
    bodies: &[SolverBody],
    contacts: &[ContactPoint],
    rows: &mut [Row],
    blocks: bool,
) -> Vec<ContactPatch> {
    // Points of a pair come one after another; a pair with several normals gets several patches.
    let mut groups: Vec<(usize, usize, DVec3, Vec<usize>)> = Vec::new();
    let mut pair_start = 0;
    for (i, c) in contacts.iter().enumerate() {
        if groups
            .last()
            .is_none_or(|g: &(usize, usize, DVec3, Vec<usize>)| (g.0, g.1) != (c.a, c.b))
        {
            pair_start = groups.len();
        }
        match groups[pair_start..]
            .iter_mut()
            .find(|g| g.2.dot(c.normal) >= PATCH_COS)
        {
            Some(g) => g.3.push(i),
            None => groups.push((c.a, c.b, c.normal, vec![i])),
        }
    }
    groups
        .into_iter()
        .map(|(a, b, _, points)| ContactPatch::new(bodies, contacts, rows, a, b, points, blocks))
        .collect()
}

impl ContactPatch {
    fn new(
        bodies: &[SolverBody],
        contacts: &[ContactPoint],
        rows: &mut [Row],
        a: usize,
        b: usize,
        points: Vec<usize>,
        block: bool,
    ) -> Self {
        let normal = points
            .iter()
            .map(|&i| contacts[i].normal)
            .sum::<DVec3>()
            .normalize_or(contacts[points[0]].normal);
        // Centre of pressure of the last substep (its warm-start impulses); the points' centre
        // when there were none.
        let load: f64 = points.iter().map(|&i| contacts[i].normal_impulse).sum();
        let weight = |i: usize| {
            if load > 0.0 {
                contacts[i].normal_impulse / load
            } else {
                1.0 / points.len() as f64
            }
        };
        let anchor_m: DVec3 = points
            .iter()
            .map(|&i| contacts[i].point_m * weight(i))
            .sum();
        for &i in &points {
            let d = contacts[i].point_m - anchor_m;
            rows[i].arm_m = (d - normal * d.dot(normal)).length();
        }
        let ra = anchor_m - bodies[a].com_m;
        let rb = anchor_m - bodies[b].com_m;
        let (t0, t1) = normal.any_orthonormal_pair();
        let k00 = effective(bodies, a, b, ra, rb, t0, t0);
        let k01 = effective(bodies, a, b, ra, rb, t0, t1);
        let k11 = effective(bodies, a, b, ra, rb, t1, t1);
        let k_t_inv = inverse_2x2(k00, k01, k11);
        let inverse_inertia = bodies[a].inverse_inertia + bodies[b].inverse_inertia;
        let k_roll = |d: DVec3, e: DVec3| d.dot(inverse_inertia * e);
        let k_roll_inv = inverse_2x2(k_roll(t0, t0), k_roll(t0, t1), k_roll(t1, t1));
        let k_twist = normal.dot(bodies[a].inverse_inertia * normal)
            + normal.dot(bodies[b].inverse_inertia * normal);
        let k_twist_inv = if k_twist > 0.0 && k_twist.is_finite() {
            1.0 / k_twist
        } else {
            0.0
        };
        // Warm start: the points' stored shares, the tangential part projected on the plane.
        let mut tangent_impulse: DVec3 = points.iter().map(|&i| contacts[i].tangent_impulse).sum();
        tangent_impulse -= normal * tangent_impulse.dot(normal);
        let mut twist_impulse: f64 = points.iter().map(|&i| contacts[i].twist_impulse).sum();
        if k_t_inv == [0.0; 4] {
            tangent_impulse = DVec3::ZERO;
        }
        if k_twist_inv == 0.0 {
            twist_impulse = 0.0;
        }
        let block = block
            .then(|| normal_block(bodies, contacts, rows, &points, normal))
            .flatten();
        Self {
            a,
            b,
            friction: contacts[points[0]].friction,
            rolling_resistance_m: contacts[points[0]].rolling_resistance_m,
            points,
            normal,
            anchor_m,
            tangent_impulse,
            twist_impulse,
            rolling_impulse: DVec3::ZERO,
            ra,
            rb,
            tangents: [t0, t1],
            k_t_inv,
            k_twist_inv,
            k_roll_inv,
            block,
        }
    }

    /// The block of its normal impulses, when it has one.
    pub(super) fn block(&self) -> Option<&NormalBlock> {
        self.block.as_ref()
    }

    /// Applies the friction it starts from (its points' stored shares) to the bodies.
    pub(super) fn warm_start_friction(&self, bodies: &mut [SolverBody]) {
        let (a, b) = (self.a, self.b);
        apply_pair(bodies, a, b, self.ra, self.rb, self.tangent_impulse);
        apply_twist(bodies, a, b, self.normal * self.twist_impulse);
    }

    /// One block step of the patch's normal impulses ([`NormalBlock`]); `false`, with nothing
    /// changed, when the patch has no block or the step would make an impulse negative.
    pub(super) fn solve_normal_block(
        &self,
        bodies: &mut [SolverBody],
        contacts: &mut [ContactPoint],
        rows: &[Row],
    ) -> bool {
        let Some(block) = &self.block else {
            return false;
        };
        let points = &self.points;
        let mut residual = [0.0; MAX_BLOCK];
        for (r, &i) in residual.iter_mut().zip(points) {
            let (c, row) = (&contacts[i], &rows[i]);
            let vn = relative(bodies, c.a, c.b, row.ra, row.rb).dot(c.normal);
            *r = row.target_vn - vn;
        }
        let step = block.step(&residual);
        if points
            .iter()
            .zip(step)
            .any(|(&i, d)| contacts[i].normal_impulse + d < 0.0)
        {
            return false;
        }
        for (&i, d) in points.iter().zip(step) {
            let (c, row) = (&mut contacts[i], &rows[i]);
            c.normal_impulse += d;
            apply_pair(bodies, c.a, c.b, row.ra, row.rb, c.normal * d);
        }
        true
    }

    /// One iteration of the patch's tangential and torsional friction.
    pub(super) fn solve_friction(
        &mut self,
        bodies: &mut [SolverBody],
        contacts: &[ContactPoint],
        rows: &[Row],
    ) {
        let (a, b) = (self.a, self.b);
        let limit = |arm: &dyn Fn(usize) -> f64| {
            self.points
                .iter()
                .map(|&i| self.friction * contacts[i].normal_impulse * arm(i))
                .sum::<f64>()
        };
        if self.k_t_inv != [0.0; 4] {
            let vt = relative(bodies, a, b, self.ra, self.rb);
            let d = self.tangent_step(self.k_t_inv, vt);
            let total = clamp_length(self.tangent_impulse + d, limit(&|_| 1.0));
            let delta = total - self.tangent_impulse;
            self.tangent_impulse = total;
            apply_pair(bodies, a, b, self.ra, self.rb, delta);
        }
        if self.k_twist_inv > 0.0 {
            let spin = (bodies[b].omega_rad_s - bodies[a].omega_rad_s).dot(self.normal);
            let max = limit(&|i| rows[i].arm_m);
            let total = (self.twist_impulse - spin * self.k_twist_inv).clamp(-max, max);
            let delta = total - self.twist_impulse;
            self.twist_impulse = total;
            apply_twist(bodies, a, b, self.normal * delta);
        }
        if self.rolling_resistance_m > 0.0 && self.k_roll_inv != [0.0; 4] {
            // Rolling resistance: a couple in the tangent plane against the relative rolling,
            // at most b Σ P_n (the lever-arm form of rolling friction; Box2D v3's rolling
            // resistance).
            let w = bodies[b].omega_rad_s - bodies[a].omega_rad_s;
            let d = self.tangent_step(self.k_roll_inv, w);
            let load: f64 = self
                .points
                .iter()
                .map(|&i| contacts[i].normal_impulse)
                .sum();
            let total = clamp_length(self.rolling_impulse + d, self.rolling_resistance_m * load);
            let delta = total - self.rolling_impulse;
            self.rolling_impulse = total;
            apply_twist(bodies, a, b, delta);
        }
    }
}

impl ContactPatch {
    /// The impulse in the tangent plane that cancels the tangential part of `w` (a relative
    /// velocity or angular velocity) through `k_inv`, the inverse of that part's 2×2
    /// effective mass: −(K⁻¹ (w·t0, w·t1)) in the tangents' basis.
    fn tangent_step(&self, k_inv: [f64; 4], w: DVec3) -> DVec3 {
        let [t0, t1] = self.tangents;
        let (x, y) = (w.dot(t0), w.dot(t1));
        -(t0 * (k_inv[0] * x + k_inv[1] * y) + t1 * (k_inv[2] * x + k_inv[3] * y))
    }
}

/// `v` shortened to length `max` when longer (zero when `max` is not positive): a cone's or a
/// disc's clamp of an accumulated impulse.
fn clamp_length(v: DVec3, max: f64) -> DVec3 {
    let len = v.length();
    if len <= max {
        v
    } else if max > 0.0 {
        v * (max / len)
    } else {
        DVec3::ZERO
    }
}

/// The inverse of the symmetric 2×2 matrix [[k00, k01], [k01, k11]], row-major; zero when it
/// is singular or not finite.
fn inverse_2x2(k00: f64, k01: f64, k11: f64) -> [f64; 4] {
    let det = k00 * k11 - k01 * k01;
    if det > 1e-12 * (k00 * k11).max(f64::MIN_POSITIVE) && det.is_finite() {
        [k11 / det, -k01 / det, -k01 / det, k00 / det]
    } else {
        [0.0; 4]
    }
}

/// Each point keeps its share of its patch's friction, in proportion to its normal impulse,
/// for the next warm start.
pub(super) fn share_friction(contacts: &mut [ContactPoint], patches: &[ContactPatch]) {
    for patch in patches {
        let total: f64 = patch
            .points
            .iter()
            .map(|&i| contacts[i].normal_impulse)
            .sum();
        for &i in &patch.points {
            let w = if total > 0.0 {
                contacts[i].normal_impulse / total
            } else {
                1.0 / patch.points.len() as f64
            };
            contacts[i].tangent_impulse = patch.tangent_impulse * w;
            contacts[i].twist_impulse = patch.twist_impulse * w;
        }
    }
}
