//! Islands (release build): objects out of each other's reach step apart, each at its own CFL
//! substep, with the same outcome as a world stepped as one; objects heading for each other join
//! one island before they meet.

use splatphys_core::material::MaterialSpec;
use splatphys_core::scene::{ColliderSpec, ObjectKind, Scene, SceneObject, Surface};
use splatphys_core::world::World;

/// A soft (E = 2e4 Pa) and a stiff (E = 2e6 Pa) jelly sphere 0.6 m apart, dropped 5 cm onto a
/// floor, stepped for 0.5 s with islands on or off; `only` keeps one of them moving.
fn soft_and_stiff(islands: bool, only: Option<&str>) -> World {
    let spheres = [("soft", -0.3, 2e4), ("stiff", 0.3, 2e6)];
    let mut scene = Scene::builder()
        .grid_dx_m(0.01)
        .duration_s(0.5)
        .frame_rate_hz(30.0)
        .sleep(false)
        .islands(islands)
        .collider(
            ColliderSpec::plane("floor", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
                .surface(Surface::Separate),
        );
    for (name, x, e) in spheres {
        // The other one stays, static, so that the particles are sampled the same.
        let kind = match only {
            Some(o) if o != name => ObjectKind::Static,
            _ => ObjectKind::Deformable,
        };
        scene = scene.object(
            SceneObject::sphere(name, [x, 0.0, 0.1], 0.05)
                .kind(kind)
                .spacing_m(0.01)
                .material(MaterialSpec::jelly(e, 0.3, 1000.0)),
        );
    }
    let mut w = World::from_scene(&scene.build().expect("scene")).expect("world");
    while !w.is_finished() {
        w.advance_frame().expect("step");
    }
    w
}

#[test]
fn objects_out_of_each_others_reach_step_as_they_would_alone() {
    let apart = soft_and_stiff(true, None);
    let whole = soft_and_stiff(false, None);
    let (soft, stiff) = (&apart.bodies()[0], &apart.bodies()[1]);
    println!(
        "islands: soft {} substeps ({:.2e}..{:.2e} s), stiff {} ({:.2e}..{:.2e} s); as one: {} each",
        soft.stats().substeps_taken,
        soft.stats().dt_range_s[0],
        soft.stats().dt_range_s[1],
        stiff.stats().substeps_taken,
        stiff.stats().dt_range_s[0],
        stiff.stats().dt_range_s[1],
        whole.bodies()[0].stats().substeps_taken
    );
    // c_p grows with sqrt(E): 10x here. With the falling speed (up to 1 m/s) in both bounds the
    // soft sphere's substep is still several times the stiff one's.
    assert!(soft.stats().substeps_taken * 3 < stiff.stats().substeps_taken);
    assert_eq!(
        whole.bodies()[0].stats().substeps_taken,
        whole.bodies()[1].stats().substeps_taken
    );
    assert_eq!(apart.stats().island_escapes, 0);
    // Each steps exactly as it would alone: the same substeps, the same state to the bit.
    for (k, name) in ["soft", "stiff"].into_iter().enumerate() {
        let alone = soft_and_stiff(true, Some(name));
        assert_eq!(
            apart.bodies()[k].stats().substeps_taken,
            alone.bodies()[k].stats().substeps_taken
        );
        assert_eq!(apart.objects()[k].com_m, alone.objects()[k].com_m, "{name}");
        assert_eq!(
            &apart.bodies()[k].particle_positions(),
            &alone.bodies()[k].particle_positions(),
            "{name}"
        );
    }
    // Stepped as one, the soft sphere takes the stiff one's substep: MPM at a 9x smaller dt,
    // which moves its bounces by millimetres (a difference of time resolution, not of islands).
    let d = (apart.objects()[0].com_m[2] - whole.objects()[0].com_m[2]).abs();
    println!(
        "soft sphere's height, islands against one world: {:.2} mm apart",
        d * 1e3
    );
}

/// Two jelly spheres 0.34 m apart (centre to centre) approaching at 1 m/s each, no gravity.
fn head_on(islands: bool) -> World {
    let jelly = MaterialSpec::jelly(2e5, 0.3, 1000.0);
    let scene = Scene::builder()
        .grid_dx_m(0.01)
        .duration_s(0.4)
        .frame_rate_hz(30.0)
        .gravity_m_s2([0.0; 3])
        .sleep(false)
        .islands(islands)
        .object(
            SceneObject::sphere("left", [-0.17, 0.0, 0.5], 0.05)
                .spacing_m(0.01)
                .velocity([1.0, 0.0, 0.0])
                .restitution(0.5)
                .material(jelly.clone()),
        )
        .object(
            SceneObject::sphere("right", [0.17, 0.0, 0.5], 0.05)
                .spacing_m(0.01)
                .velocity([-1.0, 0.0, 0.0])
                .restitution(0.5)
                .material(jelly),
        )
        .build()
        .expect("scene");
    World::from_scene(&scene).expect("world")
}

#[test]
fn objects_heading_for_each_other_join_one_island_before_they_meet() {
    let mut apart = head_on(true);
    let mut whole = head_on(false);
    // The gap (0.24 m) closes in 0.12 s. A frame is 1/30 s: at the start the spheres cannot
    // meet within it and step apart; one frame later their swept boxes overlap.
    assert_eq!(
        apart.plan_islands(apart.frame_dt_s()),
        vec![vec![0], vec![1]]
    );
    assert_eq!(whole.plan_islands(whole.frame_dt_s()), vec![vec![0, 1]]);
    apart.advance_frame().expect("step");
    let end = apart.time_s() + apart.frame_dt_s();
    assert_eq!(apart.plan_islands(end), vec![vec![0, 1]]);
    while !apart.is_finished() {
        apart.advance_frame().expect("step");
    }
    while !whole.is_finished() {
        whole.advance_frame().expect("step");
    }
    assert_eq!(apart.stats().island_escapes, 0);
    // They met and bounced apart in both runs, the same within 1 % of the approach speed and
    // 1 mm.
    for (a, b) in apart.objects().iter().zip(whole.objects()) {
        println!(
            "{}: v {:.4} m/s against {:.4} m/s, x {:.5} m against {:.5} m",
            a.name, a.velocity_m_s[0], b.velocity_m_s[0], a.com_m[0], b.com_m[0]
        );
        assert!(a.velocity_m_s[0].abs() > 0.1 && a.velocity_m_s[0].signum() == a.com_m[0].signum());
        assert!((a.velocity_m_s[0] - b.velocity_m_s[0]).abs() < 0.01);
        assert!((a.com_m[0] - b.com_m[0]).abs() < 1e-3);
    }
}
