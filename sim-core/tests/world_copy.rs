//! A world copied into an older copy of itself (`clone_from`, which reuses the older copy's
//! buffers: a server keeps one every frame to restore a failed step) steps on exactly as a fresh
//! copy does, and as the original does.

use splatphys_core::material::MaterialSpec;
use splatphys_core::scene::{ColliderSpec, ObjectKind, Scene, SceneObject, Surface};
use splatphys_core::world::World;

/// Every object's particle positions and velocities, bit for bit.
fn state(w: &World) -> Vec<Vec<u32>> {
    w.bodies()
        .iter()
        .map(|b| {
            let p = b.particles();
            p.x.iter()
                .chain(&p.v)
                .flat_map(|v| v.to_array().map(f32::to_bits))
                .collect()
        })
        .collect()
}

#[test]
fn a_world_copied_into_an_older_copy_steps_on_as_a_fresh_copy_and_the_original() {
    // A jelly cube landing on a rigid box on a floor: deformable, rigid and contact state.
    let scene = Scene::builder()
        .grid_dx_m(0.02)
        .frame_rate_hz(30.0)
        .duration_s(1.0)
        .collider(
            ColliderSpec::plane("floor", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
                .surface(Surface::Separate)
                .friction(0.5),
        )
        .object(
            SceneObject::cuboid("box", [-0.1, -0.1, 0.001], [0.1, 0.1, 0.06])
                .spacing_m(0.01)
                .kind(ObjectKind::Rigid),
        )
        .object(
            SceneObject::cuboid("jelly", [-0.05, -0.05, 0.1], [0.05, 0.05, 0.2])
                .spacing_m(0.01)
                .material(MaterialSpec::jelly(1e5, 0.3, 1000.0)),
        )
        .build()
        .expect("scene");
    let mut w = World::from_scene(&scene).expect("world");
    let mut older = w.clone();
    for _ in 0..6 {
        w.advance_frame().expect("step");
    }
    // A copy with fewer frames behind it takes the current state in place.
    older.clone_from(&w);
    let mut fresh = w.clone();
    assert_eq!(state(&older), state(&w));
    assert_eq!(older.time_s(), w.time_s());
    for _ in 0..6 {
        w.advance_frame().expect("step");
        older.advance_frame().expect("step");
        fresh.advance_frame().expect("step");
    }
    let moved = w.objects()[1].com_m[2] < 0.14;
    assert!(moved, "the jelly did not land: {:?}", w.objects()[1].com_m);
    assert_eq!(
        state(&older),
        state(&w),
        "the copied-into world went another way"
    );
    assert_eq!(state(&fresh), state(&w), "the fresh copy went another way");
    assert_eq!(older.objects()[1].com_m, w.objects()[1].com_m);
}
