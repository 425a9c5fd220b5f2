//! How deep the bodies of a scene lie inside each other and inside the ground and walls at the
//! end of a run, measured on the scene's exact shapes (parry's `contact` query, the geometry
//! rapier is built on) at each body's final pose, the same way for every engine.
//!
//! A body's geometric centre follows its centre of mass rigidly: c = com + R (c₀ − com₀), with
//! c₀ and com₀ at the start and R its rotation from the start pose; its shape is turned by
//! R · q₀, q₀ its start orientation ([`super::scenes::BodySpec::orientation_wxyz`]). The
//! splatphys bodies are particle clouds whose outermost particles sit up to about half a
//! lattice spacing inside the nominal shape (jittered cell centres); the depth here is always
//! that of the nominal shapes, whatever surface a solver makes of them.

use glam::{DQuat, DVec3};
use rapier3d::parry::query;
use rapier3d::parry::shape::{Ball, Cuboid, HalfSpace, Shape};
use rapier3d::prelude::{Pose, Rotation, Vec3};

use super::scenes::{BodyShape, ContactScene};
use super::{FinalBody, MassProps};

fn v3(v: DVec3) -> Vec3 {
    Vec3::new(v.x as f32, v.y as f32, v.z as f32)
}

fn pose(center: DVec3, q: DQuat) -> Pose {
    Pose::from_parts(
        v3(center),
        Rotation::from_xyzw(q.x as f32, q.y as f32, q.z as f32, q.w as f32),
    )
}

fn shape(s: BodyShape) -> Box<dyn Shape> {
    match s {
        BodyShape::Cuboid { half_extents_m } => {
            Box::new(Cuboid::new(Vec3::from_array(half_extents_m)))
        }
        BodyShape::Ball { radius_m } => Box::new(Ball::new(radius_m)),
    }
}

/// Depth (m, >= 0) of the deepest overlap between `a` and `b` at their poses; 0 when apart.
fn depth(pa: &Pose, a: &dyn Shape, pb: &Pose, b: &dyn Shape) -> f64 {
    match query::contact(pa, a, pb, b, 0.0) {
        Ok(Some(c)) => f64::from(-c.dist).max(0.0),
        // Every pair here (box, ball, half-space) is supported; treat the impossible as apart.
        _ => 0.0,
    }
}

/// The deepest overlap (m) of any body with another body, the ground or a wall, with the bodies
/// at `end` (mass properties `mass` from the start).
pub fn max_penetration_m(scene: &ContactScene, mass: &[MassProps], end: &[FinalBody]) -> f64 {
    let bodies: Vec<(Pose, Box<dyn Shape>, DVec3, f64)> = scene
        .bodies
        .iter()
        .zip(mass)
        .zip(end)
        .map(|((b, m), f)| {
            let c0 = DVec3::from(b.center_m.map(f64::from));
            let center = f.com_m + f.orientation * (c0 - m.com_m);
            let r = f64::from(b.shape.bounding_radius_m());
            let turn = (f.orientation * b.orientation()).normalize();
            (pose(center, turn), shape(b.shape), center, r)
        })
        .collect();
    let ground = HalfSpace::new(Vec3::Z);
    let walls: Vec<(Pose, Cuboid)> = scene
        .walls
        .iter()
        .map(|[lo, hi]| {
            let (lo, hi) = (Vec3::from_array(*lo), Vec3::from_array(*hi));
            let h = (hi - lo) / 2.0;
            (Pose::from_translation(lo + h), Cuboid::new(h))
        })
        .collect();
    let mut deepest = 0.0f64;
    for (i, (pa, a, ca, ra)) in bodies.iter().enumerate() {
        // Half-space first: parry 0.31 answers (shape, half-space) as if the shape were all
        // inside (the test below pins the order that measures the depth).
        deepest = deepest.max(depth(&Pose::IDENTITY, &ground, pa, a.as_ref()));
        for (pw, w) in &walls {
            deepest = deepest.max(depth(pa, a.as_ref(), pw, w));
        }
        for (pb, b, cb, rb) in &bodies[i + 1..] {
            if (*ca - *cb).length() <= ra + rb {
                deepest = deepest.max(depth(pa, a.as_ref(), pb, b.as_ref()));
            }
        }
    }
    deepest
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::scenes::{BodySpec, IDENTITY_WXYZ, SceneKind};

    /// The deepest overlap of `bodies` (shape, start centre, drop), unrotated, next to a wall
    /// filling x >= 0.25 m.
    fn deepest(bodies: &[(BodyShape, [f32; 3], f64)]) -> f64 {
        let axis_aligned: Vec<_> = bodies
            .iter()
            .map(|&(s, c, dz)| (s, c, dz, IDENTITY_WXYZ))
            .collect();
        deepest_turned(&axis_aligned, DQuat::IDENTITY)
    }

    /// The deepest overlap of `bodies` (shape, start centre, drop, start orientation) when each
    /// ends `drop` lower than it started, turned by `turn` about its centre, next to the wall.
    fn deepest_turned(bodies: &[(BodyShape, [f32; 3], f64, [f32; 4])], turn: DQuat) -> f64 {
        let scene = ContactScene {
            kind: SceneKind::Pile,
            bodies: bodies
                .iter()
                .map(|(shape, c, _, q)| BodySpec {
                    name: "b".into(),
                    shape: *shape,
                    center_m: *c,
                    orientation_wxyz: *q,
                    settle_drop_m: None,
                })
                .collect(),
            walls: vec![[[0.25, -1.0, 0.0], [0.3, 1.0, 1.0]]],
        };
        let mass: Vec<MassProps> = bodies
            .iter()
            .map(|(_, c, _, _)| MassProps {
                mass_kg: 1.0,
                com_m: DVec3::from(c.map(f64::from)),
                inertia_kg_m2: glam::DMat3::IDENTITY,
            })
            .collect();
        // Every body ends `dz` lower than it started.
        let end: Vec<FinalBody> = bodies
            .iter()
            .map(|(_, c, dz, _)| FinalBody {
                com_m: DVec3::from(c.map(f64::from)) - DVec3::Z * *dz,
                orientation: turn,
                velocity_m_s: DVec3::ZERO,
                omega_rad_s: DVec3::ZERO,
                asleep: false,
            })
            .collect();
        max_penetration_m(&scene, &mass, &end)
    }

    #[test]
    fn overlap_is_the_depth_of_the_deepest_pair() {
        let cube = BodyShape::Cuboid {
            half_extents_m: [0.05; 3],
        };
        let ball = BodyShape::Ball { radius_m: 0.03 };
        // f32 poses and shapes: depths hold to well under a micrometre.
        let close = |got: f64, want: f64| (got - want).abs() < 1e-6;
        // Resting on the ground, touching: nothing; floating: nothing.
        assert!(close(deepest(&[(cube, [0.0, 0.0, 0.05], 0.0)]), 0.0));
        assert!(close(deepest(&[(cube, [0.0, 0.0, 1.0], 0.0)]), 0.0));
        // Sunk 3 mm into the ground.
        assert!(close(deepest(&[(cube, [0.0, 0.0, 0.05], 0.003)]), 0.003));
        // A box 4 mm into the one below it (the lower one on the ground).
        let stacked = [
            (cube, [0.0, 0.0, 0.05], 0.0),
            (cube, [0.0, 0.0, 0.15], 0.004),
        ];
        assert!(close(deepest(&stacked), 0.004));
        assert!(close(deepest(&[(ball, [0.0, 0.0, 0.03], 0.002)]), 0.002));
        // A ball 5 mm into the wall, another 1 mm into a box.
        assert!(close(deepest(&[(ball, [0.225, 0.0, 0.5], 0.0)]), 0.005));
        let ball_on_box = [
            (cube, [0.0, 0.0, 0.05], 0.0),
            (ball, [0.0, 0.0, 0.13], 0.001),
        ];
        assert!(close(deepest(&ball_on_box), 0.001));
    }

    #[test]
    fn overlap_follows_the_start_orientation_and_the_turn() {
        let cube = BodyShape::Cuboid {
            half_extents_m: [0.05; 3],
        };
        let close = |got: f64, want: f64| (got - want).abs() < 1e-6;
        let z45 = DQuat::from_rotation_z(std::f64::consts::FRAC_PI_4);
        let q45 = [z45.w, z45.x, z45.y, z45.z].map(|v| v as f32);
        // A cube 1 cm clear of the wall axis-aligned; turned 45° about z its edge reaches
        // 0.05 √2 = 70.7 mm from its centre, 10.7 mm into the wall, whether it started turned
        // or turned during the run.
        let at = [0.19, 0.0, 0.5];
        let want = 0.19 + 0.05 * std::f64::consts::SQRT_2 - 0.25;
        assert!(close(deepest(&[(cube, at, 0.0)]), 0.0));
        let started = deepest_turned(&[(cube, at, 0.0, q45)], DQuat::IDENTITY);
        assert!(close(started, want), "{started}");
        let turned = deepest_turned(&[(cube, at, 0.0, IDENTITY_WXYZ)], z45);
        assert!(close(turned, want), "{turned}");
        // Started turned 45° and turned back during the run: axis-aligned again, clear.
        let back = deepest_turned(&[(cube, at, 0.0, q45)], z45.inverse());
        assert!(close(back, 0.0), "{back}");
    }
}
