//! Objects on static objects (release build): a jelly resting on a static box matches the same
//! jelly on a collider plane at the box's top; boxes on a tilted support stick or slide at the
//! Coulomb acceleration; impacts on two supports at once stay symmetric and follow e; oblique
//! impacts follow e along the normal and Coulomb's law along the surface, on static and free
//! solids; a collapsing sand column stops at a static box.

use rayon::prelude::*;
use splatphys_core::material::MaterialSpec;
use splatphys_core::scene::{
    ColliderSpec, ObjectBuilder, ObjectKind, Scene, SceneBuilder, SceneObject, Surface,
    SurfaceContact,
};
use splatphys_core::world::World;

/// COM (m) and COM velocity (m/s) of object `k`, from its particles.
fn com(w: &World, k: usize) -> ([f64; 3], [f64; 3]) {
    let o = &w.objects()[k];
    (o.com_m, o.velocity_m_s)
}

fn run_until(w: &mut World, t_s: f64) {
    while w.time_s() < t_s - 1e-9 && !w.is_finished() {
        w.advance_frame().expect("step");
    }
}

fn jelly_cube(z0: f32) -> ObjectBuilder {
    SceneObject::cuboid("jelly", [-0.05, -0.05, z0], [0.05, 0.05, z0 + 0.1])
        .spacing_m(0.005)
        .material(MaterialSpec::jelly(2e5, 0.3, 1000.0))
        .friction(0.5)
}

#[test]
fn a_jelly_on_a_static_box_rests_like_a_jelly_on_a_plane() {
    let base = || {
        Scene::builder()
            .grid_dx_m(0.005)
            .duration_s(1.5)
            .frame_rate_hz(20.0)
            .sleep(false)
    };
    let on_box = base()
        .object(
            SceneObject::cuboid("table", [-0.15, -0.15, 0.0], [0.15, 0.15, 0.1])
                .kind(ObjectKind::Static)
                .friction(0.5),
        )
        .object(jelly_cube(0.101))
        .build()
        .expect("scene");
    let on_plane = base()
        .collider(
            ColliderSpec::plane("top", [0.0, 0.0, 0.1], [0.0, 0.0, 1.0])
                .surface(Surface::Separate)
                .friction(0.5),
        )
        .object(jelly_cube(0.101))
        .build()
        .expect("scene");
    let (mut a, mut b) = (
        World::from_scene(&on_box).expect("world"),
        World::from_scene(&on_plane).expect("world"),
    );
    let mut worst = 0.0f64;
    // Both rest within 1 s (the heights hold to 0.01 mm from there to 5 s).
    for t in [0.5, 1.0, 1.5] {
        // Side by side (each world is mostly serial).
        rayon::join(|| run_until(&mut a, t), || run_until(&mut b, t));
        let (za, zb) = (com(&a, 1).0[2], com(&b, 0).0[2]);
        println!("t = {t} s: on the box {za:.5} m, on the plane {zb:.5} m");
        worst = worst.max((za - zb).abs());
    }
    // The same boundary rule on the same surface: equal to well within a millimetre (the
    // issue's bound; the elastic sag itself is ~0.5 mm).
    assert!(worst < 1e-3, "differs by {:.3} mm", worst * 1e3);
    // And resting: not sinking (the sag of a 10 cm jelly at E = 2e5 Pa is below 1 mm).
    let (z, v) = com(&a, 1);
    assert!(
        z[2] > 0.15 - 1e-3 && v[2].abs() < 1e-2,
        "z = {} v = {}",
        z[2],
        v[2]
    );
}

#[test]
fn a_jelly_rests_at_the_same_height_wherever_the_top_of_its_support_lies_in_a_cell() {
    // A damped 10 cm jelly cube on a static box, and on a collider plane, whose top lies on a
    // node layer, half-way, and nine tenths of the way to the next (1 cm cells). With the rule
    // at the nodes inside the solid only, the first node layer inside it held the cube: on the
    // box 1.05 mm lower at 0.9 than at 0, on the plane 1.04 mm.
    let rest = |offset: f32, plane: bool, contact: SurfaceContact| {
        let top = 0.1 + offset * 0.01;
        let builder = Scene::builder()
            .grid_dx_m(0.01)
            .duration_s(0.6) // settled: within 1 µm of the 1 s heights
            .frame_rate_hz(20.0)
            .surface_contact(contact)
            .sleep(false);
        let builder = if plane {
            builder.collider(
                ColliderSpec::plane("top", [0.0, 0.0, top], [0.0, 0.0, 1.0])
                    .surface(Surface::Separate)
                    .friction(0.5),
            )
        } else {
            builder.object(
                SceneObject::cuboid("table", [-0.15, -0.15, top - 0.1], [0.15, 0.15, top])
                    .kind(ObjectKind::Static)
                    .surface(Surface::Separate)
                    .friction(0.5),
            )
        };
        let scene = builder
            .object(
                SceneObject::cuboid(
                    "jelly",
                    [-0.05, -0.05, top + 0.001],
                    [0.05, 0.05, top + 0.101],
                )
                .spacing_m(0.005)
                .material(MaterialSpec {
                    damping_viscosity_pa_s: Some(20.0),
                    ..MaterialSpec::jelly(2e5, 0.3, 1000.0)
                })
                .friction(0.5),
            )
            .build()
            .expect("scene");
        let mut w = World::from_scene(&scene).expect("world");
        while !w.is_finished() {
            w.advance_frame().expect("step");
        }
        com(&w, w.objects().len() - 1).0[2] - f64::from(top)
    };
    for (contact, plane, what) in [
        (SurfaceContact::Grid, false, "static box"),
        (SurfaceContact::Grid, true, "collider plane"),
    ] {
        let heights: Vec<f64> = [0.0, 0.5, 0.9]
            .into_par_iter()
            .map(|o| rest(o, plane, contact))
            .collect();
        println!("{what}: COM above the top {heights:?} m");
        let spread = heights.iter().copied().fold(f64::MIN, f64::max)
            - heights.iter().copied().fold(f64::MAX, f64::min);
        assert!(spread < 0.5e-3, "{what}: rest heights {heights:?} m");
    }
}

/// Gravity tilted by θ about y: a horizontal support becomes a ramp of angle θ (down-slope +x).
fn ramp(theta_deg: f64) -> SceneBuilder {
    let (s, c) = theta_deg.to_radians().sin_cos();
    Scene::builder()
        .grid_dx_m(0.01)
        .frame_rate_hz(50.0)
        .duration_s(1.0)
        .sleep(false)
        .gravity_m_s2([(9.81 * s) as f32, 0.0, (-9.81 * c) as f32])
}

fn slide(mover: ObjectBuilder, mu: f32) -> f64 {
    let scene = ramp(30.0)
        .object(
            SceneObject::cuboid("ramp", [-1.0, -0.3, -0.1], [1.0, 0.3, 0.0])
                .kind(ObjectKind::Static)
                .friction(mu),
        )
        .object(mover.friction(mu).restitution(0.0))
        .build()
        .expect("scene");
    let mut w = World::from_scene(&scene).expect("world");
    run_until(&mut w, 0.3);
    let v0 = com(&w, 1).1[0];
    run_until(&mut w, 0.8);
    let v1 = com(&w, 1).1[0];
    (v1 - v0) / 0.5
}

#[test]
fn a_rigid_box_on_a_ramp_sticks_or_slides_at_the_coulomb_acceleration() {
    let rigid = || {
        SceneObject::cuboid("box", [-0.05, -0.05, 0.0005], [0.05, 0.05, 0.1005])
            .kind(ObjectKind::Rigid)
    };
    let g = 9.81f64;
    let (s, c) = 30f64.to_radians().sin_cos();
    let a = slide(rigid(), 0.3);
    let expected = g * (s - 0.3 * c);
    println!("rigid, mu = 0.3: a = {a:.4} m/s², law {expected:.4}");
    // Exact for a rigid box; the solver meets it to 0.01 % (see the turned slab below).
    assert!((a - expected).abs() < 0.01 * expected);
    let a = slide(rigid(), 0.8);
    println!("rigid, mu = 0.8: a = {a:.5} m/s²");
    assert!(a.abs() < 1e-2, "sticks");
}

#[test]
fn a_jelly_on_a_ramp_slides_at_the_coulomb_acceleration() {
    let jelly = || {
        SceneObject::cuboid("jelly", [-0.05, -0.05, 0.0005], [0.05, 0.05, 0.1005])
            .spacing_m(0.005)
            .material(MaterialSpec::jelly(1e6, 0.3, 1000.0))
    };
    let g = 9.81f64;
    let (s, c) = 30f64.to_radians().sin_cos();
    let a = slide(jelly(), 0.3);
    let expected = g * (s - 0.3 * c);
    println!("jelly, mu = 0.3: a = {a:.4} m/s², law {expected:.4}");
    assert!((a - expected).abs() < 0.05 * expected);
}

/// Acceleration (m/s²) along the slope of a box of kind `kind` resting on a static slab turned
/// 30° about y (gravity straight down), between 0.3 s and 0.8 s, friction `mu` on both.
fn slide_on_turned_slab(kind: ObjectKind, mu: f32) -> f64 {
    let turn = [0.0, 30.0, 0.0];
    let theta = 30f64.to_radians();
    let (s, c) = theta.sin_cos();
    // The slab's top face normal is R z = (sin θ, 0, cos θ); down the slope is (cos θ, 0, -sin θ).
    let normal = [s, 0.0, c];
    let down = [c, 0.0, -s];
    // The box sits on the top face: its centre 5 cm (slab) + 5 cm (box) + 0.5 mm along the normal.
    let up = 0.1005;
    let centre = [normal[0] * up, 0.0, -0.05 + normal[2] * up];
    let scene = Scene::builder()
        .grid_dx_m(0.01)
        .frame_rate_hz(50.0)
        .duration_s(1.0)
        .sleep(false)
        .object(
            SceneObject::cuboid("slab", [-1.0, -0.3, -0.1], [1.0, 0.3, 0.0])
                .rotation_deg(turn)
                .kind(ObjectKind::Static)
                .friction(mu),
        )
        .object(
            SceneObject::cuboid(
                "box",
                [centre[0] as f32 - 0.05, -0.05, centre[2] as f32 - 0.05],
                [centre[0] as f32 + 0.05, 0.05, centre[2] as f32 + 0.05],
            )
            .spacing_m(0.005)
            .rotation_deg(turn)
            .kind(kind)
            .material(MaterialSpec::jelly(1e6, 0.3, 1000.0))
            .friction(mu)
            .restitution(0.0),
        )
        .build()
        .expect("scene");
    let mut w = World::from_scene(&scene).expect("world");
    let along = |w: &World| {
        let v = com(w, 1).1;
        v[0] * down[0] + v[2] * down[2]
    };
    run_until(&mut w, 0.3);
    let v0 = along(&w);
    run_until(&mut w, 0.8);
    (along(&w) - v0) / 0.5
}

#[test]
fn boxes_on_a_turned_static_slab_slide_at_the_coulomb_acceleration() {
    // The ramp test again with the geometry turned instead of gravity.
    let (s, c) = 30f64.to_radians().sin_cos();
    let law = 9.81 * (s - 0.3 * c);
    // The law is exact for a rigid box, and the solver meets it to 0.03 % (friction per patch
    // with a stable manifold; per-point friction gave the box a spin about the normal and
    // +3 %). 1 % leaves room for the solver's convergence on other lattices. The jelly's
    // grid contact meets it to 0.0 % here; 2 % leaves room on other lattices.
    for (kind, tol) in [(ObjectKind::Rigid, 0.01), (ObjectKind::Deformable, 0.02)] {
        let a = slide_on_turned_slab(kind, 0.3);
        println!("{kind} box on a slab turned 30°, mu = 0.3: a = {a:.4} m/s², law {law:.4}");
        assert!((a - law).abs() < tol * law, "{kind}: {a} against {law}");
    }
    let a = slide_on_turned_slab(ObjectKind::Rigid, 0.8);
    println!("rigid box, mu = 0.8: a = {a:.5} m/s²");
    assert!(a.abs() < 1e-2, "sticks: {a}");
}

/// A block falling at 1 m/s (no gravity) onto two static supports under its ends (e = 0, so
/// the pair's e = max(e_block, 0) is the block's).
/// `seed` draws the block's lattice jitter.
fn two_supports(block: ObjectBuilder, contact: SurfaceContact, seed: u64) -> World {
    let scene = Scene::builder()
        .surface_contact(contact)
        .seed(seed)
        .grid_dx_m(0.01)
        .frame_rate_hz(100.0)
        .duration_s(0.4)
        .gravity_m_s2([0.0; 3])
        .sleep(false)
        .object(
            SceneObject::cuboid("left", [-0.2, -0.1, -0.1], [-0.1, 0.1, 0.0])
                .kind(ObjectKind::Static)
                .restitution(0.0)
                .friction(0.0),
        )
        .object(
            SceneObject::cuboid("right", [0.1, -0.1, -0.1], [0.2, 0.1, 0.0])
                .kind(ObjectKind::Static)
                .restitution(0.0)
                .friction(0.0),
        )
        .object(block.velocity([0.0, 0.0, -1.0]).friction(0.0))
        .build()
        .expect("scene");
    let mut w = World::from_scene(&scene).expect("world");
    while !w.is_finished() {
        w.advance_frame().expect("step");
    }
    w
}

#[test]
fn impacts_on_two_supports_stay_symmetric_and_follow_e() {
    let block = |e: f32, kind: ObjectKind| {
        SceneObject::cuboid("block", [-0.18, -0.05, 0.005], [0.18, 0.05, 0.055])
            .kind(kind)
            .restitution(e)
            .material(MaterialSpec::jelly(2e5, 0.3, 1000.0))
    };
    // The grid rule holds a jelly block to 1 % over five lattices (0.06–0.79 % measured). The
    // particle barrier pushes along one normal per face of a support, and the jittered lattice
    // leaves a few particles beside each support's inner edge, below its top, where the side
    // face pushes them sideways (a face of their own, to keep the push conservative); how many
    // depends on the lattice: 0.3–4.8 % of the impact over seeds 0–4 (one normal per support
    // was smaller but pushed each face's particles partly along the other's normal and gained
    // energy). Bounded at 10 % here; the goal is 2 %.
    let mut runs = vec![
        (0.0, ObjectKind::Rigid, SurfaceContact::Grid, 0),
        (1.0, ObjectKind::Rigid, SurfaceContact::Grid, 0),
    ];
    for seed in 0..5 {
        runs.push((0.0, ObjectKind::Deformable, SurfaceContact::Grid, seed));
        runs.push((0.0, ObjectKind::Deformable, SurfaceContact::Barrier, seed));
    }
    for (e, kind, contact, seed) in runs {
        let w = two_supports(block(e, kind), contact, seed);
        let (_, v) = com(&w, 2);
        let sideways = (v[0] * v[0] + v[1] * v[1]).sqrt();
        println!(
            "{kind:?} e = {e}, {}, seed {seed}: v = {v:?}",
            contact.name()
        );
        // Of the 1 m/s impact speed.
        let bound = if contact == SurfaceContact::Barrier {
            0.1
        } else {
            0.01
        };
        assert!(
            sideways <= bound,
            "{kind:?} e = {e}, {}, seed {seed}: sideways {sideways:.4} m/s",
            contact.name()
        );
        if kind == ObjectKind::Rigid {
            let b = &w.bodies()[2];
            let ke = 0.5 * b.rigid().mass_kg * b.rigid().velocity_m_s.length_squared()
                + 0.5
                    * b.rigid()
                        .omega_rad_s
                        .dot(b.rigid_world_inertia() * b.rigid().omega_rad_s);
            let ke0 = 0.5 * b.rigid().mass_kg;
            if e == 0.0 {
                assert!(v[2].abs() <= 0.01, "bounced at {} m/s", v[2]);
            } else {
                assert!(
                    ke <= 1.01 * ke0,
                    "energy grew by {:.2} %",
                    (ke / ke0 - 1.0) * 100.0
                );
                assert!(v[2] > 0.95, "e = 1 bounce {}", v[2]);
            }
        }
    }
}

/// 0.3 s without gravity, dx = 1 cm.
fn weightless() -> SceneBuilder {
    Scene::builder()
        .grid_dx_m(0.01)
        .frame_rate_hz(100.0)
        .duration_s(0.3)
        .gravity_m_s2([0.0; 3])
        .sleep(false)
}

/// A 10 cm jelly cube 1 cm above z = 0, thrown down at 1 m/s, restitution `e`, no friction.
fn thrown_jelly(e: f32) -> ObjectBuilder {
    SceneObject::cuboid("jelly", [-0.05, -0.05, 0.01], [0.05, 0.05, 0.11])
        .spacing_m(0.005)
        .material(MaterialSpec::jelly(2e5, 0.3, 1000.0))
        .restitution(e)
        .friction(0.0)
        .velocity([0.0, 0.0, -1.0])
}

#[test]
fn a_jelly_bouncing_off_a_static_box_follows_e() {
    // No gravity: a jelly cube at 1 m/s onto a static slab. The grid stops it and its elasticity
    // throws it back; the restitution law then leaves e times the approach speed.
    for e in [0.0f32, 0.5, 1.0] {
        let scene = weightless()
            .object(
                SceneObject::cuboid("slab", [-0.2, -0.2, -0.1], [0.2, 0.2, 0.0])
                    .kind(ObjectKind::Static)
                    .restitution(0.0)
                    .friction(0.0),
            )
            .object(thrown_jelly(e))
            .build()
            .expect("scene");
        let mut w = World::from_scene(&scene).expect("world");
        let mut lowest = f32::INFINITY;
        while !w.is_finished() {
            w.advance_frame().expect("step");
            let z = w.bodies()[1].particles().x.iter().map(|x| x.z);
            lowest = z.fold(lowest, f32::min);
        }
        let v = com(&w, 1).1[2];
        println!(
            "e = {e}: rebound {v:.4} m/s, lowest particle {:.1} mm",
            lowest * 1e3
        );
        // It lands on the slab, not on a cushion of grid nodes above it: its particles (5 mm
        // apart, so their surface lies 2.5 mm below the lowest) come within a millimetre of the
        // top. (When every node inside the slab took the rule, it turned back 7.4 mm up.)
        assert!(
            lowest < 0.0035,
            "e = {e}: turned back {lowest} m above the slab"
        );
        if e < 1.0 {
            // The law: e times the 1 m/s approach, to 1 % of it.
            assert!((v - f64::from(e)).abs() < 0.01, "e = {e}: rebound {v}");
        } else {
            // e = 1 asks for no loss; the law never adds energy, so the jelly keeps what its
            // own elasticity returns. MPM loses some at the sudden stop of its bottom layer on
            // a 1 cm grid: 0.79 m/s here (0.93 on the cushion of nodes, which never let it touch).
            assert!(v > 0.75 && v <= 1.0, "e = 1: rebound {v}");
        }
    }
}

#[test]
fn a_jelly_dropped_on_a_collider_table_follows_e_and_still_jumps_when_pushed() {
    // The same law at a grid collider (the collider's e is the object's): a jelly cube at 1 m/s
    // onto a plane, no gravity, rebounds at e.
    let scene = |e: f32| {
        weightless()
            .collider(
                ColliderSpec::plane("table", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
                    .surface(Surface::Separate)
                    .friction(0.0),
            )
            .object(thrown_jelly(e))
            .build()
            .expect("scene")
    };
    for e in [0.0f32, 0.5] {
        let mut w = World::from_scene(&scene(e)).expect("world");
        while !w.is_finished() {
            w.advance_frame().expect("step");
        }
        let v = com(&w, 0).1[2];
        println!("collider, e = {e}: rebound {v:.4} m/s");
        assert!((v - f64::from(e)).abs() < 0.01, "e = {e}: rebound {v}");
    }
    // A jelly resting on the table (e = 0) and then sent up at 0.5 m/s keeps that speed when it
    // leaves: a command is not a rebound.
    let mut w = World::from_scene(&scene(0.0)).expect("world");
    while !w.is_finished() {
        w.advance_frame().expect("step");
    }
    w.apply(&splatphys_core::scene::Command::SetVelocity {
        object: 0,
        velocity_m_s: [0.0, 0.0, 0.5],
        angular_velocity_rad_s: None,
    })
    .expect("accepted");
    for _ in 0..10 {
        w.advance_frame().expect("step");
    }
    let v = com(&w, 0).1[2];
    println!("sent up from rest at 0.5 m/s: {v:.4} m/s after 0.1 s");
    assert!((v - 0.5).abs() < 0.02, "{v}");
}

#[test]
fn an_oblique_jelly_rebounds_at_e_along_the_normal_whatever_the_friction() {
    // No gravity: a jelly cube at 45°, (1, 0, −1) m/s, onto a plane with friction (a grid
    // collider, and a static slab). Friction takes tangential momentum during the impact, and the
    // grid's impulse then leans away from the normal; the restitution law must still act along
    // the surface normal: the rebound is e times the 1 m/s approach, whatever μ and the surface.
    // (The slab's own e is 0, so the pair's e = max(e_A, e_B) is the jelly's.) And friction
    // takes no more than Coulomb's law allows for the normal impulse the impact keeps,
    // μ (1 + e) times 1 m/s per kg, though the grid's impact is nearly elastic until the law
    // acts: the cube slides on at 1 − μ (1 + e) m/s at least (0.7 at μ = 0.3 and e = 0, where
    // friction over the grid's whole contact left it 0.46), and never faster than it came.
    let collider = |surface: Surface, mu: f32| {
        ColliderSpec::plane("table", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
            .surface(surface)
            .friction(mu)
    };
    let slab = |surface: Surface, mu: f32| {
        SceneObject::cuboid("slab", [-0.3, -0.3, -0.1], [0.3, 0.3, 0.0])
            .kind(ObjectKind::Static)
            .surface(surface)
            .friction(mu)
            .restitution(0.0)
    };
    let mut runs = Vec::new();
    for (surface, mu) in [
        (Surface::Separate, 0.3),
        (Surface::Separate, 0.6),
        (Surface::Sticky, 1.0),
    ] {
        for e in [0.0f32, 0.5] {
            for on_slab in [false, true] {
                runs.push((surface, mu, e, on_slab));
            }
        }
    }
    // The runs side by side (each world is mostly serial).
    let rebounds: Vec<_> = runs
        .into_par_iter()
        .map(|(surface, mu, e, on_slab)| {
            let jelly = thrown_jelly(e).friction(mu).velocity([1.0, 0.0, -1.0]);
            let scene = if on_slab {
                weightless().object(jelly).object(slab(surface, mu))
            } else {
                weightless().object(jelly).collider(collider(surface, mu))
            };
            let mut w = World::from_scene(&scene.build().expect("scene")).expect("world");
            while !w.is_finished() {
                w.advance_frame().expect("step");
            }
            (surface, mu, e, on_slab, com(&w, 0).1)
        })
        .collect();
    for (surface, mu, e, on_slab, v) in rebounds {
        let on = if on_slab { "static slab" } else { "collider" };
        println!(
            "{on}, {surface:?}, mu = {mu}, e = {e}: rebound {:.4} m/s, v_x {:.4}",
            v[2], v[0]
        );
        // The same 1 % as the head-on drops above.
        assert!(
            (v[2] - f64::from(e)).abs() < 0.01,
            "{on}, {surface:?}, mu = {mu}, e = {e}: {v:?}"
        );
        let coulomb = 1.0 - f64::from(surface.friction(mu)) * (1.0 + f64::from(e));
        assert!(
            v[0] > coulomb - 0.01 && v[0] < 1.0,
            "{on}, {surface:?}, mu = {mu}, e = {e}: v_x {:.4} against Coulomb's {coulomb:.4}",
            v[0]
        );
    }
}

#[test]
fn an_oblique_jelly_on_a_free_slab_keeps_the_momentum_and_coulombs_bound() {
    // No gravity: the 1 kg jelly cube at (1, 0, −1) m/s onto a free rigid slab (40 × 40 × 2 cm,
    // 1.6 kg), μ = 0.3, e = 0. What the restitution law gives back of the grid's friction the
    // slab gives up: the pair's momentum holds along every axis. The two leave together along
    // the normal, and their sliding speed falls by at most μ times the 1 m/s approach (the
    // slab's turn adds half a percent to that): 0.76 m/s, where friction over the grid's whole
    // contact left 0.52.
    let slab = SceneObject::cuboid("slab", [-0.2, -0.2, -0.02], [0.2, 0.2, 0.0])
        .spacing_m(0.005)
        .material(MaterialSpec::jelly(1e6, 0.3, 500.0))
        .kind(ObjectKind::Rigid)
        .friction(0.3)
        .restitution(0.0);
    let jelly = thrown_jelly(0.0).friction(0.3).velocity([1.0, 0.0, -1.0]);
    let scene = weightless().object(jelly).object(slab);
    let mut w = World::from_scene(&scene.build().expect("scene")).expect("world");
    let momentum = |w: &World| {
        let mut p = [0.0f64; 3];
        for o in w.objects() {
            for (a, v) in p.iter_mut().zip(o.velocity_m_s) {
                *a += o.mass_kg * v;
            }
        }
        p
    };
    let before = momentum(&w);
    while !w.is_finished() {
        w.advance_frame().expect("step");
    }
    let after = momentum(&w);
    let (v_jelly, v_slab) = (com(&w, 0).1, com(&w, 1).1);
    let (slide, normal) = (v_jelly[0] - v_slab[0], v_jelly[2] - v_slab[2]);
    println!(
        "jelly {v_jelly:.4?}, slab {v_slab:.4?} m/s, slab turning at {:.4?} rad/s; momentum \
         {before:.4?} -> {after:.4?} N s",
        w.objects()[1].angular_velocity_rad_s
    );
    for axis in 0..3 {
        assert!(
            (after[axis] - before[axis]).abs() < 0.01,
            "momentum {before:?} -> {after:?}"
        );
    }
    // At e = 0 they part at the contact point, where the slab, turned by the friction, falls
    // away a little faster than its COM (0.56 rad/s about 3 cm from it: 0.02 m/s).
    assert!(normal.abs() < 0.03, "they separate at {normal} m/s");
    assert!(slide > 0.68 && slide < 1.0, "sliding at {slide} m/s");
}

/// A sand column collapsing next to a static box stops at the box's face: the box is a boundary
/// on the sand's grid. Without the box the same sand runs out past where the face would be, so
/// the check can fail.
#[test]
fn a_sand_column_collapsing_against_a_static_box_stops_at_it() {
    // The box's face toward the sand, m (the column's edge is at x = 0.05).
    const FACE_X: f32 = 0.08;
    let run = |with_box: bool| {
        let mut scene = Scene::builder()
            .grid_dx_m(0.01)
            .duration_s(0.8)
            .frame_rate_hz(30.0)
            .sleep(false)
            .collider(
                ColliderSpec::plane("floor", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
                    .surface(Surface::Separate)
                    .friction(0.5),
            )
            .object(
                SceneObject::cylinder("sand", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 0.05, 0.15)
                    .spacing_m(0.006)
                    .material(MaterialSpec::new(
                        splatphys_core::material::MaterialModel::Sand,
                        3.5e5,
                        0.3,
                        1600.0,
                    ))
                    .friction(0.5),
            );
        if with_box {
            scene = scene.object(
                SceneObject::cuboid("wall", [FACE_X, -0.12, 0.0], [FACE_X + 0.04, 0.12, 0.1])
                    .kind(ObjectKind::Static)
                    .friction(0.5),
            );
        }
        let mut w = World::from_scene(&scene.build().expect("scene")).expect("world");
        run_until(&mut w, 0.8);
        // The farthest grain in +x below the wall's top, m.
        let sand = w.bodies()[0].particles();
        let reach = sand
            .x
            .iter()
            .filter(|x| x.z < 0.1 && x.y.abs() < 0.1)
            .map(|x| x.x)
            .fold(f32::MIN, f32::max);
        let top = sand.x.iter().map(|x| x.z).fold(0.0f32, f32::max);
        (reach, top)
    };
    // Side by side (each world is mostly serial).
    let ((free_reach, free_top), (reach, top)) = rayon::join(|| run(false), || run(true));
    println!(
        "sand reaches x = {:.1} mm without the box, {:.1} mm with its face at {:.0} mm (tops {:.0} / {:.0} mm)",
        free_reach * 1e3,
        reach * 1e3,
        FACE_X * 1e3,
        free_top * 1e3,
        top * 1e3
    );
    assert!(
        free_top < 0.13,
        "the column collapses (top at {free_top} m)"
    );
    assert!(
        free_reach > FACE_X + 0.01,
        "without the box the sand runs past the face ({free_reach} m)"
    );
    // With it: stopped at the face, within half a grid cell, and piled against it (the
    // boundary nodes hold grains off the face by up to a cell and a half).
    assert!(
        reach < FACE_X + 0.005,
        "sand went {:.1} mm into the box",
        (reach - FACE_X) * 1e3
    );
    assert!(
        reach > FACE_X - 0.015,
        "the sand stopped {:.1} mm short of the face",
        (FACE_X - reach) * 1e3
    );
}
