//! Objects on captured ground (release build): the background's collision surface leaves out
//! the cells objects occupy at the start, but not the ground under them. An object placed just
//! above a captured table rests on it, one sunk into it rests in a dimple, and Gaussians a
//! segmentation left under an object in the air go with it. A jelly rests at the same height
//! wherever the ground's surface lies in a grid cell.

use rayon::prelude::*;
use splatphys_core::formats::ply::write_ply;
use splatphys_core::scene::load_scene_str;
use splatphys_core::world::World;

mod support;

/// Gaussian spacing of the captured table (m).
const H_M: f32 = 0.005;

/// Writes `ground.ply` to `dir`: a captured table, 0.6 m × 0.6 m of opaque Gaussians `H_M` apart
/// in two layers, the top layer's centres at z = `lift_m` − 2.5 mm (its level set's top face is
/// z = 0 on 5 mm and 1 cm cells with no lift), and `extra` Gaussians.
fn write_ground(dir: &std::path::Path, lift_m: f32, extra: &[[f32; 3]]) {
    let cloud = support::flat_capture([-0.3, -0.3], [120, 120], H_M, lift_m, extra);
    write_ply(dir.join("ground.ply"), &cloud, &[]).expect("ply");
}

/// Runs `object` (a TOML `[[object]]` table) over the ground of [`write_ground`] in `dir` for
/// `duration_s` on 1 cm cells, with `simulation` added to its `[simulation]` table; returns the
/// world after its first step and the object's lowest, highest and last COM height (m) over
/// the frames.
fn run_with(
    dir: &std::path::Path,
    object: &str,
    duration_s: f64,
    simulation: &str,
) -> (World, (f64, f64, f64)) {
    let text = format!(
        r#"
[simulation]
duration_s = {duration_s}
frame_rate_hz = 20.0
grid_dx_m = 0.01
sleep = false
{simulation}

[[source]]
name = "ground"
path = "ground.ply"

{object}
"#
    );
    let scene = load_scene_str(&text, dir).expect("scene");
    let mut w = World::from_scene(&scene).expect("world");
    let (mut lo, mut hi, mut last) = (f64::MAX, f64::MIN, 0.0);
    while !w.is_finished() {
        w.advance_frame().expect("step");
        last = w.objects()[0].com_m[2];
        lo = lo.min(last);
        hi = hi.max(last);
    }
    (w, (lo, hi, last))
}

/// [`run_with`] with the scene's defaults: the object's lowest, highest and last COM height.
fn run(dir: &std::path::Path, object: &str, duration_s: f64) -> (f64, f64, f64) {
    run_with(dir, object, duration_s, "").1
}

const JELLY: &str =
    r#"{ model = "jelly", youngs_modulus_pa = 2e5, poisson_ratio = 0.3, density_kg_m3 = 1000.0 }"#;

#[test]
fn objects_placed_just_above_captured_ground_rest_on_it() {
    // Bases 0.5 mm above the table: their cells, grown by one, hold the table's top Gaussians.
    // Carved out with them, the ground had a hole under each object, and a jelly ball fell into
    // it at g. Both rest on the table as on a procedural box: the jelly ball's COM within 1 mm
    // of its radius in every frame (measured 39.8-40.2 mm; on a static box 39.8-40.2 mm).
    let dir = tempfile::tempdir().expect("tempdir");
    write_ground(dir.path(), 0.0, &[]);
    let jelly = format!(
        r#"[[object]]
name = "ball"
shape = {{ sphere = {{ center_m = [0.0, 0.0, 0.0405], radius_m = 0.04 }} }}
spacing_m = 0.005
material = {JELLY}"#
    );
    let rigid = r#"[[object]]
name = "box"
shape = { box = { min_m = [-0.05, -0.05, 0.0005], max_m = [0.05, 0.05, 0.1005] } }
kind = "rigid"
spacing_m = 0.005"#;
    for (what, object, rest_m) in [
        ("jelly ball", jelly.as_str(), 0.04),
        ("rigid box", rigid, 0.05),
    ] {
        let (lo, hi, last) = run(dir.path(), object, 0.6);
        println!("{what}: COM {lo:.4}-{hi:.4} m, last {last:.4} m, at rest on the table {rest_m}");
        assert!(
            lo > rest_m - 0.001 && hi < rest_m + 0.001,
            "{what}: COM {lo:.4}-{hi:.4} m, last {last:.4} m; on the table {rest_m} m"
        );
    }
}

#[test]
fn an_object_sunk_into_captured_ground_rests_in_a_dimple() {
    // A rigid box whose base lies 4 mm below the table's top face: the table's Gaussians beside
    // its base go (the object is not shot out), but the ground thickened below it stays, so it
    // settles into a dimple a cell or two deep and stays there.
    let dir = tempfile::tempdir().expect("tempdir");
    write_ground(dir.path(), 0.0, &[]);
    let sunk = r#"[[object]]
name = "box"
shape = { box = { min_m = [-0.05, -0.05, -0.004], max_m = [0.05, 0.05, 0.096] } }
kind = "rigid"
spacing_m = 0.005"#;
    let (lo, hi, last) = run(dir.path(), sunk, 0.6);
    println!("sunk box: COM {lo:.4}-{hi:.4} m, last {last:.4} m (placed at 0.046)");
    assert!(
        lo > 0.046 - 0.03,
        "the box sank through the ground: lowest COM {lo:.4} m"
    );
    assert!(
        hi < 0.046 + 0.005,
        "the box was thrown up: highest COM {hi:.4} m"
    );
}

#[test]
fn gaussians_left_under_an_object_in_the_air_go_with_it() {
    // A disc of background Gaussians (6 cm across) 2 mm under a ball held 20 cm above the table:
    // what a segmentation leaves of an object's underside. It joins no ground beyond the
    // object, so it goes, and the ball falls onto the table.
    let dir = tempfile::tempdir().expect("tempdir");
    let mut disc = Vec::new();
    for i in -6..=6 {
        for j in -6..=6 {
            let (x, y) = (i as f32 * H_M, j as f32 * H_M);
            if x.hypot(y) <= 0.03 {
                disc.push([x, y, 0.2 - 0.04 - 0.002]);
            }
        }
    }
    write_ground(dir.path(), 0.0, &disc);
    let ball = r#"[[object]]
name = "ball"
shape = { sphere = { center_m = [0.0, 0.0, 0.2], radius_m = 0.04 } }
kind = "rigid"
spacing_m = 0.005
restitution = 0.0"#;
    let (lo, _, last) = run(dir.path(), ball, 0.6);
    println!("ball over a left-over disc: lowest COM {lo:.4} m, last {last:.4} m");
    assert!(
        (last - 0.04).abs() < 0.005,
        "the ball did not fall onto the table: COM {last:.4} m"
    );
}

#[test]
fn a_jelly_rests_at_the_same_height_wherever_captured_ground_lies_in_a_cell() {
    // A damped 10 cm jelly cube laid 1 mm above captured ground whose level set (cells of 6 mm)
    // puts its top face on a grid node layer (1 cm cells) and 0.6, 0.2 and 0.8 of the way to
    // the next: its COM rests at the same height above the face within 0.5 mm (measured
    // 50.79-50.94 mm; on a static box 50.63-50.79 mm, `--test contact_supports`; with the
    // ground's rule at every grid node inside it, 50.35-50.94 mm).
    let heights: Vec<f64> = [0.0f32, 0.006, 0.012, 0.018]
        .into_par_iter()
        .map(|lift| {
            let dir = tempfile::tempdir().expect("tempdir");
            write_ground(dir.path(), lift, &[]);
            let cube = format!(
                r#"[[object]]
name = "jelly"
shape = {{ box = {{ min_m = [-0.05, -0.05, {lo}], max_m = [0.05, 0.05, {hi}] }} }}
spacing_m = 0.005
material = {{ model = "jelly", youngs_modulus_pa = 2e5, poisson_ratio = 0.3, density_kg_m3 = 1000.0, damping_viscosity_pa_s = 20.0 }}"#,
                lo = lift + 0.001,
                hi = lift + 0.101
            );
            let (w, (_, _, last)) = run_with(dir.path(), &cube, 0.6, "collision_dx_m = 0.006");
            // The level set's top face over the cube's centre.
            let ground = w.background_collision().expect("captured ground");
            let face = (0..400)
                .map(|k| lift - 0.01 + k as f32 * 1e-4)
                .find(|&z| ground.geometry.distance(glam::Vec3A::new(0.0, 0.0, z)).0 > 0.0)
                .expect("the ground's top face");
            assert!((face - lift).abs() < 1e-4, "face at {face} m, lift {lift} m");
            last - f64::from(face)
        })
        .collect();
    println!("COM above the captured ground's face: {heights:?} m");
    let spread = heights.iter().copied().fold(f64::MIN, f64::max)
        - heights.iter().copied().fold(f64::MAX, f64::min);
    assert!(spread < 0.5e-3, "rest heights {heights:?} m");
}
