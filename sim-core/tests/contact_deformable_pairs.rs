//! Deformable objects in contact with each other (release build): a column of three jelly
//! cubes, the middle one set 2 cm off the axis, stands on a floor: no cube sinks into the one
//! below and none slides or tips off; a jelly ball dropped on a jelly slab lands without being
//! sent off sideways, and one thrown along it rolls.

use splatphys_core::material::MaterialSpec;
use splatphys_core::scene::{ColliderSpec, ObjectBuilder, Scene, SceneObject, Surface};
use splatphys_core::world::World;

/// A 10 cm jelly cube (E = 2e5 Pa, ν = 0.3, 1000 kg/m³) with its base at `z0` and its centre at
/// x = `x0` (m).
fn jelly_cube(name: &str, x0: f32, z0: f32) -> ObjectBuilder {
    SceneObject::cuboid(name, [x0 - 0.05, -0.05, z0], [x0 + 0.05, 0.05, z0 + 0.1])
        .spacing_m(0.01)
        .material(MaterialSpec::jelly(2e5, 0.3, 1000.0))
        .friction(0.5)
}

#[test]
fn an_offset_column_of_jelly_cubes_stands_without_sinking_or_sliding() {
    let scene = Scene::builder()
        .grid_dx_m(0.01)
        .duration_s(4.0)
        .frame_rate_hz(20.0)
        .sleep(false)
        .collider(
            ColliderSpec::plane("floor", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
                .surface(Surface::Separate)
                .friction(0.5),
        )
        .object(jelly_cube("low", 0.0, 0.001))
        .object(jelly_cube("middle", 0.02, 0.103))
        .object(jelly_cube("top", 0.0, 0.205))
        .build()
        .expect("scene");
    let mut w = World::from_scene(&scene).expect("world");
    let start: Vec<[f64; 3]> = w.objects().iter().map(|o| o.com_m).collect();
    let mut at = Vec::new();
    for t in [1.0, 4.0] {
        while w.time_s() < t - 1e-9 {
            w.advance_frame().expect("step");
        }
        let coms: Vec<[f64; 3]> = w.objects().iter().map(|o| o.com_m).collect();
        println!("t = {t} s: COMs {coms:.5?} m");
        at.push(coms);
    }
    let st = &w.stats();
    println!(
        "COM layer {:.1} % of the step ({} substeps)",
        100.0 * st.com_layer_wall_s / (st.com_layer_wall_s + st.mpm_wall_s),
        st.substeps
    );
    let (early, end) = (&at[0], &at[1]);
    for k in 0..3 {
        // Sinking at g dt² per substep, as when the load arrives after the positions moved,
        // takes ~5 mm/s at this dx (dt ≈ 0.5 ms): 15 mm between t = 1 s and 4 s. What is left
        // is the slow elastic settling under the load above (strain ~1 % at the bottom).
        let sink = early[k][2] - end[k][2];
        assert!(sink.abs() < 1e-3, "cube {k} sank {:.2} mm", sink * 1e3);
        // The middle cube is held by a couple (the pressure centre under its COM, inside the
        // contact); a single contact point 1 cm off its COM spins it off the column.
        let side = ((end[k][0] - start[k][0]).powi(2) + (end[k][1] - start[k][1]).powi(2)).sqrt();
        println!(
            "cube {k}: down {:.2} mm from t = 1 s to 4 s, {:.2} mm sideways from the start",
            sink * 1e3,
            side * 1e3
        );
        assert!(side < 5e-3, "cube {k} moved {:.1} mm sideways", side * 1e3);
    }
    for k in 1..3 {
        // Contact begins once particles share a grid cell: at most a cell (10 mm) of overlap.
        let apart = end[k][2] - end[k - 1][2];
        println!("cubes {} and {k}: COMs {:.2} mm apart", k - 1, apart * 1e3);
        assert!(
            apart > 0.1 - 0.01,
            "cubes {} and {k} overlap by {:.1} mm",
            k - 1,
            (0.1 - apart) * 1e3
        );
    }
    let v = w
        .objects()
        .iter()
        .map(|o| o.velocity_m_s)
        .collect::<Vec<_>>();
    assert!(
        v.iter().flatten().all(|c| c.abs() < 5e-3),
        "still moving: {v:?}"
    );
}

/// A jelly ball (r = 4 cm, E = 2e5 Pa) 2 mm above a stiffer jelly slab (E = 1e6 Pa, 40 × 30 ×
/// 5 cm on a floor), at `offset_m` (x, y) from the slab's centre, thrown at `velocity_m_s`,
/// friction 0.5 everywhere; its world, `frame_rate_hz` frames over `duration_s`.
fn ball_on_slab(
    offset_m: [f32; 2],
    velocity_m_s: [f32; 3],
    duration_s: f64,
    frame_rate_hz: f64,
) -> World {
    let scene = Scene::builder()
        .grid_dx_m(0.01)
        .duration_s(duration_s)
        .frame_rate_hz(frame_rate_hz)
        .sleep(false)
        .collider(
            ColliderSpec::plane("floor", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
                .surface(Surface::Separate)
                .friction(0.5),
        )
        .object(
            SceneObject::cuboid("slab", [-0.2, -0.15, 0.0], [0.2, 0.15, 0.05])
                .spacing_m(0.01)
                .material(MaterialSpec::jelly(1e6, 0.3, 1000.0))
                .friction(0.5),
        )
        .object(
            SceneObject::sphere("ball", [offset_m[0], offset_m[1], 0.092], 0.04)
                .spacing_m(0.01)
                .material(MaterialSpec::jelly(2e5, 0.3, 1000.0))
                .friction(0.5)
                .velocity(velocity_m_s),
        )
        .build()
        .expect("scene");
    World::from_scene(&scene).expect("world")
}

/// The ball of [`ball_on_slab`] dropped at `offset_m`: its largest horizontal speed over 0.3 s
/// and the speed it lands at (m/s).
fn sideways_over_impact(offset_m: [f32; 2]) -> (f64, f64) {
    let mut w = ball_on_slab(offset_m, [0.0; 3], 0.3, 200.0);
    let (mut impact, mut sideways) = (0.0_f64, 0.0_f64);
    while !w.is_finished() {
        w.advance_frame().expect("step");
        let v = w.objects()[1].velocity_m_s;
        impact = impact.max(-v[2]);
        sideways = sideways.max(v[0].hypot(v[1]));
    }
    (sideways, impact)
}

/// A ball dropped straight down lands straight. It first touches with whichever of its
/// particles is lowest, up to 2 cm off its axis, where its own surface is tilted by 25°; the
/// contact normal comes from the flatter surface (the slab's) and the point from the two
/// surfaces' curvatures. With the plain difference of the two surfaces' normals at the zones'
/// midpoint the ball left at 0.40-0.51 of its impact speed sideways at these offsets.
#[test]
fn a_jelly_ball_dropped_on_a_jelly_slab_lands_without_much_sideways_kick() {
    for offset in [[0.0, 0.0], [0.003, 0.0], [0.004, 0.007]] {
        let (sideways, impact) = sideways_over_impact(offset);
        println!(
            "jelly ball on a jelly slab at {offset:?} m: impact {impact:.3} m/s, largest \
             sideways speed {sideways:.4} m/s ({:.2} of it)",
            sideways / impact
        );
        assert!(impact > 0.2, "the ball did not land ({impact} m/s)");
        // A ball of particles 1 cm apart is lumpy at that scale, and the curvature each
        // surface shows over a cell is an estimate (0.7-0.8 of 1/R for this ball), so the
        // point stays a few mm off the axis: up to about a fifth of the impact speed is left.
        assert!(
            sideways < 0.3 * impact,
            "sideways {sideways:.4} m/s after an impact at {impact:.3} m/s"
        );
    }
}

/// A ball thrown along a slab rolls on. Sliding at first, friction turns it until it rolls
/// without slipping (a solid sphere: at 5/7 of the throw, 0.29 m/s, ω = v / R); a couple that
/// keeps the pair's relative spin at zero anywhere inside a footprint about as wide as the ball
/// (what keeps a box from tipping off another) stopped it dead within 0.2 s. That couple now acts
/// only where the two surfaces stay within a quarter cell of each other across the footprint.
#[test]
fn a_jelly_ball_thrown_along_a_jelly_slab_rolls_on() {
    let mut w = ball_on_slab([-0.1, 0.0], [0.4, 0.0, 0.0], 0.3, 20.0);
    while !w.is_finished() {
        w.advance_frame().expect("step");
        let ball = &w.objects()[1];
        let (v, omega) = (ball.velocity_m_s, ball.angular_velocity_rad_s);
        println!(
            "rolling jelly ball at t = {:.2} s: v {v:.3?} m/s, ω {omega:.2?} rad/s, \
             ω_y R {:.3} m/s",
            w.time_s(),
            omega[1] * 0.04
        );
        // Rolling, not sliding or stuck: ω_y R = v_x within a quarter (the ball is soft, and
        // its ω is a fit to its particles).
        if w.time_s() > 0.1 - 1e-9 {
            assert!(
                (omega[1] * 0.04 - v[0]).abs() < 0.25 * v[0],
                "not rolling: v {v:?}, ω {omega:?}"
            );
        }
    }
    // Still rolling on along the throw. It slows (to about half by 0.3 s) and wanders sideways:
    // each patch's normal leans by a few degrees with the dent under the ball and the lumps of a
    // ball of particles 1 cm apart, and nothing resolves that finer.
    let v = w.objects()[1].velocity_m_s;
    assert!(v[0] > 0.12, "the ball slowed to {:.3} m/s", v[0]);
    assert!(v[1].abs() < v[0], "the ball turned sideways: {v:?}");
}
