//! The collision geometry of an object: an analytic signed distance for procedural shapes, a
//! sampled [`LevelSet`] otherwise, both in the object's rest frame (the world frame at t = 0), and
//! the pose that carries the rest frame to the world (x = c + R (x0 − c0)).
//!
//! Analytic distances are the standard ones (Quilez, "distance functions"; exact for the sphere
//! and the box, and for the cylinder as the 2D box distance in (radial, axial) coordinates).

use glam::{DVec3, Quat, Vec3A};

use super::level_set::LevelSet;
use crate::collider::BoxShape;
use crate::procedural::Shape;

/// The surface of an object in its rest frame.
#[derive(Debug, Clone, PartialEq)]
pub enum Geometry {
    /// A procedural shape's exact surface.
    Analytic(Shape),
    /// A level set built from the object's particles.
    Sampled(LevelSet),
    /// A procedural shape turned by `rotation` about its centre ([`Shape::center`]).
    Turned {
        /// The shape as written.
        shape: Shape,
        /// Its rotation about its centre.
        rotation: Quat,
    },
}

/// Where the rest frame is now: x = `com_m` + R (x0 − `rest_com_m`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// COM in the rest frame (m).
    pub rest_com_m: Vec3A,
    /// COM now (m).
    pub com_m: Vec3A,
    /// Rotation R from the rest frame.
    pub rotation: Quat,
}

impl Pose {
    /// The rest frame itself (static objects).
    pub const IDENTITY: Pose = Pose {
        rest_com_m: Vec3A::ZERO,
        com_m: Vec3A::ZERO,
        rotation: Quat::IDENTITY,
    };

    /// World point of rest point `x0`.
    #[inline]
    pub fn to_world(&self, x0: Vec3A) -> Vec3A {
        self.com_m + self.rotation * (x0 - self.rest_com_m)
    }

    /// Rest point of world point `x`.
    #[inline]
    pub fn to_rest(&self, x: Vec3A) -> Vec3A {
        self.rest_com_m + self.rotation.inverse() * (x - self.com_m)
    }
}

/// How far, in surface-point spacings, a box's edge points are moved into their face.
const EDGE_INSET: f32 = 0.02;

/// `x0` in a cylinder's frame: (unit axis, height above the middle along it, radial offset from
/// the axis, half height).
#[inline]
fn cylinder_frame(
    x0: Vec3A,
    base_m: [f32; 3],
    axis: [f32; 3],
    height_m: f32,
) -> (Vec3A, f32, Vec3A, f32) {
    let a = Vec3A::from(axis).try_normalize().unwrap_or(Vec3A::Z);
    let half = 0.5 * height_m;
    let d = x0 - Vec3A::from(base_m) - a * half;
    let t = d.dot(a);
    (a, t, d - a * t, half)
}

/// 2D box distance: outside length plus the inside part, for (a, b) offsets from the faces.
#[inline]
fn box2(a: f32, b: f32) -> f32 {
    Vec3A::new(a.max(0.0), b.max(0.0), 0.0).length() + a.max(b).min(0.0)
}

impl Geometry {
    /// Whether its signed distance is exact (a procedural shape), not sampled on a grid (a level
    /// set, which resolves nothing finer than its cells).
    pub fn is_exact(&self) -> bool {
        matches!(self, Geometry::Analytic(_) | Geometry::Turned { .. })
    }

    /// Whether it is exact and thinner than `thickness_m` (m) across: material can then lie
    /// behind it within a particle's stencil ([`crate::mpm::reach::NodeGaps::behind_normal`]).
    pub fn is_thinner_than(&self, thickness_m: f32) -> bool {
        match self {
            Geometry::Analytic(shape) | Geometry::Turned { shape, .. } => {
                shape.thickness_m() < thickness_m
            }
            Geometry::Sampled(_) => false,
        }
    }

    /// Signed distance (m, negative inside) at rest-frame point `x0` and the outward unit
    /// normal there (any unit vector where it is undefined).
    pub fn distance(&self, x0: Vec3A) -> (f32, Vec3A) {
        match self {
            Geometry::Turned { shape, rotation } => {
                let c = Vec3A::from(shape.center());
                let (d, n) = Geometry::Analytic(*shape).distance(c + rotation.inverse() * (x0 - c));
                (d, *rotation * n)
            }
            Geometry::Analytic(Shape::Sphere { center_m, radius_m }) => {
                let d = x0 - Vec3A::from(*center_m);
                let len = d.length();
                (len - radius_m, d.try_normalize().unwrap_or(Vec3A::Z))
            }
            Geometry::Analytic(Shape::Box { min_m, max_m }) => BoxShape {
                min_m: Vec3A::from(*min_m),
                max_m: Vec3A::from(*max_m),
            }
            .signed_distance(x0),
            Geometry::Analytic(Shape::Cylinder {
                base_m,
                axis,
                radius_m,
                height_m,
            }) => {
                let (a, t, radial, half) = cylinder_frame(x0, *base_m, *axis, *height_m);
                let rho = radial.length();
                let er = radial
                    .try_normalize()
                    .unwrap_or_else(|| a.any_orthonormal_vector());
                let (qr, qa) = (rho - radius_m, t.abs() - half);
                let phi = box2(qr, qa);
                let ea = a * t.signum();
                let n = if qr > 0.0 && qa > 0.0 {
                    (er * qr + ea * qa).normalize()
                } else if qr > qa {
                    er
                } else {
                    ea
                };
                (phi, n)
            }
            Geometry::Sampled(ls) => {
                let (phi, g) = ls.sample(x0);
                (phi, g.try_normalize().unwrap_or(Vec3A::Z))
            }
        }
    }

    /// Whether rest point `x0` is nearest an edge or a corner of a box, or the rim of a cylinder,
    /// rather than a face: there the outward normal of [`Self::distance`] turns with the point
    /// (a sphere and a level set are smooth). Inside, within 1 % of the shape's smallest
    /// half-extent of two faces counts as an edge.
    pub fn near_edge(&self, x0: Vec3A) -> bool {
        let edge = |q: &mut [f32], tol: f32| {
            if q.iter().filter(|v| **v > 0.0).count() >= 2 {
                return true;
            }
            if q.iter().any(|v| *v > 0.0) {
                return false;
            }
            q.sort_by(|a, b| b.total_cmp(a));
            q[0] - q[1] < tol
        };
        match self {
            Geometry::Turned { shape, rotation } => {
                let c = Vec3A::from(shape.center());
                Geometry::Analytic(*shape).near_edge(c + rotation.inverse() * (x0 - c))
            }
            Geometry::Analytic(Shape::Box { min_m, max_m }) => {
                let (lo, hi) = (Vec3A::from(*min_m), Vec3A::from(*max_m));
                let half = (hi - lo) * 0.5;
                let q = (x0 - (lo + hi) * 0.5).abs() - half;
                edge(&mut q.to_array(), 0.01 * half.min_element())
            }
            Geometry::Analytic(Shape::Cylinder {
                base_m,
                axis,
                radius_m,
                height_m,
            }) => {
                let (_, t, radial, half) = cylinder_frame(x0, *base_m, *axis, *height_m);
                let tol = 0.01 * radius_m.min(half);
                edge(&mut [radial.length() - radius_m, t.abs() - half], tol)
            }
            Geometry::Analytic(Shape::Sphere { .. }) | Geometry::Sampled(_) => false,
        }
    }

    /// Points on the surface (rest frame, m), about `spacing_m` apart; edges and corners of a box
    /// included.
    pub fn surface_points(&self, spacing_m: f32) -> Vec<Vec3A> {
        let s = spacing_m.max(1e-6);
        match self {
            Geometry::Turned { shape, rotation } => {
                let c = Vec3A::from(shape.center());
                Geometry::Analytic(*shape)
                    .surface_points(s)
                    .into_iter()
                    .map(|p| c + *rotation * (p - c))
                    .collect()
            }
            Geometry::Analytic(Shape::Sphere { center_m, radius_m }) => {
                let n =
                    ((4.0 * std::f32::consts::PI * radius_m * radius_m) / (s * s)).ceil() as usize;
                fibonacci_sphere(n.max(12))
                    .map(|d| Vec3A::from(*center_m) + d * *radius_m)
                    .collect()
            }
            Geometry::Analytic(Shape::Box { min_m, max_m }) => {
                // A grid on each face, its border points moved EDGE_INSET of the spacing into
                // the face: a point exactly on an edge would take either face's normal in
                // another box's distance, and aligned stacks put many points there.
                let (lo, hi) = (Vec3A::from(*min_m), Vec3A::from(*max_m));
                let n = ((hi - lo) / s).ceil().as_uvec3().max(glam::UVec3::ONE);
                let mut out = Vec::new();
                for axis in 0..3 {
                    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                    let inset = |i: u32, n: u32, len: f32| {
                        let d = (EDGE_INSET * s / len).min(0.25);
                        (i as f32 / n as f32).clamp(d, 1.0 - d)
                    };
                    for side in [lo[axis], hi[axis]] {
                        for j in 0..=n[v] {
                            for i in 0..=n[u] {
                                let mut p = Vec3A::ZERO;
                                p[axis] = side;
                                p[u] = lo[u] + (hi[u] - lo[u]) * inset(i, n[u], hi[u] - lo[u]);
                                p[v] = lo[v] + (hi[v] - lo[v]) * inset(j, n[v], hi[v] - lo[v]);
                                out.push(p);
                            }
                        }
                    }
                }
                out
            }
            Geometry::Analytic(Shape::Cylinder {
                base_m,
                axis,
                radius_m,
                height_m,
            }) => {
                let a = Vec3A::from(*axis).try_normalize().unwrap_or(Vec3A::Z);
                let (u, v) = a.any_orthonormal_pair();
                let base = Vec3A::from(*base_m);
                let around = ((std::f32::consts::TAU * radius_m) / s).ceil().max(6.0) as usize;
                let along = (height_m / s).ceil().max(1.0) as usize;
                let rings = (radius_m / s).ceil().max(1.0) as usize;
                let mut out = Vec::new();
                let ring = |r: f32, h: f32, count: usize, out: &mut Vec<Vec3A>| {
                    for k in 0..count {
                        let t = std::f32::consts::TAU * k as f32 / count as f32;
                        out.push(base + a * h + (u * t.cos() + v * t.sin()) * r);
                    }
                };
                for k in 0..=along {
                    ring(
                        *radius_m,
                        height_m * k as f32 / along as f32,
                        around,
                        &mut out,
                    );
                }
                for h in [0.0, *height_m] {
                    out.push(base + a * h);
                    for r in 1..rings {
                        let radius = radius_m * r as f32 / rings as f32;
                        let count = (around * r / rings).max(6);
                        ring(radius, h, count, &mut out);
                    }
                }
                out
            }
            Geometry::Sampled(ls) => ls.surface_points().to_vec(),
        }
    }
}

/// `n` nearly even unit directions (the Fibonacci lattice, González 2010).
fn fibonacci_sphere(n: usize) -> impl Iterator<Item = Vec3A> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..n).map(move |i| {
        let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let t = golden * i as f32;
        Vec3A::new(r * t.cos(), r * t.sin(), z)
    })
}

/// An object's collision surface: its geometry, points on it (rest frame) and the rest frame's
/// COM, the origin of its [`Pose`].
#[derive(Debug, Clone, PartialEq)]
pub struct Collision {
    /// The surface.
    pub geometry: Geometry,
    /// `[P]` points on the surface, rest frame (m).
    pub points: Vec<Vec3A>,
    /// COM in the rest frame (m).
    pub rest_com_m: Vec3A,
    /// Bounds of the surface points, rest frame (m).
    pub rest_bounds_m: (Vec3A, Vec3A),
    /// The points grouped in space, so that a query skips a group far from the other surface.
    pub groups: PointGroups,
}

impl Collision {
    /// `geometry` with surface points about `spacing_m` apart, rest COM `rest_com_m`.
    pub fn new(geometry: Geometry, spacing_m: f32, rest_com_m: Vec3A) -> Self {
        let points = geometry.surface_points(spacing_m);
        let mut lo = Vec3A::splat(f32::INFINITY);
        let mut hi = Vec3A::splat(f32::NEG_INFINITY);
        for p in &points {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        if points.is_empty() {
            (lo, hi) = (rest_com_m, rest_com_m);
        }
        let groups = PointGroups::new(&points, GROUP_CELLS * spacing_m.max(1e-6));
        Self {
            geometry,
            points,
            rest_com_m,
            rest_bounds_m: (lo, hi),
            groups,
        }
    }

    /// The surface at `com_m` turned by `rotation`.
    pub fn placed(&self, com_m: DVec3, rotation: Quat) -> Placed<'_> {
        let pose = Pose {
            rest_com_m: self.rest_com_m,
            com_m: com_m.as_vec3a(),
            rotation,
        };
        let (lo, hi) = self.rest_bounds_m;
        let mut wlo = Vec3A::splat(f32::INFINITY);
        let mut whi = Vec3A::splat(f32::NEG_INFINITY);
        for k in 0..8 {
            let corner = Vec3A::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            );
            let w = pose.to_world(corner);
            wlo = wlo.min(w);
            whi = whi.max(w);
        }
        Placed {
            geometry: &self.geometry,
            points: &self.points,
            groups: Some(&self.groups),
            pose,
            bounds_m: (wlo, whi),
        }
    }
}

/// Surface points per group: a group is the points of one cube of this many point spacings.
const GROUP_CELLS: f32 = 8.0;

/// How fast a surface's signed distance can change with position, at most (m per m): 1 for an
/// exact distance; a level set's trilinear interpolation of exact node distances has a gradient
/// of at most √3, and outside its grid it adds the distance to the grid (√3 + 1).
pub const DISTANCE_LIPSCHITZ: f32 = 3.0;

/// Surface points grouped in space (cubes of 8 point spacings): a query whose distance
/// at a group's centre exceeds its margin plus [`DISTANCE_LIPSCHITZ`] times the group's radius
/// can skip every point of the group, since no point of it can come closer.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PointGroups {
    /// Point indices, group after group (ascending within a group).
    order: Vec<u32>,
    /// Each group: its centre (m, rest frame), the radius holding its points (m) and its range
    /// of `order`.
    groups: Vec<(Vec3A, f32, std::ops::Range<usize>)>,
}

impl PointGroups {
    /// Groups `points` (rest frame, m) by cubes of side `cube_m` (m), in a fixed order.
    pub fn new(points: &[Vec3A], cube_m: f32) -> Self {
        let key = |p: Vec3A| (p / cube_m).floor().as_ivec3();
        let mut order: Vec<u32> = (0..points.len() as u32).collect();
        order.sort_by_key(|&i| {
            let k = key(points[i as usize]);
            (k.z, k.y, k.x, i)
        });
        let mut groups = Vec::new();
        let mut start = 0;
        while start < order.len() {
            let k = key(points[order[start] as usize]);
            let end = start
                + order[start..]
                    .iter()
                    .take_while(|&&i| key(points[i as usize]) == k)
                    .count();
            let members = || order[start..end].iter().map(|&i| points[i as usize]);
            let centre = members().sum::<Vec3A>() / (end - start) as f32;
            let radius = members()
                .map(|p| (p - centre).length())
                .fold(0.0f32, f32::max);
            // f32 rounding of the centre and lengths: widen by a relative 1e-5.
            groups.push((centre, radius * (1.0 + 1e-5) + 1e-7, start..end));
            start = end;
        }
        Self { order, groups }
    }

    /// Calls `visit(i)` for every point `i` of every group for which `near(centre (m, rest frame),
    /// radius (m))` holds, group by group.
    pub fn for_each_near(
        &self,
        mut near: impl FnMut(Vec3A, f32) -> bool,
        mut visit: impl FnMut(usize),
    ) {
        for (centre, radius, range) in &self.groups {
            if near(*centre, *radius) {
                self.order[range.clone()]
                    .iter()
                    .for_each(|&i| visit(i as usize));
            }
        }
    }
}

/// A surface placed in the world.
#[derive(Debug, Clone, Copy)]
pub struct Placed<'a> {
    /// Its surface.
    pub geometry: &'a Geometry,
    /// Its surface points in the rest frame (m); empty: it only receives points.
    pub points: &'a [Vec3A],
    /// The points grouped in space, when they are ([`PointGroups`]); `None`: every point is
    /// examined.
    pub groups: Option<&'a PointGroups>,
    /// Rest frame to world.
    pub pose: Pose,
    /// World bounds of the object (m).
    pub bounds_m: (Vec3A, Vec3A),
}

impl Placed<'_> {
    /// Its signed distance (m, negative inside) and outward normal (world frame) at world point
    /// `x` (m).
    pub fn surface_at(&self, x: Vec3A) -> (f32, Vec3A) {
        let (phi, n0) = self.geometry.distance(self.pose.to_rest(x));
        (phi, self.pose.rotation * n0)
    }
}

/// One contact point before solving.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RawContact {
    /// Point (m).
    pub point_m: Vec3A,
    /// Unit normal from A to B.
    pub normal: Vec3A,
    /// Separation (m): negative when penetrating.
    pub separation_m: f32,
    /// Which surface point made it (bit 31: one of B's), for warm starting.
    pub feature: u32,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn analytic_distances_are_exact() {
        let b = Geometry::Analytic(Shape::Box {
            min_m: [0.0; 3],
            max_m: [0.1, 0.2, 0.3],
        });
        let (d, n) = b.distance(Vec3A::new(0.05, 0.1, 0.35));
        assert!((d - 0.05).abs() < 1e-6 && n == Vec3A::Z);
        let (d, n) = b.distance(Vec3A::new(0.02, 0.1, 0.15));
        assert!((d + 0.02).abs() < 1e-6 && n == Vec3A::NEG_X);
        let c = Geometry::Analytic(Shape::Cylinder {
            base_m: [0.0; 3],
            axis: [0.0, 0.0, 2.0],
            radius_m: 0.01,
            height_m: 0.5,
        });
        let (d, n) = c.distance(Vec3A::new(0.03, 0.0, 0.25));
        assert!((d - 0.02).abs() < 1e-6 && (n - Vec3A::X).length() < 1e-6);
        let (d, n) = c.distance(Vec3A::new(0.0, 0.0, 0.6));
        assert!((d - 0.1).abs() < 1e-6 && (n - Vec3A::Z).length() < 1e-6);
        let s = Geometry::Analytic(Shape::Sphere {
            center_m: [1.0, 0.0, 0.0],
            radius_m: 0.5,
        });
        assert!((s.distance(Vec3A::ZERO).0 - 0.5).abs() < 1e-6);
    }

    #[test]
    fn edges_and_rims_are_told_from_faces() {
        let b = Geometry::Analytic(Shape::Box {
            min_m: [0.0; 3],
            max_m: [0.1, 0.2, 0.3],
        });
        // Beside a face, on it, inside it: a face.
        assert!(!b.near_edge(Vec3A::new(0.05, 0.1, 0.35)));
        assert!(!b.near_edge(Vec3A::new(0.05, 0.1, 0.3)));
        assert!(!b.near_edge(Vec3A::new(0.05, 0.1, 0.29)));
        // Beyond an edge, beyond a corner, inside along an edge: not.
        assert!(b.near_edge(Vec3A::new(0.12, 0.1, 0.32)));
        assert!(b.near_edge(Vec3A::new(-0.01, -0.01, -0.01)));
        assert!(b.near_edge(Vec3A::new(0.0999, 0.1, 0.2999)));
        let c = Geometry::Analytic(Shape::Cylinder {
            base_m: [0.0; 3],
            axis: [0.0, 0.0, 1.0],
            radius_m: 0.1,
            height_m: 0.5,
        });
        assert!(!c.near_edge(Vec3A::new(0.12, 0.0, 0.25)));
        assert!(c.near_edge(Vec3A::new(0.12, 0.0, 0.52)));
        let s = Geometry::Analytic(Shape::Sphere {
            center_m: [0.0; 3],
            radius_m: 0.5,
        });
        assert!(!s.near_edge(Vec3A::new(0.6, 0.0, 0.0)));
    }

    #[test]
    fn surface_points_lie_on_the_surface() {
        let shapes = [
            Shape::Sphere {
                center_m: [0.1, 0.2, 0.3],
                radius_m: 0.05,
            },
            Shape::Box {
                min_m: [0.0; 3],
                max_m: [0.1, 0.05, 0.02],
            },
            Shape::Cylinder {
                base_m: [0.0; 3],
                axis: [1.0, 1.0, 0.0],
                radius_m: 0.03,
                height_m: 0.1,
            },
        ];
        for shape in shapes {
            let g = Geometry::Analytic(shape);
            let pts = g.surface_points(0.01);
            assert!(pts.len() > 20, "{shape:?}");
            for p in pts {
                assert!(g.distance(p).0.abs() < 1e-5, "{shape:?} {p}");
            }
        }
    }

    #[test]
    fn a_pose_round_trips() {
        let pose = Pose {
            rest_com_m: Vec3A::new(0.1, 0.2, 0.3),
            com_m: Vec3A::new(-1.0, 0.5, 2.0),
            rotation: Quat::from_rotation_y(0.7),
        };
        let x = Vec3A::new(0.3, -0.2, 0.9);
        assert!((pose.to_rest(pose.to_world(x)) - x).length() < 1e-6);
    }
}
