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

/// Runs `w`, checking after every frame that no particle of object `ball` lies below
/// `bottom_m`; returns the ball's lowest particle over the run, the highest its COM reaches
/// from 0.05 s on (after the impact) and its final COM height (m).
fn never_below(mut w: World, ball: usize, bottom_m: f32) -> (f32, f64, f64) {
    let (mut lowest, mut highest) = (f32::INFINITY, f64::NEG_INFINITY);
    while !w.is_finished() {
        w.advance_frame().expect("step");
        let z = w.bodies()[ball]
            .particles()
            .x
            .iter()
            .map(|x| x.z)
            .fold(f32::INFINITY, f32::min);
        assert!(
            z >= bottom_m,
            "a particle at z = {z} m, below the plate's bottom {bottom_m} m at t = {:.3} s",
            w.time_s()
        );
        lowest = lowest.min(z);
        if w.time_s() >= 0.05 {
            highest = highest.max(w.objects()[ball].com_m[2]);
        }
    }
    (lowest, highest, w.objects()[ball].com_m[2])
}

#[test]
fn a_soft_ball_at_5_m_s_never_passes_a_1_mm_static_plate() {
    // The plate's mid-plane on a node layer, a third and half-way between two.
    for centre in [0.0f32, 0.0033, 0.005] {
        let (lo, hi) = (centre - 0.0005, centre + 0.0005);
        let scene = ball_onto(hi)
            .object(
                SceneObject::cuboid("plate", [-0.2, -0.2, lo], [0.2, 0.2, hi])
                    .kind(ObjectKind::Static)
                    .friction(0.5)
                    .restitution(0.0),
            )
            .build()
            .expect("scene");
        let w = World::from_scene(&scene).expect("world");
        // The ball is object 0, the plate object 1.
        let (lowest, highest, com) = never_below(w, 0, lo);
        println!(
            "static plate at {centre} m: lowest particle {lowest:.4} m, highest COM {highest:.4} m, COM at the end {com:.4} m"
        );
        // It stays on the plate: its COM ends above it and never rises much above a radius
        // over it (a rebound at a fifth of the 5 m/s it came at would lift it 5 cm).
        assert!(com > hi as f64 + 0.01, "the ball's COM ended at {com} m");
        assert!(
            highest < hi as f64 + 0.055,
            "the ball bounced: its COM reached {highest} m"
        );
    }
}

#[test]
fn a_soft_ball_at_5_m_s_never_passes_a_1_mm_collider_box() {
    for centre in [0.0f32, 0.005] {
        let (lo, hi) = (centre - 0.0005, centre + 0.0005);
        let scene = ball_onto(hi)
            .collider(
                ColliderSpec::cuboid("plate", [-0.2, -0.2, lo], [0.2, 0.2, hi])
                    .surface(Surface::Separate)
                    .friction(0.5),
            )
            .build()
            .expect("scene");
        let w = World::from_scene(&scene).expect("world");
        let (lowest, highest, com) = never_below(w, 0, lo);
        println!(
            "collider plate at {centre} m: lowest particle {lowest:.4} m, highest COM {highest:.4} m, COM at the end {com:.4} m"
        );
        assert!(com > hi as f64 + 0.01, "the ball's COM ended at {com} m");
        assert!(
            highest < hi as f64 + 0.055,
            "the ball bounced: its COM reached {highest} m"
        );
    }
}
