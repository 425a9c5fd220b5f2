//! Nothing passes a thin solid (release build): a soft ball thrown at 5 m/s onto a static plate
//! or a collider box 1 mm thick, a tenth of a grid cell, wherever the plate lies in the cell.
//! With e = 0 on both, the restitution law leaves it no rebound: the plate's touches are the
//! particles' sweeps where no grid node lies inside it.

use splatphys_core::material::MaterialSpec;
use splatphys_core::scene::{ColliderSpec, ObjectKind, Scene, SceneBuilder, SceneObject, Surface};
use splatphys_core::world::World;

/// A 4 cm jelly ball (E = 2e5 Pa, particles 5 mm apart) whose bottom is 1.5 cm above `top_m`,
/// thrown down at 5 m/s onto a 1 cm grid, with e = 0.
fn ball_onto(top_m: f32) -> SceneBuilder {
    Scene::builder()
        .grid_dx_m(0.01)
        .duration_s(0.3)
        .frame_rate_hz(100.0)
        .sleep(false)
        .object(
            SceneObject::sphere("ball", [0.0, 0.0, top_m + 0.055], 0.04)
                .spacing_m(0.005)
                .material(MaterialSpec::jelly(2e5, 0.3, 1000.0))
                .restitution(0.0)
                .velocity([0.0, 0.0, -5.0]),
        )
}

/// Runs `scene` (the ball is object 0) with a plate from `lo` to `hi` (m) named `what`: no
/// particle of the ball ever lies below the plate, and it stays on it, never rising much
/// above a radius over it after the impact (a rebound at a fifth of the 5 m/s it came at would
/// lift it 5 cm) and keeping its shape: the grid holds the material at the plate (where only the
/// particles' sweeps stopped it, it carried no strain for the stop and lay flat, its COM
/// 12–17 mm over the plate). The undamped ball rings after its landing, so its COM is averaged
/// over the last 0.1 s, and must stay above three quarters of its 4 cm radius.
fn stays_on_the_plate(scene: &Scene, (lo, hi): (f32, f32), what: &str) {
    let mut w = World::from_scene(scene).expect("world");
    let (mut lowest, mut highest) = (f32::INFINITY, f64::NEG_INFINITY);
    let mut late = Vec::new();
    while !w.is_finished() {
        w.advance_frame().expect("step");
        let z = w.bodies()[0]
            .particles()
            .x
            .iter()
            .map(|x| x.z)
            .fold(f32::INFINITY, f32::min);
        assert!(
            z >= lo,
            "{what}: a particle at z = {z} m, below the plate's bottom {lo} m at t = {:.3} s",
            w.time_s()
        );
        lowest = lowest.min(z);
        let com = w.objects()[0].com_m[2];
        if w.time_s() >= 0.05 {
            highest = highest.max(com);
        }
        if w.time_s() > 0.2 + 1e-9 {
            late.push(com - hi as f64);
        }
    }
    let resting = late.iter().sum::<f64>() / late.len().max(1) as f64;
    println!(
        "{what}: lowest particle {lowest:.4} m, highest COM {highest:.4} m, COM over the \
         plate from 0.2 s on {resting:.4} m"
    );
    assert!(
        late.len() >= 5 && resting > 0.03,
        "{what}: the ball lay flat, its COM {resting:.4} m over the plate from 0.2 s on"
    );
    assert!(
        highest < hi as f64 + 0.055,
        "{what}: the ball bounced, its COM reached {highest} m"
    );
}

#[test]
fn a_soft_ball_at_5_m_s_never_passes_a_1_mm_static_plate() {
    // The plate's mid-plane on a node layer, a third, half and three quarters of the way to
    // the next.
    for centre in [0.0f32, 0.0033, 0.005, 0.0075] {
        for surface in [Surface::Separate, Surface::Sticky] {
            let (lo, hi) = (centre - 0.0005, centre + 0.0005);
            let scene = ball_onto(hi)
                .object(
                    SceneObject::cuboid("plate", [-0.2, -0.2, lo], [0.2, 0.2, hi])
                        .kind(ObjectKind::Static)
                        .surface(surface)
                        .friction(0.5)
                        .restitution(0.0),
                )
                .build()
                .expect("scene");
            let what = format!("{surface:?} static plate at {centre} m");
            stays_on_the_plate(&scene, (lo, hi), &what);
        }
    }
}

#[test]
fn a_soft_ball_at_5_m_s_never_passes_a_1_mm_collider_box() {
    for centre in [0.0f32, 0.0033, 0.005, 0.0075] {
        for surface in [Surface::Separate, Surface::Sticky] {
            let (lo, hi) = (centre - 0.0005, centre + 0.0005);
            let scene = ball_onto(hi)
                .collider(
                    ColliderSpec::cuboid("plate", [-0.2, -0.2, lo], [0.2, 0.2, hi])
                        .surface(surface)
                        .friction(0.5),
                )
                .build()
                .expect("scene");
            let what = format!("{surface:?} collider box at {centre} m");
            stays_on_the_plate(&scene, (lo, hi), &what);
        }
    }
}

/// A soft ball thrown at 5 m/s onto an awake rigid plate 2 mm thick (8,000 kg/m³, 0.58 kg)
/// lying across two static supports, with the plate's middle on a node layer and 0.35 of a
/// cell above one: no particle ever lies below the moving plate's bottom face (the sweeps
/// follow each particle's path relative to the plate). The plate being light and the grid not
/// holding the ball at it, the ball lands flat, and with the middle on a node layer it throws
/// the plate up (docs/limitations.md): neither is asserted here.
#[test]
fn a_soft_ball_at_5_m_s_never_passes_a_2_mm_rigid_plate() {
    for centre in [0.0f32, 0.0035] {
        let (lo, hi) = (centre - 0.001, centre + 0.001);
        let support = |name: &str, x0: f32, x1: f32| {
            SceneObject::cuboid(name, [x0, -0.1, lo - 0.05], [x1, 0.1, lo])
                .kind(ObjectKind::Static)
                .friction(0.5)
        };
        let scene = ball_onto(hi)
            .object(support("left", -0.2, -0.1))
            .object(support("right", 0.1, 0.2))
            .object(
                SceneObject::cuboid("plate", [-0.15, -0.06, lo], [0.15, 0.06, hi])
                    .kind(ObjectKind::Rigid)
                    .spacing_m(0.002)
                    .material(MaterialSpec::jelly(2e5, 0.3, 8000.0))
                    .friction(0.5)
                    .restitution(0.0),
            )
            .build()
            .expect("scene");
        let mut w = World::from_scene(&scene).expect("world");
        let mut closest = f64::INFINITY;
        while !w.is_finished() {
            w.advance_frame().expect("step");
            // The plate stays level enough for its bottom to be its COM less half its
            // thickness, under the ball.
            let bottom = w.objects()[3].com_m[2] - 0.001;
            let under = w.bodies()[0]
                .particles()
                .x
                .iter()
                .filter(|x| x.x.abs() < 0.14 && x.y.abs() < 0.05)
                .map(|x| x.z as f64 - bottom)
                .fold(f64::INFINITY, f64::min);
            closest = closest.min(under);
            assert!(
                under > -1e-4,
                "plate centred at {centre} m: a particle {:.4} m below its bottom at t = {:.3} s",
                -under,
                w.time_s()
            );
        }
        println!("plate centred at {centre} m: lowest particle {closest:.4} m over its bottom");
    }
}
