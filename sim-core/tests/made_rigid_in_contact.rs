//! A soft jelly dropped onto a heavy box sags over it; made rigid there, its frozen shape (sampled
//! on cells, up to a cell outside its particles) starts deep inside the box, partly past the
//! middle of its own thin draped parts, where its points face away and show no overlap. No
//! later frame may gain energy: neither when a turn brings such a point back at its full depth
//! nor when the two part and meet again.

use splatphys_core::material::MaterialSpec;
use splatphys_core::scene::{ColliderSpec, ObjectKind, Scene, SceneObject};
use splatphys_core::world::World;

const GRAVITY_M_S2: f64 = 9.81;

/// Kinetic + gravitational (above z = 0) energy of the two rigid objects (J).
fn energy(w: &World) -> f64 {
    w.bodies()
        .iter()
        .take(2)
        .map(|b| {
            let r = b.rigid();
            let omega = r.omega_rad_s;
            0.5 * r.mass_kg * r.velocity_m_s.length_squared()
                + 0.5 * omega.dot(b.rigid_world_inertia() * omega)
                + r.mass_kg * GRAVITY_M_S2 * r.com_m.z
        })
        .sum()
}

#[test]
fn a_jelly_made_rigid_while_draped_over_a_box_gains_no_energy() {
    let mut cases = 0;
    for youngs_pa in [3e4, 1e5] {
        for (vx, vy) in [(-0.8f32, 0.7f32), (0.4, -0.3), (0.0, 0.0)] {
            for freeze_frame in [1, 2] {
                let jelly =
                    SceneObject::cuboid("jelly", [-0.03, -0.03, 0.052], [0.03, 0.03, 0.112])
                        .spacing_m(0.01)
                        .material(MaterialSpec::jelly(youngs_pa, 0.3, 2250.0))
                        .friction(0.25)
                        .restitution(0.5)
                        .velocity([vx, vy, -1.2]);
                let steel = SceneObject::cuboid("box", [-0.025, -0.02, 0.0], [0.025, 0.03, 0.05])
                    .kind(ObjectKind::Rigid)
                    .spacing_m(0.01)
                    .material(MaterialSpec::jelly(5e4, 0.3, 6700.0))
                    .friction(0.25)
                    .restitution(0.5);
                let scene = Scene::builder()
                    .grid_dx_m(0.02)
                    .duration_s(0.25)
                    .frame_rate_hz(60.0)
                    .sleep(false)
                    .object(jelly)
                    .object(steel)
                    .collider(ColliderSpec::plane(
                        "floor",
                        [0.0, 0.0, 0.0],
                        [0.0, 0.0, 1.0],
                    ))
                    .build()
                    .expect("scene");
                let mut w = World::from_scene(&scene).expect("world");
                for _ in 0..freeze_frame {
                    w.advance_frame().expect("frame");
                }
                w.set_kind(0, ObjectKind::Rigid).expect("rigid");
                w.advance_frame().expect("frame");
                let mut before = energy(&w);
                for frame in freeze_frame + 1..15 {
                    w.advance_frame().expect("frame");
                    let after = energy(&w);
                    assert!(
                        after <= before * 1.01 + 1e-6,
                        "E {youngs_pa} Pa, v ({vx}, {vy}), made rigid at frame {freeze_frame}: \
                         frame {frame} went from {before:.5} J to {after:.5} J"
                    );
                    before = after;
                }
                cases += 1;
            }
        }
    }
    assert_eq!(cases, 12);
}
