//! Exact contact manifolds for procedural shapes and grid colliders, from parry (the geometry
//! library rapier is built on): SAT with polygon clipping for boxes, the polygonal feature maps
//! of cylinders, GJK/EPA where nothing closed-form applies (Bergen, "Collision Detection in
//! Interactive 3D Environments", 2003), and one point for a ball.
//!
//! An object's procedural shape sits in its rest frame ([`Geometry::Analytic`] and
//! [`Geometry::Turned`]); parry's primitives sit at their own origin (a cylinder along y), so
//! each gets a local pose in the rest frame, and the object's [`Pose`] carries that to the
//! world. Sampled surfaces (level sets) and the domain bound have no exact shape here: the
//! point probes of [`super::manifold`] serve them.

use glam::{DVec3, Vec3A};
use parry3d_f64::math::{Pose as Iso, Vector};
use parry3d_f64::query::{ContactManifold, DefaultQueryDispatcher, PersistentQueryDispatcher};
use parry3d_f64::shape::{Ball, Cuboid, Cylinder, HalfSpace, Shape as ParryShape};

use super::geometry::{Geometry, Pose, RawContact};
use crate::collider::{Collider, Shape as ColliderShape};
use crate::procedural::Shape;

/// A parry primitive, built on the stack per query (no allocation).
enum Primitive {
    Ball(Ball),
    Cuboid(Cuboid),
    Cylinder(Cylinder),
    HalfSpace(HalfSpace),
}

impl Primitive {
    fn shape(&self) -> &dyn ParryShape {
        match self {
            Primitive::Ball(s) => s,
            Primitive::Cuboid(s) => s,
            Primitive::Cylinder(s) => s,
            Primitive::HalfSpace(s) => s,
        }
    }
}

fn v(x: impl Into<Vec3A>) -> Vector {
    let x: Vec3A = x.into();
    Vector::new(x.x as f64, x.y as f64, x.z as f64)
}

fn dv(x: Vector) -> DVec3 {
    DVec3::new(x.x, x.y, x.z)
}

fn q(r: glam::Quat) -> parry3d_f64::math::Rotation {
    let r = r.as_dquat();
    parry3d_f64::math::Rotation::from_xyzw(r.x, r.y, r.z, r.w)
}

/// `shape` as a parry primitive with its pose in the rest frame, turned by `turn` about the
/// shape's centre.
fn primitive(shape: &Shape, turn: glam::Quat) -> Option<(Primitive, Iso)> {
    let centre = Vec3A::from(shape.center());
    Some(match *shape {
        Shape::Sphere { radius_m, .. } => (
            Primitive::Ball(Ball::new(radius_m as f64)),
            Iso::from_parts(v(centre), q(turn)),
        ),
        Shape::Box { min_m, max_m } => {
            let half = (Vec3A::from(max_m) - Vec3A::from(min_m)) * 0.5;
            (
                Primitive::Cuboid(Cuboid::new(v(half))),
                Iso::from_parts(v(centre), q(turn)),
            )
        }
        Shape::Cylinder {
            axis,
            radius_m,
            height_m,
            ..
        } => {
            let a = Vec3A::from(axis).try_normalize()?;
            let along = glam::Quat::from_rotation_arc(glam::Vec3::Y, a.into());
            (
                Primitive::Cylinder(Cylinder::new(0.5 * height_m as f64, radius_m as f64)),
                Iso::from_parts(v(centre), q(turn * along)),
            )
        }
    })
}

/// The rest-frame-to-world isometry of `pose`: x = com + R (x0 − rest_com).
fn world(pose: &Pose) -> Iso {
    let r = pose.rotation;
    let t = pose.com_m - r * pose.rest_com_m;
    Iso::from_parts(v(t), q(r))
}

/// `g`'s exact shape placed in the world by `pose`; `None` for a sampled surface.
fn placed(g: &Geometry, pose: &Pose) -> Option<(Primitive, Iso)> {
    let (p, local) = match g {
        Geometry::Analytic(s) => primitive(s, glam::Quat::IDENTITY)?,
        Geometry::Turned { shape, rotation } => primitive(shape, *rotation)?,
        Geometry::Sampled(_) => return None,
    };
    Some((p, world(pose) * local))
}

/// The contact points of two placed primitives closer than `margin_m`, normals from the first
/// to the second; `None` when parry has no algorithm for the pair.
fn manifold(a: &(Primitive, Iso), b: &(Primitive, Iso), margin_m: f32) -> Option<Vec<RawContact>> {
    let pos12 = a.1.inverse() * b.1;
    let mut manifolds: Vec<ContactManifold<(), ()>> = Vec::new();
    DefaultQueryDispatcher
        .contact_manifolds(
            &pos12,
            a.0.shape(),
            b.0.shape(),
            margin_m as f64,
            &mut manifolds,
            &mut None,
        )
        .ok()?;
    let mut out = Vec::new();
    for (k, m) in manifolds.iter().enumerate() {
        let n = dv(a.1.rotation * m.local_n1);
        if !(n.is_finite() && n.length_squared() > 0.5) {
            continue;
        }
        for (i, c) in m.points.iter().enumerate() {
            let (p1, p2) = (dv(a.1 * c.local_p1), dv(b.1 * c.local_p2));
            if !(c.dist.is_finite() && p1.is_finite() && p2.is_finite()) {
                continue;
            }
            out.push(RawContact {
                point_m: ((p1 + p2) * 0.5).as_vec3a(),
                normal: n.as_vec3a(),
                separation_m: c.dist as f32,
                feature: ((k as u32) << 16) | i as u32,
            });
        }
    }
    Some(out)
}

/// The exact contact points of two objects' surfaces at their poses closer than `margin_m`
/// (normals from A to B); `None` unless both are procedural shapes.
pub fn between(
    (ga, pa): (&Geometry, &Pose),
    (gb, pb): (&Geometry, &Pose),
    margin_m: f32,
) -> Option<Vec<RawContact>> {
    manifold(&placed(ga, pa)?, &placed(gb, pb)?, margin_m)
}

/// The collider's shape at time `t_s` as a placed primitive; `None` for the domain bound (the
/// inside of a box).
fn collider_primitive(c: &Collider, t_s: f64) -> Option<(Primitive, Iso)> {
    let shift = c.offset(t_s);
    match c.shape {
        ColliderShape::Plane(p) => {
            let n = p.normal.as_dvec3();
            Some((
                Primitive::HalfSpace(HalfSpace::new(Vector::new(n.x, n.y, n.z))),
                Iso::from_translation(v(p.point_m + shift)),
            ))
        }
        ColliderShape::Box(b) => Some((
            Primitive::Cuboid(Cuboid::new(v((b.max_m - b.min_m) * 0.5))),
            Iso::from_translation(v((b.min_m + b.max_m) * 0.5 + shift)),
        )),
        ColliderShape::DomainBound(_) => None,
    }
}

/// The exact contact points of an object's surface at its pose with grid collider `c` at time
/// `t_s`, closer than `margin_m` (normals from the object into the collider); `None` unless
/// the object is a procedural shape and the collider a plane or a box. An inactive collider
/// has none.
pub fn against_collider(
    (g, pose): (&Geometry, &Pose),
    c: &Collider,
    t_s: f64,
    margin_m: f32,
) -> Option<Vec<RawContact>> {
    let a = placed(g, pose)?;
    let b = collider_primitive(c, t_s)?;
    if !c.is_active(t_s) {
        return Some(Vec::new());
    }
    manifold(&a, &b, margin_m)
}
