//! Broad and narrow phase of deformable pairs: bounding spheres and boxes, then the objects'
//! occupied grid cells, grouped into contact patches (a contact manifold), each with its own
//! point, normal and particles.

use glam::{DMat3, DVec3, IVec3, Vec3A};

use super::super::body::Body;
use super::super::measure::{BodyState, outer};

/// The largest distance, in cells along any axis, of a group's cells from its first cell
/// ([`group_cells`]): a group spans at most 5 cells, so places of contact a few cells apart (a
/// peg touching both sides of a hole, the two walls of a trough) get their own normals, and
/// the groups that face the same way are merged again ([`merge_smooth`]).
pub const PATCH_RADIUS_CELLS: i32 = 2;

/// One contact patch of a pair: groups of the cells both objects occupy that face the same way.
#[derive(Debug, Clone, PartialEq)]
pub struct Patch {
    /// Unit normal from A to B.
    pub normal: DVec3,
    /// Contact point (m): the midpoint of the two zones' centroids.
    pub point_m: DVec3,
    /// A's particles in the patch's cells (cells B occupies).
    pub zone_a: Vec<u32>,
    /// B's particles in the patch's cells (cells A occupies).
    pub zone_b: Vec<u32>,
    /// The first cells of the groups of cells it was made of ([`group_cells`]).
    seeds: Vec<IVec3>,
}

/// A detected contact between two deformable bodies: its patches, and what
/// [`Manifold::footprints`] needs.
#[derive(Debug, Clone, PartialEq)]
pub struct Manifold {
    /// The patches, in the order of their first cells.
    pub patches: Vec<Patch>,
    /// Each body's particles near the overlap, and the cells each occupies inside it (sorted).
    near: [Vec<u32>; 2],
    cells: [Vec<[i32; 3]>; 2],
    /// The overlap of the two boxes grown by a cell (m), and 1 / cell size (1/m).
    overlap_m: (DVec3, DVec3),
    inv_cell: f32,
}

impl Manifold {
    /// Where each patch may press when it rests: A's and B's particles within a cell of a cell
    /// the other occupies (where the two touch or are about to; the zones are only where they
    /// already overlap) and within a cell of the patch's extent, as offsets from the patch's
    /// point in its contact plane. Computed on demand: impacts do not need it.
    pub fn footprints(&self, a: &Body, b: &Body) -> Vec<Footprint> {
        let (lo, hi) = self.overlap_m;
        let inv_h = self.inv_cell;
        // (position, cell, whether the particle is B's).
        let mut touching: Vec<(DVec3, IVec3, bool)> = Vec::new();
        for (body, near, other, is_b) in [
            (a, &self.near[0], &self.cells[1], false),
            (b, &self.near[1], &self.cells[0], true),
        ] {
            touching.extend(near.iter().filter_map(|&i| {
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
                touches.then_some((xd, c, is_b))
            }));
        }
        let cell_m = 1.0 / f64::from(inv_h);
        self.patches
            .iter()
            .map(|p| {
                let (point, n) = (p.point_m, p.normal);
                // Each touching particle's offset in the contact plane and its height away
                // from the plane, growing away from the other object.
                let here: Vec<(DVec3, f64, bool)> = touching
                    .iter()
                    .filter(|(_, c, _)| {
                        p.seeds
                            .iter()
                            .any(|s| (*c - *s).abs().max_element() <= PATCH_RADIUS_CELLS + 1)
                    })
                    .map(|&(x, _, is_b)| {
                        let d = x - point;
                        let h = if is_b { d.dot(n) } else { -d.dot(n) };
                        (d - n * d.dot(n), h, is_b)
                    })
                    .collect();
                // How fast the gap between the two surfaces opens away from the point: the sum
                // of their curvatures (1/m).
                let curvature: f64 = [false, true]
                    .into_iter()
                    .map(|side| {
                        let points = here.iter().filter(|h| h.2 == side).map(|h| (h.0, h.1));
                        surface_curvature(points, n)
                    })
                    .sum();
                let offsets_m: Vec<DVec3> = here.iter().map(|h| h.0).collect();
                let radius_m = offsets_m.iter().map(|d| d.length()).fold(0.0, f64::max);
                let flat = curvature * radius_m * radius_m / 2.0 <= FLAT_GAP_CELLS * cell_m;
                Footprint::new(offsets_m, flat)
            })
            .collect()
    }
}

/// Where a resting contact may press: the in-plane offsets (m) from the contact point of the
/// particles where the two objects touch ([`Manifold::footprints`]). The centre of pressure must
/// lie inside it, which bounds the couple a flat contact can carry (a box standing off-centre on
/// another is held; one hanging past the edge tips).
#[derive(Debug, Clone, Default)]
pub struct Footprint {
    offsets_m: Vec<DVec3>,
    mean_arm_m: f64,
    /// Whether the two surfaces stay within [`FLAT_GAP_CELLS`] of each other across it.
    flat: bool,
}

/// A footprint is flat when the gap between the two surfaces, from their fitted curvatures,
/// opens by at most this many cells out to its edge (two faces, a box on a box); a curved one
/// (a ball on a slab) presses at its point only, so the ball rolls.
pub const FLAT_GAP_CELLS: f64 = 0.25;

/// The curvature κ (1/m) of a surface whose points lie at in-plane offsets `d` (m, normal to
/// `n`) and heights h (m, growing away from the contact), from the least-squares fit
/// h = a + g·d + κ |d|²/2 (a tilt g is a tipped flat face, not a curved one); 0 when the points
/// do not determine it (fewer than five, or all on a line).
fn surface_curvature(points: impl Iterator<Item = (DVec3, f64)>, n: DVec3) -> f64 {
    let t1 = n.any_orthonormal_vector();
    let t2 = n.cross(t1);
    let mut m = glam::DMat4::ZERO;
    let mut rhs = glam::DVec4::ZERO;
    let mut count = 0;
    for (d, h) in points {
        count += 1;
        let (u, v) = (d.dot(t1), d.dot(t2));
        let phi = glam::DVec4::new(1.0, u, v, 0.5 * (u * u + v * v));
        m += glam::DMat4::from_cols(phi * phi.x, phi * phi.y, phi * phi.z, phi * phi.w);
        rhs += phi * h;
    }
    if count < 5 || m.determinant().abs() <= 1e-30 {
        return 0.0;
    }
    let k = (m.inverse() * rhs).w;
    if k.is_finite() { k } else { 0.0 }
}

impl Footprint {
    fn new(offsets_m: Vec<DVec3>, flat: bool) -> Self {
        let mean_arm_m = if offsets_m.is_empty() {
            0.0
        } else {
            offsets_m.iter().map(|d| d.length()).sum::<f64>() / offsets_m.len() as f64
        };
        Self {
            offsets_m,
            mean_arm_m,
            flat,
        }
    }

    /// How far the pressure centre may move from the point along unit `u` (m, >= 0): the
    /// footprint's extent for a flat contact, none for a curved one (a ball rolls).
    pub fn reach_m(&self, u: DVec3) -> f64 {
        if !self.flat {
            return 0.0;
        }
        self.offsets_m.iter().map(|d| d.dot(u)).fold(0.0, f64::max)
    }

    /// Mean distance from the point (m): the arm of torsional friction (2/3 R for a disc).
    pub fn mean_arm_m(&self) -> f64 {
        self.mean_arm_m
    }
}

#[inline]
fn cell(x: Vec3A, inv_h: f32) -> IVec3 {
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

/// Groups the shared cells (sorted) into patches: each cell joins the first patch whose first
/// cell is within [`PATCH_RADIUS_CELLS`] of it along every axis, else starts one. Returns each
/// cell's patch and the patches' first cells; deterministic (the cells' order).
fn group_cells(shared: &[[i32; 3]]) -> (Vec<u32>, Vec<IVec3>) {
    let mut seeds: Vec<IVec3> = Vec::new();
    // Cells come in x order, so seeds do too: those more than the radius behind the current
    // cell in x can take no later cell, and the search starts after them.
    let mut first_in_reach = 0;
    let of_cell = shared
        .iter()
        .map(|&c| {
            let c = IVec3::from_array(c);
            while seeds
                .get(first_in_reach)
                .is_some_and(|s| s.x < c.x - PATCH_RADIUS_CELLS)
            {
                first_in_reach += 1;
            }
            let k = seeds[first_in_reach..]
                .iter()
                .position(|s| (c - *s).abs().max_element() <= PATCH_RADIUS_CELLS)
                .map(|k| k + first_in_reach)
                .unwrap_or_else(|| {
                    seeds.push(c);
                    seeds.len() - 1
                });
            k as u32
        })
        .collect();
    (of_cell, seeds)
}

/// The largest angle between a group's normal and a contact's for [`merge_smooth`] to take the
/// group as part of that contact (45°). The groups of one smooth contact (two spheres, two flat
/// faces) face within a few degrees of each other, up to ~20° where a group sits at the edge of
/// a face (its plane fit sees the edge); a peg's two sides in a hole face 180° apart, a trough's
/// walls 60° or more.
const SMOOTH_COS: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// Groups `groups` into contacts, largest group first: each joins the first contact whose normal
/// (the particle-weighted mean of its groups') is within 45° of its own, else starts one.
/// Deterministic (ties in size keep the groups' order); contacts come in the order of their
/// first groups.
fn merge_smooth(groups: Vec<Patch>) -> Vec<Vec<Patch>> {
    let size = |g: &Patch| g.zone_a.len() + g.zone_b.len();
    let mut order: Vec<usize> = (0..groups.len()).collect();
    order.sort_by_key(|&k| (std::cmp::Reverse(size(&groups[k])), k));
    let mut contacts: Vec<(DVec3, Vec<usize>)> = Vec::new();
    for k in order {
        let n = groups[k].normal;
        let joins = contacts
            .iter()
            .position(|(sum, _)| sum.normalize_or_zero().dot(n) >= SMOOTH_COS);
        let weighted = n * size(&groups[k]) as f64;
        match joins {
            Some(c) => {
                contacts[c].0 += weighted;
                contacts[c].1.push(k);
            }
            None => contacts.push((weighted, vec![k])),
        }
    }
    for (_, members) in &mut contacts {
        members.sort_unstable();
    }
    contacts.sort_by_key(|(_, members)| members[0]);
    let mut groups: Vec<Option<Patch>> = groups.into_iter().map(Some).collect();
    contacts
        .into_iter()
        .map(|(_, members)| {
            members
                .into_iter()
                .filter_map(|k| groups[k].take())
                .collect()
        })
        .collect()
}

/// Narrow phase on occupied cells of size `cell_m`; `None` when no cell is shared.
pub fn narrow_phase(
    a: &Body,
    sa: &BodyState,
    b: &Body,
    sb: &BodyState,
    cell_m: f32,
) -> Option<Manifold> {
    let inv_h = 1.0 / cell_m;
    // Only particles inside the boxes' overlap (grown by a cell) can share a cell, and the
    // normal below looks 3 cells around each contact point (which lies in that grown overlap)
    // and around points a cell to either side of it: one pass per body keeps the particles of
    // the overlap grown by 5 cells, and everything after works on those.
    let lo = sa.aabb_m.0.max(sb.aabb_m.0) - DVec3::splat(cell_m as f64);
    let hi = sa.aabb_m.1.min(sb.aabb_m.1) + DVec3::splat(cell_m as f64);
    let (lo3, hi3) = (
        (lo - DVec3::splat(4.0 * cell_m as f64)).as_vec3a(),
        (hi + DVec3::splat(4.0 * cell_m as f64)).as_vec3a(),
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
    let inside = |x: Vec3A| {
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
    let cells_a = cells_of(a, &near_a);
    let shared: Vec<[i32; 3]> = cells_a
        .iter()
        .filter(|c| cells_b.binary_search(c).is_ok())
        .copied()
        .collect();
    if shared.is_empty() {
        return None;
    }
    let (patch_of_cell, seeds) = group_cells(&shared);
    // Each body's particles in shared cells, by patch.
    let zones = |body: &Body, near: &[u32]| -> Vec<Vec<u32>> {
        let mut zones = vec![Vec::new(); seeds.len()];
        for &i in near {
            let x = body.particles.x[i as usize];
            if !inside(x) {
                continue;
            }
            if let Ok(k) = shared.binary_search(&cell(x, inv_h).to_array()) {
                zones[patch_of_cell[k] as usize].push(i);
            }
        }
        zones
    };
    let (zones_a, zones_b) = (zones(a, &near_a), zones(b, &near_b));
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
    // Each patch's normal and point from the two surfaces near the zones' midpoint: robust even
    // when its zones hold a handful of particles (zone centroids alone are not). Groups, which
    // only need to know which way they face, take the difference of the two outward normals
    // ([`surface_normal`]); the patches they make, the full [`contact_frame`].
    let reach_m = 3.0 * cell_m as f64;
    let patch = |zone_a: Vec<u32>, zone_b: Vec<u32>, seeds: Vec<IVec3>, refine: bool| {
        let (ca, cb) = (centroid(a, &zone_a), centroid(b, &zone_b));
        let point = (ca + cb) * 0.5;
        let frame = if refine {
            contact_frame([a, b], [&near_a, &near_b], point, cell_m as f64)
        } else {
            let outward = |body: &Body, near: &[u32]| surface_normal(body, near, point, reach_m);
            match (outward(a, &near_a), outward(b, &near_b)) {
                (Some(na), Some(nb)) => (na - nb).try_normalize(),
                (Some(na), None) => Some(na),
                (None, Some(nb)) => Some(-nb),
                (None, None) => None,
            }
            .map(|n| (n, point))
        };
        let (normal, point) = frame.unwrap_or_else(|| {
            let n = (cb - ca)
                .try_normalize()
                .or_else(|| (sb.com_m - sa.com_m).try_normalize())
                .unwrap_or(DVec3::Z);
            (n, point)
        });
        Patch {
            normal,
            point_m: point,
            zone_a,
            zone_b,
            seeds,
        }
    };
    let groups: Vec<(Vec<u32>, Vec<u32>, Vec<IVec3>)> = zones_a
        .into_iter()
        .zip(zones_b)
        .zip(seeds)
        .filter(|((za, zb), _)| !za.is_empty() && !zb.is_empty())
        .map(|((za, zb), seed)| (za, zb, vec![seed]))
        .collect();
    // Groups that face the same way are one smooth contact (two spheres, two flat faces, a
    // plank on two supports): merged, they get one point and one normal from all their
    // particles, and a couple over their whole footprint holds a resting pair. A single group
    // needs no merging, nor the normal it takes.
    let merged = if groups.len() < 2 {
        groups
    } else {
        let faced = groups
            .into_iter()
            .map(|(za, zb, seeds)| patch(za, zb, seeds, false))
            .collect();
        merge_smooth(faced)
            .into_iter()
            .map(|members| {
                let mut merged = (Vec::new(), Vec::new(), Vec::new());
                for m in members {
                    merged.0.extend(m.zone_a);
                    merged.1.extend(m.zone_b);
                    merged.2.extend(m.seeds);
                }
                merged
            })
            .collect()
    };
    let patches: Vec<Patch> = merged
        .into_iter()
        .map(|(za, zb, seeds)| patch(za, zb, seeds, true))
        .collect();
    (!patches.is_empty()).then_some(Manifold {
        patches,
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
    let mut moments = Moments::default();
    for &i in near {
        moments.add_within(body, i, point, reach_m * reach_m);
    }
    moments.normal()
}

/// Mass moments of particles about a sample point, for [`surface_normal`] there.
#[derive(Debug, Clone, Copy, Default)]
struct Moments {
    count: usize,
    /// Σ m (kg).
    m_kg: f64,
    /// Σ m d, d the offset from the sample point (kg m).
    first: DVec3,
    /// Σ m d dᵀ (kg m²).
    second: DMat3,
}

impl Moments {
    /// Adds particle `i` of `body` when it lies within √`reach2` (m) of `point`.
    fn add_within(&mut self, body: &Body, i: u32, point: DVec3, reach2: f64) {
        let d = body.particles.x[i as usize].as_dvec3() - point;
        if d.length_squared() <= reach2 {
            let m = body.particles.mass_kg[i as usize] as f64;
            self.count += 1;
            self.m_kg += m;
            self.first += d * m;
            self.second += outer(d, d) * m;
        }
    }

    /// The outward normal at the sample point ([`surface_normal`]).
    fn normal(&self) -> Option<DVec3> {
        if self.m_kg <= 0.0 || !self.m_kg.is_finite() {
            return None;
        }
        let centroid = self.first / self.m_kg;
        let from_centroid = (-centroid).try_normalize();
        if self.count < 4 {
            return from_centroid;
        }
        let cov = self.second * (1.0 / self.m_kg) - outer(centroid, centroid);
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
}

/// The normal (from A to B) and point of a patch whose zones' midpoint is `point` (m), from
/// the two objects' particles `near` (cells of `cell_m`); `None` when neither has particles
/// within 3 cells of it.
///
/// Each side's surface near the point is taken as a sphere of the curvature that its
/// [`surface_normal`] shows a cell to either side of the point, along two directions in the
/// contact plane (signed: convex positive; a flat face about 0, a ball of radius R about 1/R).
/// A side's normal errs by κ δ for a point δ off its true place, so the normals are combined
/// with inverse-variance weights 1/κ²: the flatter side decides (a ball on a slab: the slab's
/// normal), equal sides share it. The point then moves, by at most two cells, to where each side's
/// normal would match the contact normal, weighted by κ² (a ball touching first with a particle
/// off its axis: to below its centre). On an osculating-sphere model of each surface this is
/// the point where the two touch.
fn contact_frame(
    bodies: [&Body; 2],
    near: [&[u32]; 2],
    point: DVec3,
    cell_m: f64,
) -> Option<(DVec3, DVec3)> {
    let reach_m = 3.0 * cell_m;
    let reach2 = reach_m * reach_m;
    let (na, nb) = match [0, 1].map(|k| surface_normal(bodies[k], near[k], point, reach_m)) {
        [Some(na), Some(nb)] => (na, nb),
        [Some(na), None] => return Some((na, point)),
        [None, Some(nb)] => return Some((-nb, point)),
        [None, None] => return None,
    };
    let first = (na - nb).try_normalize().unwrap_or(na);
    let t1 = first.any_orthonormal_vector();
    let tangents = [t1, first.cross(t1)];
    // κ[side][direction] (1/m), from the normals a cell to either side, in one pass per side.
    let beside = [tangents[0], -tangents[0], tangents[1], -tangents[1]].map(|t| point + t * cell_m);
    let mut kappa = [[0.0_f64; 2]; 2];
    for (k, row) in kappa.iter_mut().enumerate() {
        let mut moments = [Moments::default(); 4];
        for &i in near[k] {
            for (m, at) in moments.iter_mut().zip(&beside) {
                m.add_within(bodies[k], i, *at, reach2);
            }
        }
        for (j, (t, kt)) in tangents.iter().zip(row.iter_mut()).enumerate() {
            if let (Some(plus), Some(minus)) =
                (moments[2 * j].normal(), moments[2 * j + 1].normal())
            {
                *kt = (plus - minus).dot(*t) / (2.0 * cell_m);
            }
        }
    }
    // A floor under κ² (a tenth of 1/reach, squared) keeps the weights finite for two flat
    // faces, which then share the normal.
    let floor2 = (0.1 / reach_m).powi(2);
    let weight = |row: [f64; 2]| 1.0 / (row[0] * row[0] + row[1] * row[1] + floor2);
    let normal = (na * weight(kappa[0]) - nb * weight(kappa[1])).try_normalize()?;
    // The same directions, turned into the plane of the contact normal.
    let Some(t1) = (tangents[0] - normal * tangents[0].dot(normal)).try_normalize() else {
        return Some((normal, point));
    };
    let mut shift = DVec3::ZERO;
    for (j, t) in [t1, normal.cross(t1)].iter().enumerate() {
        let (ka, kb) = (kappa[0][j], kappa[1][j]);
        shift -= *t * ((ka * na.dot(*t) + kb * nb.dot(*t)) / (ka * ka + kb * kb + floor2));
    }
    let shift = if shift.length() > 2.0 * cell_m {
        shift.normalize_or_zero() * (2.0 * cell_m)
    } else {
        shift
    };
    Some((normal, point + shift))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn group(normal: DVec3, particles: usize, seed: [i32; 3]) -> Patch {
        Patch {
            normal: normal.normalize(),
            point_m: DVec3::ZERO,
            zone_a: vec![0; particles],
            zone_b: vec![0; particles],
            seeds: vec![IVec3::from_array(seed)],
        }
    }

    #[test]
    fn cells_group_within_two_cells_of_their_first() {
        // A row of 12 cells along x and one cell far off it.
        let mut cells: Vec<[i32; 3]> = (0..12).map(|x| [x, 0, 0]).collect();
        cells.push([1, 9, 0]);
        cells.sort_unstable();
        let (of_cell, seeds) = group_cells(&cells);
        assert_eq!(
            seeds,
            [[0, 0, 0], [1, 9, 0], [3, 0, 0], [6, 0, 0], [9, 0, 0]].map(IVec3::from_array)
        );
        for (c, k) in cells.iter().zip(&of_cell) {
            let d = IVec3::from_array(*c) - seeds[*k as usize];
            assert!(d.abs().max_element() <= PATCH_RADIUS_CELLS, "{c:?} in {k}");
        }
    }

    #[test]
    fn groups_facing_the_same_way_merge_and_opposite_sides_do_not() {
        let tilted = DVec3::new(20f64.to_radians().sin(), 0.0, 20f64.to_radians().cos());
        let groups = vec![
            group(DVec3::X, 3, [0, 0, 0]),
            group(DVec3::Z, 9, [0, 5, 0]),
            group(-DVec3::X, 4, [0, 9, 0]),
            group(tilted, 2, [40, 0, 0]),
        ];
        let contacts = merge_smooth(groups);
        let normals: Vec<Vec<DVec3>> = contacts
            .iter()
            .map(|c| c.iter().map(|g| g.normal).collect())
            .collect();
        // In the order of their first groups; the tilted group joins the upward contact however
        // far it is (a plank on two supports is one contact).
        assert_eq!(
            normals,
            vec![vec![DVec3::X], vec![DVec3::Z, tilted], vec![-DVec3::X]]
        );
    }
}
