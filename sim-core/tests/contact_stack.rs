//! Resting contact of rigid boxes (release build): a stack and a pyramid dropped from 2 mm gaps
//! hold their rest positions for 10 s with sleeping off, so only contact holds them.

use splatphys_core::scene::{ColliderSpec, ObjectBuilder, ObjectKind, Scene, SceneObject};
use splatphys_core::world::World;

const SIDE_M: f32 = 0.1;
const GAP_M: f32 = 0.002;

fn rigid_box(name: String, min: [f32; 3]) -> ObjectBuilder {
    SceneObject::cuboid(name, min, min.map(|v| v + SIDE_M))
        .kind(ObjectKind::Rigid)
        .restitution(0.0)
        .friction(0.5)
}

/// Runs `boxes` (lower corners, and how many gaps lie below each) for 10 s on a ground plane;
/// returns each box's COM error (m) against its rest COM: the start COM lowered by its gaps.
fn settle(boxes: &[([f32; 3], u32)]) -> Vec<[f64; 3]> {
    let mut s = Scene::builder()
        .grid_dx_m(0.01)
        .duration_s(10.0)
        .sleep(false)
        .collider(ColliderSpec::ground("floor"));
    for (k, (min, _)) in boxes.iter().enumerate() {
        s = s.object(rigid_box(format!("box{k}"), *min));
    }
    let mut world = World::from_scene(&s.build().expect("scene")).expect("world");
    let rest: Vec<[f64; 3]> = world
        .bodies()
        .iter()
        .zip(boxes)
        .map(|(b, (_, gaps))| {
            let c = b.rigid().com_m;
            [c.x, c.y, c.z - f64::from(*gaps) * f64::from(GAP_M)]
        })
        .collect();
    while !world.is_finished() {
        world.advance_frame().expect("step");
    }
    world
        .bodies()
        .iter()
        .zip(&rest)
        .map(|(b, r)| {
            let c = b.rigid().com_m;
            [c.x - r[0], c.y - r[1], c.z - r[2]]
        })
        .collect()
}

#[test]
fn a_stack_of_ten_boxes_stays_at_its_rest_heights() {
    let boxes: Vec<([f32; 3], u32)> = (0..10)
        .map(|k| {
            let z = k as f32 * (SIDE_M + GAP_M) + GAP_M;
            ([-0.05, -0.05, z], k + 1)
        })
        .collect();
    let err = settle(&boxes);
    for (k, e) in err.iter().enumerate() {
        println!(
            "box {k}: dz = {:+.3} mm, dx = {:+.3} mm, dy = {:+.3} mm",
            e[2] * 1e3,
            e[0] * 1e3,
            e[1] * 1e3
        );
    }
    for (k, e) in err.iter().enumerate() {
        // Rigid contact: the heights are exact up to the solver's slop (0.05 mm per contact).
        assert!(
            e[2].abs() < 1e-3,
            "box {k} height off by {:.2} mm",
            e[2] * 1e3
        );
        // And it does not creep sideways: a column that rocks (its faces solved point by
        // point, or its frames ending on sliver substeps) creeps by millimetres at the top.
        // 2 mm is 2 % of a box's width.
        let sideways = (e[0] * e[0] + e[1] * e[1]).sqrt();
        assert!(
            sideways < 2e-3,
            "box {k} crept {:.2} mm sideways",
            sideways * 1e3
        );
    }
}

#[test]
fn a_pyramid_of_fifteen_boxes_holds() {
    // Rows of 5, 4, 3, 2, 1, each box over the gap between two below, 2 mm apart both ways.
    let mut boxes = Vec::new();
    for row in 0..5u32 {
        let n = 5 - row;
        for i in 0..n {
            let x = (i as f32 - (n as f32 - 1.0) / 2.0) * (SIDE_M + GAP_M) - SIDE_M / 2.0;
            let z = row as f32 * (SIDE_M + GAP_M) + GAP_M;
            boxes.push(([x, -0.05, z], row + 1));
        }
    }
    let err = settle(&boxes);
    for (k, e) in err.iter().enumerate() {
        let d = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
        println!("box {k}: |d| = {:.3} mm", d * 1e3);
        assert!(d < 5e-3, "box {k} moved {:.2} mm", d * 1e3);
    }
}
