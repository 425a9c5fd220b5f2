//! Contact manifolds: the contact points of two posed surfaces, or of a surface and a grid
//! collider.
//!
//! Two procedural shapes, or a procedural shape and a plane or box collider, get parry's exact
//! manifold ([`super::exact`]), reduced as below. What follows serves sampled surfaces (level
//! sets) and the domain bound.
//!
//! Each object carries points on its own surface (rest frame). A point of A whose signed distance
//! in B is below a margin is a contact point: at that point, with B's outward normal there
//! (reversed: normals run from A to B; where the point is on a face of A and nearest an edge of
//! B, A's face normal instead) and that distance as the separation. The same is done with
//! B's points in A, so an edge or a corner of either object is caught, and several separate
//! patches (a donut on a post, a box on two supports) each get their own points. A pair keeps at
//! most [`MAX_POINTS`] spanning the contact's area, in a fixed order.
//!
//! A procedural sphere against an exact convex surface (another procedural shape, a plane or box
//! collider) is one point instead, from the other's signed distance at the sphere's centre, as
//! rigid-body engines do: the sphere's surface points are a polyhedron of the lattice's spacing,
//! and a polyhedron rolling on its vertices brakes (each vertex arriving is a small inelastic
//! impact). Against a sampled surface (a level set) a sphere touches the level set's faces at
//! their points nearest its centre (`sphere_on_sampled`).

use glam::Vec3A;

use super::geometry::{DISTANCE_LIPSCHITZ, Geometry, Placed, Pose, RawContact};
use crate::collider::Collider;
use crate::procedural::Shape;

/// Most contact points one pair keeps.
pub const MAX_POINTS: usize = 8;

/// A surface point counts when its own outward normal and the other surface's meet at more than
/// about 72° (−n_own·n_other above this cosine).
const FACING: f32 = 0.3;

/// Points farther than this fraction of the margin beyond the closest one are dropped.
const SUPPORT_BAND: f32 = 0.25;

/// Bit set in [`RawContact::feature`] for a point of B.
pub const FEATURE_OF_B: u32 = 1 << 31;

fn inside(bounds: (Vec3A, Vec3A), x: Vec3A, margin: f32) -> bool {
    x.cmpge(bounds.0 - margin).all() && x.cmple(bounds.1 + margin).all()
}

/// Calls `visit(i, rest point)` for the points of `from` that `near(world centre, radius)` of
/// their group admits (every point when `from` has no groups), group by group: a group far from
/// the other surface costs one distance instead of one per point. The order is not ascending
/// `i`; callers sort the few contacts they keep by feature.
fn candidates(
    from: &Placed,
    mut near: impl FnMut(Vec3A, f32) -> bool,
    mut visit: impl FnMut(usize, Vec3A),
) {
    match from.groups {
        Some(groups) => groups.for_each_near(
            |c, r| near(from.pose.to_world(c), r),
            |i| visit(i, from.points[i]),
        ),
        None => from
            .points
            .iter()
            .enumerate()
            .for_each(|(i, p0)| visit(i, *p0)),
    }
}

/// Points of `from` within `margin_m` of `into`'s surface, normals out of `into`, appended to
/// `out` in feature order.
fn probe(from: &Placed, into: &Placed, margin_m: f32, flag: u32, out: &mut Vec<RawContact>) {
    let rot = into.pose.rotation;
    let start = out.len();
    // A group whose centre lies farther than the margin plus its radius (times how fast the
    // distance can change) holds no point within the margin.
    let near = |c: Vec3A, r: f32| {
        if !inside(into.bounds_m, c, margin_m + r) {
            return false;
        }
        let (phi, _) = into.geometry.distance(into.pose.to_rest(c));
        !(phi.is_finite() && phi > margin_m + DISTANCE_LIPSCHITZ * r)
    };
    candidates(from, near, |i, p0| {
        let p = from.pose.to_world(p0);
        if !inside(into.bounds_m, p, margin_m) {
            return;
        }
        let (phi, n0) = into.geometry.distance(into.pose.to_rest(p));
        if !(phi < margin_m && phi.is_finite()) {
            return;
        }
        let normal = rot * n0;
        // The surfaces must face each other: a point on a side face that merely lies on the
        // other's edge plane is not a contact.
        let (_, own) = from.geometry.distance(p0);
        let own = from.pose.rotation * own;
        if own.dot(normal) > -FACING {
            return;
        }
        // A face point of `from` against an edge of `into`: the normal is the face's (the
        // edge's own normal turns from face to face across it and would push sideways).
        let normal =
            if into.geometry.near_edge(into.pose.to_rest(p)) && !from.geometry.near_edge(p0) {
                -own
            } else {
                normal
            };
        out.push(RawContact {
            point_m: p,
            normal,
            separation_m: phi,
            feature: i as u32 | flag,
        });
    });
    out[start..].sort_unstable_by_key(|c| c.feature);
}

/// Points deeper than this fraction of the margin may be flipped ([`drop_flipped`]).
const FLIP_DEPTH: f32 = 0.25;

/// A point opposes the pair's mean normal when their dot product is below this.
const FLIP_COSINE: f32 = -0.5;

/// `out` without the points that lie past the mid-plane of a thin part of the other surface.
///
/// A signed distance's normal points to the nearest surface, so a point sunk past the middle
/// of a plate, a floor slab or a thin wall takes the far face's normal and would push the pair
/// through it; such points are the deepest of the pair, so they would also decide which points
/// support it ([`reduce`]). A point deeper than [`FLIP_DEPTH`] of the margin whose normal
/// opposes the mean of the pair's normals (counted point by point, dot product below
/// [`FLIP_COSINE`]) is dropped. Contacts on two opposite sides of one pair (a peg in a hole, a
/// box under a shelf of the same captured background) keep their points: their mean is short,
/// or they are shallower than that, which the solver holds them to.
fn drop_flipped(mut out: Vec<RawContact>, margin_m: f32) -> Vec<RawContact> {
    let deep = -FLIP_DEPTH * margin_m;
    if out.iter().any(|c| c.separation_m < deep) {
        let mean = out.iter().map(|c| c.normal).sum::<Vec3A>() / out.len() as f32;
        out.retain(|c| c.separation_m >= deep || c.normal.dot(mean) >= FLIP_COSINE);
    }
    out
}

/// The manifold a pair keeps: at most [`MAX_POINTS`] points, four spanning the largest area as
/// in Bullet's and Box2D's manifold reduction (the point farthest from the points' centre, the
/// point farthest from it, the point farthest from their line, the point farthest beyond the
/// triangle's edges), then the deepest point, then, up to the limit, the points farthest from
/// those kept. Sequential impulses on a hundred coplanar points converge slowly in rotation and
/// rock a stack; a few points at the corners of the support hold it.
///
/// The choice must not flicker from substep to substep, or warm starting (which matches points
/// by position) starts from nothing and a tall stack does not converge: scores within
/// [`TIE`] of each other count as equal and go to the lowest feature, and the first point does
/// not depend on depths that a slight rocking reorders. The result is in feature order.
fn reduce(out: Vec<RawContact>, margin_m: f32) -> Vec<RawContact> {
    // Only points near the closest can support this substep; the rest are gaps.
    let closest = out
        .iter()
        .map(|c| c.separation_m)
        .fold(f32::INFINITY, f32::min);
    let out: Vec<RawContact> = out
        .into_iter()
        .filter(|c| c.separation_m <= closest + SUPPORT_BAND * margin_m)
        .collect();
    if out.len() <= MAX_POINTS {
        let mut out = out;
        out.sort_unstable_by_key(|c| c.feature);
        return out;
    }
    // Scores are squared lengths and areas: compare them with a tolerance on their scale.
    let pick = |out: &[RawContact], score: &dyn Fn(&RawContact) -> f32, scale: f32| -> usize {
        let tie = TIE * scale;
        let mut best = 0;
        let mut best_score = score(&out[0]);
        for (i, c) in out.iter().enumerate().skip(1) {
            let k = score(c);
            if k > best_score + tie || (k >= best_score - tie && c.feature < out[best].feature) {
                best = i;
                best_score = k;
            }
        }
        best
    };
    let (lo, hi) = out.iter().fold(
        (Vec3A::splat(f32::MAX), Vec3A::splat(f32::MIN)),
        |(lo, hi), c| (lo.min(c.point_m), hi.max(c.point_m)),
    );
    let size2 = (hi - lo).length_squared().max(f32::MIN_POSITIVE);
    let centre = out.iter().map(|c| c.point_m).sum::<Vec3A>() / out.len() as f32;
    let mut kept: Vec<RawContact> = Vec::with_capacity(MAX_POINTS);
    let mut rest = out;
    let take = |rest: &mut Vec<RawContact>, kept: &mut Vec<RawContact>, i: usize| {
        kept.push(rest.swap_remove(i));
    };
    let i = pick(&rest, &|c| (c.point_m - centre).length_squared(), size2);
    take(&mut rest, &mut kept, i);
    let p1 = kept[0].point_m;
    let i = pick(&rest, &|c| (c.point_m - p1).length_squared(), size2);
    take(&mut rest, &mut kept, i);
    let p2 = kept[1].point_m;
    let area = |c: &RawContact| (c.point_m - p1).cross(c.point_m - p2).length_squared();
    let i = pick(&rest, &area, size2 * size2);
    take(&mut rest, &mut kept, i);
    let p3 = kept[2].point_m;
    let side = (p2 - p1).cross(p3 - p1);
    // The fourth: largest area added on the far side of the triangle's edges.
    let beyond = |c: &RawContact| {
        let q = c.point_m;
        [(p1, p2), (p2, p3), (p3, p1)]
            .iter()
            .map(|(a, b)| (*b - *a).cross(q - *a).dot(-side).max(0.0))
            .fold(0.0, f32::max)
    };
    let i = pick(&rest, &beyond, size2 * side.length());
    take(&mut rest, &mut kept, i);
    // The deepest, when it lies inside the four (a bump under a face).
    let deepest = |c: &RawContact| -c.separation_m;
    let i = pick(&rest, &deepest, margin_m);
    if kept
        .iter()
        .all(|k| k.separation_m > rest[i].separation_m + TIE * margin_m)
    {
        take(&mut rest, &mut kept, i);
    }
    // Then the points farthest from those kept.
    while kept.len() < MAX_POINTS && !rest.is_empty() {
        let far = |c: &RawContact| {
            kept.iter()
                .map(|k| (k.point_m - c.point_m).length_squared())
                .fold(f32::INFINITY, f32::min)
        };
        let i = pick(&rest, &far, size2);
        take(&mut rest, &mut kept, i);
    }
    kept.sort_unstable_by_key(|c| c.feature);
    kept
}

/// Relative tolerance of the manifold's scores: within it, the lowest feature wins.
const TIE: f32 = 1e-3;

/// A procedural sphere's centre in the rest frame (m) and radius (m).
fn sphere(g: &Geometry) -> Option<(Vec3A, f32)> {
    match g {
        Geometry::Analytic(Shape::Sphere { center_m, radius_m })
        | Geometry::Turned {
            shape: Shape::Sphere { center_m, radius_m },
            ..
        } => Some((Vec3A::from(*center_m), *radius_m)),
        _ => None,
    }
}

/// The one contact of sphere `s` (centre in its rest frame, radius) posed by `pose` against a
/// surface whose signed distance and outward normal at a world point are `distance`: on the
/// surface below the centre, normal from the sphere into the surface.
fn sphere_contact(
    (centre, radius): (Vec3A, f32),
    pose: Pose,
    distance: impl Fn(Vec3A) -> Option<(f32, Vec3A)>,
    margin_m: f32,
) -> Vec<RawContact> {
    let c = pose.to_world(centre);
    let Some((phi, n)) = distance(c) else {
        return Vec::new();
    };
    let separation = phi - radius;
    if !(separation < margin_m && separation.is_finite() && n.is_finite()) {
        return Vec::new();
    }
    vec![RawContact {
        point_m: c - n * (radius + 0.5 * separation),
        normal: -n,
        separation_m: separation,
        feature: 0,
    }]
}

/// The contacts of sphere `s` (centre in its rest frame, radius) posed by `pose` with a sampled
/// surface `into` (a level set): for each boundary face of the level set within the margin of the
/// sphere, the face's point nearest the centre, with the normal from the centre to it (from the
/// sphere into the surface) and its distance minus the radius as the separation, the way engines
/// touch a sphere to a mesh, face by face. The faces tile the surface, so on a flat surface the
/// deepest point is the one below the centre and moves with it, and a ball rolls on as on a
/// plane; on the sphere's own sampled points it would roll on a polyhedron's vertices, each a
/// small inelastic impact. Features carry `flag` and the face index. `None` when `into` is not
/// sampled or the centre lies inside it (then the points decide).
fn sphere_on_sampled(
    (centre, radius): (Vec3A, f32),
    pose: Pose,
    into: &Placed,
    margin_m: f32,
    flag: u32,
) -> Option<Vec<RawContact>> {
    let Geometry::Sampled(ls) = into.geometry else {
        return None;
    };
    let c = into.pose.to_rest(pose.to_world(centre));
    let phi = ls.sample(c).0;
    if phi.is_nan() || phi < 0.0 {
        return None;
    }
    let mut near = ls.faces_near(c, radius + margin_m);
    near.sort_unstable_by(|(fa, qa, _), (fb, qb, _)| {
        (qa - c)
            .length_squared()
            .total_cmp(&(qb - c).length_squared())
            .then(fa.cmp(fb))
    });
    // Where the distance from the centre has a minimum: the nearest point of all (on an edge or
    // a corner when the ball hangs over one), and every face the centre projects into (the
    // floor below it, a wall beside it). A face whose nearest point is clipped to its edge
    // merely borders a nearer one: its point would be a second contact of the same surface with
    // a tilted normal. Faces meeting at the same point count once.
    let mut kept: Vec<(u32, Vec3A)> = Vec::new();
    for (k, &(face, q, projected)) in near.iter().enumerate() {
        let distinct = kept
            .iter()
            .all(|(_, p)| (*p - q).length() > 1e-3 * ls.spacing_m());
        if (k == 0 || projected) && distinct {
            kept.push((face, q));
        }
    }
    let mut out = Vec::new();
    for (face, q) in kept {
        let d = (q - c).length();
        let Some(n0) = (q - c).try_normalize() else {
            continue;
        };
        let normal = into.pose.rotation * n0;
        let separation = d - radius;
        out.push(RawContact {
            point_m: into.pose.to_world(c) + normal * (radius + 0.5 * separation),
            normal,
            separation_m: separation,
            feature: face | flag,
        });
    }
    out.sort_unstable_by_key(|c| c.feature);
    Some(reduce(out, margin_m))
}

/// The contacts of sphere `s` posed by `pose` with `other` (normals from the sphere into it,
/// features carrying `flag`): one exact point against an exact surface ([`sphere_contact`]), the
/// nearest face points against a level set ([`sphere_on_sampled`]); `None` when the centre lies
/// inside the level set (then the points decide).
fn sphere_against(
    s: (Vec3A, f32),
    pose: Pose,
    other: &Placed,
    margin_m: f32,
    flag: u32,
) -> Option<Vec<RawContact>> {
    if matches!(other.geometry, Geometry::Sampled(_)) {
        return sphere_on_sampled(s, pose, other, margin_m, flag);
    }
    let mut out = sphere_contact(s, pose, |x| Some(other.surface_at(x)), margin_m);
    for c in &mut out {
        c.feature = flag;
    }
    Some(out)
}

/// Contact points of `a` and `b` (normals from A to B) closer than `margin_m`.
pub fn between(a: &Placed, b: &Placed, margin_m: f32) -> Vec<RawContact> {
    if let Some(out) = super::exact::between((a.geometry, &a.pose), (b.geometry, &b.pose), margin_m)
    {
        return reduce(out, margin_m);
    }
    if let Some(s) = sphere(a.geometry)
        && let Some(out) = sphere_against(s, a.pose, b, margin_m, 0)
    {
        return out;
    }
    if let Some(s) = sphere(b.geometry)
        && let Some(mut out) = sphere_against(s, b.pose, a, margin_m, FEATURE_OF_B)
    {
        for c in &mut out {
            c.normal = -c.normal;
        }
        return out;
    }
    let mut out = Vec::new();
    probe(a, b, margin_m, 0, &mut out);
    for c in &mut out {
        c.normal = -c.normal;
    }
    let from_a = out.len();
    probe(b, a, margin_m, FEATURE_OF_B, &mut out);
    // B's points in A: A's outward normal already runs from A to B.
    debug_assert!(out[from_a..].iter().all(|c| c.feature & FEATURE_OF_B != 0));
    reduce(drop_flipped(out, margin_m), margin_m)
}

/// Contact points of `a` against grid collider `collider` at time `time_s` (normals from A into
/// the collider) closer than `margin_m`.
pub fn against_collider(
    a: &Placed,
    collider: &Collider,
    time_s: f64,
    margin_m: f32,
) -> Vec<RawContact> {
    if let Some(out) =
        super::exact::against_collider((a.geometry, &a.pose), collider, time_s, margin_m)
    {
        return reduce(out, margin_m);
    }
    // The domain's bound is the inside of a box: a sphere in its corner touches two walls.
    let convex = !matches!(collider.shape, crate::collider::Shape::DomainBound(_));
    if let Some(s) = sphere(a.geometry)
        && convex
    {
        return sphere_contact(s, a.pose, |x| collider.signed_distance(x, time_s), margin_m);
    }
    let mut out = Vec::new();
    // A collider's distance is exact (1-Lipschitz): a group farther than the margin plus its
    // radius holds no point within the margin.
    let near = |c: Vec3A, r: f32| {
        collider
            .signed_distance(c, time_s)
            .is_some_and(|(phi, _)| !(phi.is_finite() && phi > margin_m + r))
    };
    // A point within the margin counts where its own normal faces the collider; a point inside
    // it counts whatever its normal says: the collider's distance is exact, while a sampled
    // shape's normal can be coarse (the tip of a post thinner than a cell points sideways), and
    // leaving the point out would hide the depth until a small turn brought it back at once.
    candidates(a, near, |i, p0| {
        let p = a.pose.to_world(p0);
        if let Some((phi, n)) = collider.signed_distance(p, time_s)
            && phi < margin_m
            && (phi < 0.0 || (a.pose.rotation * a.geometry.distance(p0).1).dot(n) <= -FACING)
        {
            out.push(RawContact {
                point_m: p,
                normal: -n,
                separation_m: phi,
                feature: i as u32,
            });
        }
    });
    out.sort_unstable_by_key(|c| c.feature);
    reduce(drop_flipped(out, margin_m), margin_m)
}

#[cfg(test)]
mod tests {
    use glam::Quat;

    use super::*;
    use crate::procedural::Shape;

    fn cube(lo: [f32; 3], side: f32) -> Geometry {
        Geometry::Analytic(Shape::Box {
            min_m: lo,
            max_m: lo.map(|v| v + side),
        })
    }

    fn placed<'a>(g: &'a Geometry, pts: &'a [Vec3A], pose: Pose) -> Placed<'a> {
        let (mut lo, mut hi) = (Vec3A::splat(f32::MAX), Vec3A::splat(f32::MIN));
        for p in pts {
            let w = pose.to_world(*p);
            lo = lo.min(w);
            hi = hi.max(w);
        }
        Placed {
            geometry: g,
            points: pts,
            groups: None,
            pose,
            bounds_m: (lo, hi),
        }
    }

    #[test]
    fn a_box_on_a_box_touches_over_its_face_with_a_vertical_normal() {
        // Exact shapes: the corners of the overlap square [0.02, 0.1]² of the two faces, 1 mm
        // deep, normal straight up.
        let (ga, gb) = (cube([0.0; 3], 0.1), cube([0.02, 0.02, 0.099], 0.1));
        let (pa, pb) = (ga.surface_points(0.01), gb.surface_points(0.01));
        let c = between(
            &placed(&ga, &pa, Pose::IDENTITY),
            &placed(&gb, &pb, Pose::IDENTITY),
            1e-3,
        );
        assert_eq!(c.len(), 4, "{c:?}");
        let (mut lo, mut hi) = (Vec3A::splat(f32::MAX), Vec3A::splat(f32::MIN));
        for p in &c {
            assert!((p.normal - Vec3A::Z).length() < 1e-5, "{p:?}");
            assert!((p.separation_m + 1e-3).abs() < 1e-5);
            assert!((p.point_m.z - 0.0995).abs() < 1e-5, "{p:?}");
            lo = lo.min(p.point_m);
            hi = hi.max(p.point_m);
        }
        let corner = |v: Vec3A, x: f32| (v.x - x).abs() < 1e-5 && (v.y - x).abs() < 1e-5;
        assert!(corner(lo, 0.02) && corner(hi, 0.1), "{lo} {hi}");
    }

    #[test]
    fn a_level_set_box_on_a_box_touches_over_its_face_with_a_vertical_normal() {
        // The point probes of a sampled surface: at most MAX_POINTS spanning the overlap.
        let ga = cube([0.0; 3], 0.1);
        let gb = cube([0.02, 0.02, 0.099], 0.1);
        let ls = crate::contact::LevelSet::from_points(&gb.surface_points(0.005), 0.01, 1 << 22)
            .unwrap();
        let gb = Geometry::Sampled(ls);
        let (pa, pb) = (ga.surface_points(0.01), gb.surface_points(0.01));
        let c = between(
            &placed(&ga, &pa, Pose::IDENTITY),
            &placed(&gb, &pb, Pose::IDENTITY),
            0.02,
        );
        assert!(!c.is_empty() && c.len() <= MAX_POINTS, "{c:?}");
        for p in &c {
            assert!(p.normal.z > 0.9, "{p:?}");
        }
    }

    #[test]
    fn a_point_past_the_middle_of_a_thin_support_does_not_pull_the_pair_through() {
        // A sampled shape (4 mm cells, its surface a cell outside its points) sunk into a 4 cm
        // slab (top at z = 0): a 10 cm block 9 mm deep and, under it, a 2.8 cm plate whose top
        // lies 24 mm down, nearer the slab's bottom face. The
        // plate's top takes that face's normal (down) and is the deepest part, so without the
        // rule it alone would decide the pair; the pair must push the shape up everywhere.
        let slab = Geometry::Analytic(Shape::Box {
            min_m: [-0.15, -0.15, -0.04],
            max_m: [0.15, 0.15, 0.0],
        });
        let lattice = |lo: [f32; 3], hi: [f32; 3], out: &mut Vec<Vec3A>| {
            let h = 0.002;
            let n = |a: f32, b: f32| ((b - a) / h).round() as i32;
            for i in 0..=n(lo[0], hi[0]) {
                for j in 0..=n(lo[1], hi[1]) {
                    for k in 0..=n(lo[2], hi[2]) {
                        let (i, j, k) = (i as f32, j as f32, k as f32);
                        out.push(Vec3A::new(lo[0] + i * h, lo[1] + j * h, lo[2] + k * h));
                    }
                }
            }
        };
        let mut solid = Vec::new();
        lattice([-0.05, -0.05, -0.005], [0.05, 0.05, 0.03], &mut solid);
        lattice([-0.01, -0.01, -0.034], [0.01, 0.01, -0.028], &mut solid);
        let ls = crate::contact::LevelSet::from_points(&solid, 0.004, 1 << 22).unwrap();
        let shape = Geometry::Sampled(ls);
        let (ps, pt) = (slab.surface_points(0.01), shape.surface_points(0.004));
        let (a, b) = (
            placed(&slab, &ps, Pose::IDENTITY),
            placed(&shape, &pt, Pose::IDENTITY),
        );
        let c = between(&a, &b, 0.02);
        assert!(!c.is_empty());
        for p in &c {
            assert!(p.normal.z > 0.9, "{p:?}");
        }
        // The plate's points were there to drop: probed alone, they point down.
        let mut probed = Vec::new();
        probe(&b, &a, 0.02, FEATURE_OF_B, &mut probed);
        assert!(
            probed
                .iter()
                .any(|p| p.normal.z < -0.9 && p.point_m.z < -0.015)
        );
    }

    #[test]
    fn a_sphere_on_an_exact_surface_is_one_point_below_its_centre() {
        // A 5 cm sphere 1 mm above a box top, either way round: one point under the centre,
        // normal straight down from the sphere, separation 1 mm; none within a 0.5 mm margin.
        let ball = Geometry::Analytic(Shape::Sphere {
            center_m: [0.3, 0.2, 0.151],
            radius_m: 0.05,
        });
        let table = Geometry::Analytic(Shape::Box {
            min_m: [0.0, 0.0, 0.0],
            max_m: [0.5, 0.5, 0.1],
        });
        let (pb, pt) = (ball.surface_points(0.01), table.surface_points(0.01));
        let (b, t) = (
            placed(&ball, &pb, Pose::IDENTITY),
            placed(&table, &pt, Pose::IDENTITY),
        );
        for (c, down) in [
            (between(&b, &t, 2e-3), -Vec3A::Z),
            (between(&t, &b, 2e-3), Vec3A::Z),
        ] {
            assert_eq!(c.len(), 1, "{c:?}");
            assert!((c[0].normal - down).length() < 1e-6, "{c:?}");
            assert!((c[0].separation_m - 1e-3).abs() < 1e-6, "{c:?}");
            let expected = Vec3A::new(0.3, 0.2, 0.1005);
            assert!((c[0].point_m - expected).length() < 1e-6, "{c:?}");
        }
        assert!(between(&b, &t, 5e-4).is_empty());
    }

    #[test]
    fn a_sphere_on_a_sampled_surface_touches_each_part_of_it_once() {
        // A level set (1 cm cells) of a floor, top at z = 0, and of a wall whose face is at
        // x = 0.06; a 5 cm sphere 0.5 mm above the floor and 0.5 mm into the wall: one point
        // below its centre on the floor, one level with it on the wall, normals from the sphere
        // into each, whichever way round the pair is given.
        let mut points = Vec::new();
        for i in 0..40 {
            for j in 0..40 {
                let (x, y) = (
                    -0.2 + 0.01 * i as f32 + 0.005,
                    -0.2 + 0.01 * j as f32 + 0.005,
                );
                points.push(Vec3A::new(x, y, -0.005));
                points.push(Vec3A::new(0.065, y, 0.005 + 0.005 * i as f32));
            }
        }
        let ls = crate::contact::LevelSet::from_points(&points, 0.01, 1 << 22).unwrap();
        let scene = Geometry::Sampled(ls);
        let ball = Geometry::Analytic(Shape::Sphere {
            center_m: [0.0105, 0.0, 0.0505],
            radius_m: 0.05,
        });
        let (pb, ps) = (ball.surface_points(0.01), scene.surface_points(0.01));
        let (b, t) = (
            placed(&ball, &pb, Pose::IDENTITY),
            placed(&scene, &ps, Pose::IDENTITY),
        );
        for (mut c, sign) in [(between(&b, &t, 0.01), 1.0), (between(&t, &b, 0.01), -1.0)] {
            c.sort_by(|p, q| p.normal.z.total_cmp(&q.normal.z));
            assert_eq!(c.len(), 2, "{c:?}");
            let (floor, wall) = (
                c[if sign > 0.0 { 0 } else { 1 }],
                c[if sign > 0.0 { 1 } else { 0 }],
            );
            assert!(
                (floor.normal - sign * -Vec3A::Z).length() < 1e-5,
                "{floor:?}"
            );
            assert!((floor.separation_m - 5e-4).abs() < 1e-5, "{floor:?}");
            assert!((floor.point_m - Vec3A::new(0.0105, 0.0, 0.00025)).length() < 1e-5);
            assert!((wall.normal - sign * Vec3A::X).length() < 1e-5, "{wall:?}");
            assert!((wall.separation_m + 5e-4).abs() < 1e-5, "{wall:?}");
        }
    }

    #[test]
    fn two_separate_supports_both_keep_points() {
        // A plank on two posts: the manifold holds points on both.
        let plank = Geometry::Analytic(Shape::Box {
            min_m: [0.0, 0.0, 0.1],
            max_m: [0.5, 0.1, 0.12],
        });
        let posts = [cube([0.0, 0.0, 0.0], 0.1), cube([0.4, 0.0, 0.0], 0.1)];
        let pp = plank.surface_points(0.01);
        for (k, post) in posts.iter().enumerate() {
            let ps = post.surface_points(0.01);
            let c = between(
                &placed(&plank, &pp, Pose::IDENTITY),
                &placed(post, &ps, Pose::IDENTITY),
                1e-3,
            );
            assert!(c.len() >= 4, "post {k}");
            assert!(c.iter().all(|p| (p.normal + Vec3A::Z).length() < 1e-5));
        }
    }

    #[test]
    fn a_rotated_pose_moves_the_surface() {
        // B is A's cube turned 90° about z around its centre and lifted: still face contact.
        let g = cube([-0.05, -0.05, -0.05], 0.1);
        let pts = g.surface_points(0.02);
        let pose_b = Pose {
            rest_com_m: Vec3A::ZERO,
            com_m: Vec3A::new(0.0, 0.0, 0.1),
            rotation: Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
        };
        let c = between(
            &placed(&g, &pts, Pose::IDENTITY),
            &placed(&g, &pts, pose_b),
            1e-4,
        );
        assert!(!c.is_empty());
        assert!(
            c.iter()
                .all(|p| p.normal.z > 0.999 && p.separation_m.abs() < 1e-5)
        );
    }

    #[test]
    fn every_point_of_a_body_inside_a_collider_is_a_contact() {
        // A coarse level set (2 cm cells, as a jelly made rigid on a 2 cm grid gets) of a 6 cm
        // cube and of a cube with a 4 cm post under it, turned every way and lowered until its
        // deepest surface point is 5 mm into a plane: the manifold holds a point that deep in
        // every pose, whatever that point's own (coarse) normal says. Left out while its
        // normal faced away, the depth would appear all at once when a small turn brought it
        // back, and pushing it out would throw the body.
        let floor = Collider::fixed(
            crate::collider::Shape::Plane(
                crate::collider::Plane::new(Vec3A::ZERO, Vec3A::Z).unwrap(),
            ),
            crate::collider::Surface::Slip,
            0.5,
        );
        let grid = |lo: [i32; 3], hi: [i32; 3], out: &mut Vec<Vec3A>| {
            for i in lo[0]..=hi[0] {
                for j in lo[1]..=hi[1] {
                    for k in lo[2]..=hi[2] {
                        out.push(Vec3A::new(i as f32, j as f32, k as f32) * 0.01);
                    }
                }
            }
        };
        let mut cube = Vec::new();
        grid([-3, -3, -3], [3, 3, 3], &mut cube);
        let mut post = cube.clone();
        grid([0, 0, -7], [1, 1, -4], &mut post);
        for points in [cube, post] {
            let ls = crate::contact::LevelSet::from_points(&points, 0.02, 1 << 22).unwrap();
            let body = crate::contact::Collision::new(Geometry::Sampled(ls), 0.02, Vec3A::ZERO);
            for k in 0..200 {
                let t = k as f32;
                let turn = Quat::from_euler(glam::EulerRot::XYZ, 0.37 * t, 0.61 * t, 0.23 * t);
                let lowest = body
                    .points
                    .iter()
                    .map(|p| (turn * *p).z)
                    .fold(f32::INFINITY, f32::min);
                let lift = -0.005 - lowest;
                let placed = body.placed(glam::DVec3::new(0.0, 0.0, lift as f64), turn);
                let deepest = against_collider(&placed, &floor, 0.0, 0.02)
                    .iter()
                    .map(|c| c.separation_m)
                    .fold(f32::INFINITY, f32::min);
                assert!(
                    (deepest + 0.005).abs() < 1e-4,
                    "pose {k}: deepest {deepest}"
                );
            }
        }
    }

    fn ungrouped(p: Placed<'_>) -> Placed<'_> {
        Placed { groups: None, ..p }
    }

    #[test]
    fn skipping_far_groups_of_points_finds_exactly_the_contacts_of_every_point() {
        // A sampled (level-set) body of irregular shape, turned and moved through contact with
        // another sampled body, an exact box and a plane collider: the grouped probes must find
        // the same points, in the same order, as probing every point.
        let blob: Vec<Vec3A> = (0..4000)
            .map(|i| {
                let t = i as f32 * 0.618_034;
                let d = Vec3A::new((t * 2.1).sin(), (t * 3.7).cos(), (t * 1.3).sin()).normalize();
                d * (0.05 + 0.015 * (t * 5.0).sin())
            })
            .collect();
        let ls = crate::contact::LevelSet::from_points(&blob, 0.005, 1 << 22).unwrap();
        let a = crate::contact::Collision::new(Geometry::Sampled(ls.clone()), 0.005, Vec3A::ZERO);
        let b = crate::contact::Collision::new(Geometry::Sampled(ls), 0.005, Vec3A::ZERO);
        let slab = crate::contact::Collision::new(cube([-0.2, -0.2, -0.1], 0.2), 0.01, Vec3A::ZERO);
        let floor = Collider::fixed(
            crate::collider::Shape::Plane(
                crate::collider::Plane::new(Vec3A::ZERO, Vec3A::Z).unwrap(),
            ),
            crate::collider::Surface::Slip,
            0.5,
        );
        let mut contacts = 0;
        for k in 0..12 {
            let turn = Quat::from_euler(glam::EulerRot::XYZ, 0.3 * k as f32, 0.7, -0.2 * k as f32);
            let lift = 0.03 + 0.004 * k as f32;
            let pa = a.placed(glam::DVec3::new(0.0, 0.0, lift as f64), turn);
            let pb = b.placed(
                glam::DVec3::new(0.07, 0.01, lift as f64 + 0.02),
                Quat::IDENTITY,
            );
            let ps = slab.placed(glam::DVec3::new(0.0, 0.0, -0.0), Quat::IDENTITY);
            for (x, y) in [(pa, pb), (pb, pa), (pa, ps)] {
                let grouped = between(&x, &y, 0.01);
                assert_eq!(
                    grouped,
                    between(&ungrouped(x), &ungrouped(y), 0.01),
                    "pose {k}"
                );
                contacts += grouped.len();
            }
            let grouped = against_collider(&pa, &floor, 0.0, 0.01);
            assert_eq!(grouped, against_collider(&ungrouped(pa), &floor, 0.0, 0.01));
            contacts += grouped.len();
        }
        assert!(contacts > 50, "the poses made only {contacts} contacts");
    }
}
