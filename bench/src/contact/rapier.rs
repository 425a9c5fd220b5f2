//! The rapier3d side of `bench contact`: the same [`ContactScene`] as rapier bodies in the same
//! process, for a reference measured on the same machine in the same run.
//!
//! Each body is a dynamic rigid body posed at its geometric centre and start orientation, with
//! one cuboid or ball collider of the scene's size; its mass, centre of mass and inertia tensor
//! are the ones the splatphys world computed from its particles ([`MassProps`], world axes at
//! the start, turned into the body frame here), so both engines move the same masses. The
//! ground is a half-space, the walls fixed cuboids. Every collider has the scene's friction and
//! restitution, gravity is the world's, the time step is fixed (`dt_s`), sleeping is off
//! (`can_sleep(false)`), and everything else is rapier's default (`IntegrationParameters`,
//! combine rules, no CCD, single-threaded: the `parallel` feature is not enabled).

use std::time::Instant;

use anyhow::{Result, ensure};
use glam::{DMat3, DQuat, DVec3};
use rapier3d::prelude::{
    ColliderBuilder, MassProperties, Mat3, PhysicsWorld, Pose, RigidBodyBuilder, RigidBodyHandle,
    Rotation, SharedShape, Vec3,
};

use super::scenes::{BodyShape, ContactScene, ContactSettings};
use super::{EngineRun, FinalBody, MassProps, Progress};
use splatphys::trace::process_cpu_s;

/// The rapier version linked in, for tables and file rows.
pub const VERSION: &str = rapier3d::VERSION;

fn v3(v: DVec3) -> Vec3 {
    Vec3::new(v.x as f32, v.y as f32, v.z as f32)
}

fn dv3(v: Vec3) -> DVec3 {
    DVec3::new(f64::from(v.x), f64::from(v.y), f64::from(v.z))
}

fn m3(m: DMat3) -> Mat3 {
    Mat3::from_cols_array(&m.to_cols_array().map(|v| v as f32))
}

/// Builds `scene` in a rapier world: bodies in scene order, with the masses of `mass`.
///
/// # Errors
/// When `mass` does not hold one entry per body.
pub fn build(
    scene: &ContactScene,
    settings: &ContactSettings,
    mass: &[MassProps],
    gravity_m_s2: DVec3,
    dt_s: f64,
) -> Result<(PhysicsWorld, Vec<RigidBodyHandle>)> {
    ensure!(
        mass.len() == scene.bodies.len(),
        "{} mass properties for {} bodies",
        mass.len(),
        scene.bodies.len()
    );
    let (mu, e) = (settings.friction, settings.restitution);
    let mut world = PhysicsWorld::new();
    world.gravity = v3(gravity_m_s2);
    world.integration_parameters.dt = dt_s as f32;
    let ground = ColliderBuilder::new(SharedShape::halfspace(Vec3::Z))
        .friction(mu)
        .restitution(e);
    world.insert_collider(ground, None);
    for [lo, hi] in &scene.walls {
        let (lo, hi) = (Vec3::from_array(*lo), Vec3::from_array(*hi));
        let h = (hi - lo) / 2.0;
        let wall = ColliderBuilder::cuboid(h.x, h.y, h.z)
            .translation(lo + h)
            .friction(mu)
            .restitution(e);
        world.insert_collider(wall, None);
    }
    let mut handles = Vec::with_capacity(scene.bodies.len());
    for (b, m) in scene.bodies.iter().zip(mass) {
        let center = Vec3::from_array(b.center_m);
        let q0 = b.orientation();
        let rotation = Rotation::from_xyzw(q0.x as f32, q0.y as f32, q0.z as f32, q0.w as f32);
        let body = RigidBodyBuilder::dynamic()
            .pose(Pose::from_parts(center, rotation))
            .can_sleep(false);
        let collider = match b.shape {
            BodyShape::Cuboid { half_extents_m: h } => ColliderBuilder::cuboid(h[0], h[1], h[2]),
            BodyShape::Ball { radius_m } => ColliderBuilder::ball(radius_m),
        };
        // Rapier takes the centre of mass and the inertia in the body frame: Rᵀ (com − c) and
        // Rᵀ I R, with R the start orientation.
        let r = DMat3::from_quat(q0);
        let c = DVec3::from_array(b.center_m.map(f64::from));
        let props = MassProperties::with_inertia_matrix(
            v3(r.transpose() * (m.com_m - c)),
            m.mass_kg as f32,
            m3(r.transpose() * m.inertia_kg_m2 * r),
        );
        let collider = collider.friction(mu).restitution(e).mass_properties(props);
        handles.push(world.insert(body, collider).0);
    }
    Ok((world, handles))
}

/// Steps `world` with its fixed dt until `duration_s` is simulated; wall time counts the steps
/// only. `start` holds the bodies' start orientations ([`super::scenes::BodySpec::orientation`],
/// in the order of `handles`): the run reports each body's rotation from it.
pub fn run(
    world: &mut PhysicsWorld,
    handles: &[RigidBodyHandle],
    start: &[DQuat],
    duration_s: f64,
    progress: &Progress<'_>,
) -> EngineRun {
    let dt = f64::from(world.integration_parameters.dt);
    // Whole steps covering the duration; the relative 1e-6 absorbs the f32 rounding of dt
    // (1e-7), so a dt that divides the duration takes exactly duration / dt steps.
    let steps = (duration_s / dt * (1.0 - 1e-6)).ceil().max(1.0) as u64;
    let mut wall_s = 0.0;
    let cpu0 = process_cpu_s();
    for k in 0..steps {
        let t = Instant::now();
        world.step();
        wall_s += t.elapsed().as_secs_f64();
        progress.at((k + 1) as f64 * dt);
    }
    let cpu_s = cpu0.zip(process_cpu_s()).map(|(a, b)| b - a);
    let bodies = handles
        .iter()
        .zip(start)
        .map(|(h, q0)| {
            let b = &world.bodies[*h];
            let q = b.rotation();
            let q = DQuat::from_xyzw(
                f64::from(q.x),
                f64::from(q.y),
                f64::from(q.z),
                f64::from(q.w),
            );
            FinalBody {
                com_m: dv3(b.center_of_mass()),
                // The rotation from the start pose.
                orientation: (q * q0.inverse()).normalize(),
                velocity_m_s: dv3(b.linvel()),
                omega_rad_s: dv3(b.angvel()),
                asleep: b.is_sleeping(),
            }
        })
        .collect();
    EngineRun {
        steps,
        simulated_s: steps as f64 * dt,
        dt_range_s: [dt, dt],
        wall_s,
        cpu_s,
        particles: None,
        bodies,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::scenes::{BodySpec, IDENTITY_WXYZ, SceneKind};

    fn settings() -> ContactSettings {
        ContactSettings::for_tests()
    }

    #[test]
    fn rapier_holds_a_box_at_rest_on_the_ground() {
        // A 10 cm box of 1 kg standing on the ground, exact mass properties: after 1 s at
        // 1/120 s steps its COM has moved less than 0.1 mm. Rapier's contact with a fixed body
        // is a 60 Hz spring by default, which sags by g / ω² = 9.81 / (2π · 60)² = 0.069 mm
        // under the box's weight; the tolerance leaves room for that and no more.
        let h = 0.05;
        let scene = ContactScene {
            kind: SceneKind::Stack,
            bodies: vec![BodySpec {
                name: "box".into(),
                shape: BodyShape::Cuboid {
                    half_extents_m: [h as f32; 3],
                },
                center_m: [0.0, 0.0, h as f32],
                orientation_wxyz: IDENTITY_WXYZ,
                settle_drop_m: Some(0.0),
            }],
            walls: Vec::new(),
        };
        let m = 1.0;
        let i = m * (2.0 * h) * (2.0 * h) / 6.0;
        let mass = [MassProps {
            mass_kg: m,
            com_m: DVec3::new(0.0, 0.0, h),
            inertia_kg_m2: DMat3::from_diagonal(DVec3::splat(i)),
        }];
        let g = DVec3::new(0.0, 0.0, -9.81);
        let (mut world, handles) = build(&scene, &settings(), &mass, g, 1.0 / 120.0).unwrap();
        let run = run(
            &mut world,
            &handles,
            &[DQuat::IDENTITY],
            1.0,
            &Progress::hidden(),
        );
        assert_eq!(run.steps, 120);
        let drift_m = (run.bodies[0].com_m - mass[0].com_m).length();
        assert!(drift_m < 1e-4, "drifted {drift_m} m");
    }

    #[test]
    fn rapier_poses_a_turned_body_and_its_centre_of_mass() {
        // A 20 × 10 × 5 cm box lying on its largest face, described as the box standing on
        // its end turned 90° about y, with its COM 1 cm off the centre along its long axis and
        // its world inertia: it rests where it starts, to 0.2 mm (rapier's 0.069 mm sag as
        // above, a little more under the end the COM is nearer), and reports no rotation from
        // its start pose. Posed unturned it would stand 20 cm tall, 7.5 cm into
        // the ground, and fly out; a COM offset left in world axes would put its COM 1.4 cm
        // from where the world computed it.
        let half = [0.025_f32, 0.05, 0.1];
        let turn = DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2);
        let center = DVec3::new(0.3, -0.2, 0.025);
        let scene = ContactScene {
            kind: SceneKind::Pile,
            bodies: vec![BodySpec {
                name: "box".into(),
                shape: BodyShape::Cuboid {
                    half_extents_m: half,
                },
                center_m: center.as_vec3().to_array(),
                orientation_wxyz: [turn.w, turn.x, turn.y, turn.z].map(|v| v as f32),
                settle_drop_m: None,
            }],
            walls: Vec::new(),
        };
        let m = 1.0;
        let [x, y, z] = half.map(|h| 2.0 * f64::from(h));
        let local = DMat3::from_diagonal(DVec3::new(y * y + z * z, x * x + z * z, x * x + y * y))
            * (m / 12.0);
        let r = DMat3::from_quat(turn);
        let mass = [MassProps {
            mass_kg: m,
            com_m: center + turn * DVec3::new(0.0, 0.0, 0.01),
            inertia_kg_m2: r * local * r.transpose(),
        }];
        let g = DVec3::new(0.0, 0.0, -9.81);
        let (mut world, handles) = build(&scene, &settings(), &mass, g, 1.0 / 120.0).unwrap();
        let run = run(&mut world, &handles, &[turn], 1.0, &Progress::hidden());
        let end = run.bodies[0];
        let drift_m = (end.com_m - mass[0].com_m).length();
        assert!(drift_m < 2e-4, "drifted {drift_m} m");
        let angle = end.orientation.angle_between(DQuat::IDENTITY);
        assert!(angle < 1e-3, "turned {angle} rad from its start pose");
    }
}
