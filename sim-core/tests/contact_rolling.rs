//! A jelly ball thrown along a solid rolls on (release build): on a collider plane and on a
//! static slab whose top lies on a grid node layer or half-way between two, it turns until it
//! rolls without slipping and never rolls back. Under the grid rule it slows; through the
//! particle barrier (`surface_contact = "barrier"`, `splatphys_core::contact::barrier`) it
//! rolls on at 5/7 of its throw, and a ball set rolling on a frictionless plane keeps its spin.
//! Landing obliquely, a jelly ball slides and then rolls on at 5/7 of its sliding speed, as a
//! rigid one does. On a captured table (a sampled level set) it rolls as on a procedural slab,
//! under the grid rule and through the barrier.
//!
//! Only nodes where material meets the surface take the solid's rule (`splatphys_core::mpm::reach`).
//! When every node inside the solid took it, the band of nodes ahead of the contact, up to 1.5
//! cells deep, stopped the ball's surface as it turned down towards the solid: on a plane or a
//! slab top at a node layer the ball stopped within 0.15 s and rocked to and fro (v_x between
//! −0.07 and +0.06 m/s), and on a captured table it rolled back at 0.15 s.

use rayon::prelude::*;
use splatphys_core::material::MaterialSpec;
use splatphys_core::scene::{
    ColliderSpec, ObjectKind, Scene, SceneObject, Surface, SurfaceContact,
};
use splatphys_core::world::World;

mod support;

/// The throw (m/s) and the rolling speed a uniform ball reaches, 5/7 of it.
const V0_M_S: f64 = 0.4;
const ROLLING_M_S: f64 = V0_M_S * 5.0 / 7.0;
/// The ball's radius (m).
const R_M: f32 = 0.04;

/// A jelly ball (E = 2e5 Pa, ν = 0.3, 1000 kg/m³, particles half a cell apart, μ = `mu`)
/// resting on a surface at `top_m` on a grid of cell `dx_m`, thrown along it at [`V0_M_S`] (with
/// `spin`, set rolling at that speed instead): on a collider plane when `plane`, else on a
/// static slab, under `contact`. Returns (time s, v_x m/s, ω_y R m/s) every 0.05 s over
/// `duration_s`.
fn throw(
    (plane, top_m, dx_m): (bool, f32, f32),
    (mu, spin): (f32, bool),
    contact: SurfaceContact,
    duration_s: f64,
) -> Vec<(f64, f64, f64)> {
    let mut scene = Scene::builder()
        .grid_dx_m(dx_m as f64)
        .duration_s(duration_s)
        .frame_rate_hz(20.0)
        .sleep(false)
        .surface_contact(contact);
    scene = if plane {
        scene.collider(
            ColliderSpec::plane("floor", [0.0, 0.0, top_m], [0.0, 0.0, 1.0])
                .surface(Surface::Separate)
                .friction(mu),
        )
    } else {
        scene.object(
            SceneObject::cuboid("slab", [-0.3, -0.2, top_m - 0.05], [0.6, 0.2, top_m])
                .kind(ObjectKind::Static)
                .friction(mu),
        )
    };
    let scene = scene
        .object(
            SceneObject::sphere("ball", [0.0, 0.0, top_m + R_M + 0.0005], R_M)
                .spacing_m(dx_m / 2.0)
                .material(MaterialSpec::jelly(2e5, 0.3, 1000.0))
                .friction(mu)
                .velocity([V0_M_S as f32, 0.0, 0.0]),
        )
        .build()
        .expect("scene");
    let mut w = World::from_scene(&scene).expect("world");
    let ball = usize::from(!plane);
    if spin {
        let v = glam::Vec3A::new(V0_M_S as f32, 0.0, 0.0);
        let omega = glam::Vec3A::new(0.0, V0_M_S as f32 / R_M, 0.0);
        w.set_velocity(ball, v, Some(omega)).expect("set rolling");
    }
    let mut out = Vec::new();
    while !w.is_finished() {
        w.advance_frame().expect("step");
        let o = &w.objects()[ball];
        out.push((
            w.time_s(),
            o.velocity_m_s[0],
            o.angular_velocity_rad_s[1] * R_M as f64,
        ));
    }
    out
}

/// A run of [`throw`] as "t: v_x/ω_y R" pairs, for the tests' output.
fn frames(run: &[(f64, f64, f64)]) -> String {
    let line: Vec<String> = run
        .iter()
        .map(|(t, v, wr)| format!("{t:.2}: {v:.3}/{wr:.3}"))
        .collect();
    line.join(", ")
}

#[test]
fn a_jelly_ball_thrown_along_a_solid_rolls_and_never_rolls_back() {
    let runs = [
        (true, 0.0f32, "collider plane on a node layer"),
        (false, 0.0, "static slab, top on a node layer"),
        (false, 0.005, "static slab, top half-way between layers"),
    ]
    .map(|(plane, top, what)| {
        let run = throw((plane, top, 0.01), (0.5, false), SurfaceContact::Grid, 0.6);
        (run, what)
    });
    let captured = (
        throw_on_captured(SurfaceContact::Grid, 0.01, 0.6),
        "captured table",
    );
    for (run, what) in runs.into_iter().chain([captured]) {
        println!("{what}: t: v_x/ω_y R (m/s) {}", frames(&run));
        for &(t, v, wr) in &run {
            assert!(
                v > 0.0,
                "{what}: the ball rolled back at {t:.2} s (v_x {v:.3} m/s)"
            );
            if t >= 0.1 - 1e-9 {
                // Rolling, not sliding or held: ω R = v within a fifth (its ω is a fit to a
                // soft ball of particles).
                assert!(
                    (wr - v).abs() < 0.2 * v.max(0.05),
                    "{what}: not rolling at {t:.2} s: v_x {v:.3}, ω R {wr:.3} m/s"
                );
            }
        }
        // At 0.2 s still rolling at no less than 0.7 of a uniform ball's 5/7 v0. (It slows on:
        // the material that meets the surface ahead of the contact is stopped there, which
        // brakes the spin; see the README's limitations.)
        let (_, v, _) = run
            .iter()
            .find(|(t, _, _)| *t >= 0.2 - 1e-9)
            .copied()
            .expect("0.2 s");
        assert!(
            v > 0.7 * ROLLING_M_S,
            "{what}: {v:.3} m/s at 0.2 s, a uniform ball rolls at {ROLLING_M_S:.3}"
        );
    }
}

#[test]
fn a_jelly_ball_rolling_on_a_plane_slows_less_on_a_finer_grid() {
    // The ball's loss of speed is a resolution effect: the normal rule stops the material that
    // turns down towards the surface ahead of the contact at the grid nodes there, over a band a
    // cell wide. Halving the cell (4 and 8 cells across the radius) must cut the slowing from
    // 0.1 s to 0.6 s by more than a third (measured: 0.216 against 0.121 m/s²; 0.08 m/s² from
    // 0.2 s to 0.8 s on 5 mm).
    let slowing = |dx_m: f32| {
        let run = throw((true, 0.0, dx_m), (0.5, false), SurfaceContact::Grid, 0.6);
        let at = |t: f64| {
            run.iter()
                .find(|(s, _, _)| *s >= t - 1e-9)
                .map(|r| r.1)
                .expect("time in the run")
        };
        (at(0.1) - at(0.6)) / 0.5
    };
    let (coarse, fine) = (slowing(0.01), slowing(0.005));
    println!("rolling on a plane: slowing {coarse:.3} m/s² on a 1 cm grid, {fine:.3} m/s² on 5 mm");
    assert!(fine < 0.67 * coarse, "{fine} vs {coarse}");
    assert!(fine > 0.0, "the fine ball sped up: {fine}");
}

/// The three surfaces of [`a_jelly_ball_thrown_along_a_solid_rolls_and_never_rolls_back`].
const SURFACES: [(bool, f32, &str); 3] = [
    (true, 0.0, "collider plane on a node layer"),
    (false, 0.0, "static slab, top on a node layer"),
    (false, 0.005, "static slab, top half-way between layers"),
];

#[test]
fn through_the_particle_barrier_a_thrown_jelly_ball_rolls_on_at_five_sevenths() {
    // The closed form: a uniform ball thrown without spin slides for 2 v0 / (7 μ g) = 0.023 s
    // and rolls on at 5/7 v0. Over 0.8 s, from 0.2 s on: never back, rolling (ω R = v within a
    // fifth), its mean speed within 12 % of 5/7 v0 and every frame within 20 %, and no steady
    // slowing (the last 0.2 s keep 90 % of the mean of 0.2-0.4 s). Measured 2026-11-26: means
    // 0.254-0.264 m/s (-11 % to -8 %; the ball of particles is lumpy, and friction acts
    // through the touching particles), frames 0.230-0.290 m/s; under the grid rule the same
    // ball slows to 0.10-0.18 m/s by 0.6 s. On the captured table (2026-11-29): mean 0.254 m/s;
    // when the barrier acted at procedural solids only, it slowed there as under the grid rule.
    let procedural = SURFACES.map(|(plane, top, what)| {
        let run = throw(
            (plane, top, 0.01),
            (0.5, false),
            SurfaceContact::Barrier,
            0.8,
        );
        (run, what)
    });
    let captured = (
        throw_on_captured(SurfaceContact::Barrier, 0.01, 0.8),
        "captured table",
    );
    for (run, what) in procedural.into_iter().chain([captured]) {
        println!("{what}, barrier: t: v_x/ω_y R (m/s) {}", frames(&run));
        let late: Vec<(f64, f64, f64)> =
            run.iter().copied().filter(|r| r.0 >= 0.2 - 1e-9).collect();
        for &(t, v, wr) in &run {
            assert!(v > 0.0, "{what}: rolled back at {t:.2} s ({v:.3} m/s)");
            if t >= 0.1 - 1e-9 {
                assert!(
                    (wr - v).abs() < 0.2 * v,
                    "{what}: not rolling at {t:.2} s: v_x {v:.3}, ω R {wr:.3} m/s"
                );
            }
        }
        for &(t, v, _) in &late {
            assert!(
                (v / ROLLING_M_S - 1.0).abs() < 0.2,
                "{what}: {v:.3} m/s at {t:.2} s, 5/7 v0 = {ROLLING_M_S:.3}"
            );
        }
        let mean = |from: f64, to: f64| {
            let vs: Vec<f64> = late
                .iter()
                .filter(|r| r.0 >= from - 1e-9 && r.0 <= to + 1e-9)
                .map(|r| r.1)
                .collect();
            vs.iter().sum::<f64>() / vs.len() as f64
        };
        let all = mean(0.2, 0.8);
        println!("{what}, barrier: mean {all:.3} m/s from 0.2 s, 5/7 v0 = {ROLLING_M_S:.3}");
        assert!(
            (all / ROLLING_M_S - 1.0).abs() < 0.12,
            "{what}: mean {all:.3} m/s"
        );
        assert!(
            mean(0.6, 0.8) > 0.9 * mean(0.2, 0.4),
            "{what}: slowed from {:.3} to {:.3} m/s",
            mean(0.2, 0.4),
            mean(0.6, 0.8)
        );
    }
}

#[test]
fn through_the_particle_barrier_on_a_5_mm_grid_a_thrown_jelly_ball_rolls_within_a_tenth() {
    // The same ball on cells half as wide (16 across it, particles 2.5 mm): from 0.2 s to 0.8 s
    // every frame within 10 % of 5/7 v0 and rolling (ω R = v within a tenth), never back, on a
    // collider plane, on a static slab whose top lies half-way between node layers and on the
    // captured table. Measured 2026-11-29 (frames every 0.01 s): means 0.273-0.278 m/s (5/7 v0
    // = 0.286), frames 0.269-0.286 m/s; on 1 cm cells the means are 8-12 % below (the test
    // above): what the barrier loses is a matter of resolution.
    let dx = 0.005;
    // The three runs side by side (each world is mostly serial).
    let cases = [
        (Some((true, 0.0)), "collider plane"),
        (
            Some((false, 0.5 * dx)),
            "static slab, top half-way between layers",
        ),
        (None, "captured table"),
    ];
    let runs: Vec<_> = cases
        .into_par_iter()
        .map(|(procedural, what)| {
            let run = match procedural {
                Some((plane, top)) => {
                    throw((plane, top, dx), (0.5, false), SurfaceContact::Barrier, 0.8)
                }
                None => throw_on_captured(SurfaceContact::Barrier, dx, 0.8),
            };
            (run, what)
        })
        .collect();
    for (run, what) in runs {
        println!("{what}, barrier, 5 mm: t: v_x/ω_y R (m/s) {}", frames(&run));
        for &(t, v, wr) in &run {
            assert!(v > 0.0, "{what}: rolled back at {t:.2} s ({v:.3} m/s)");
            if t >= 0.2 - 1e-9 {
                assert!(
                    (v / ROLLING_M_S - 1.0).abs() < 0.1,
                    "{what}: {v:.3} m/s at {t:.2} s, 5/7 v0 = {ROLLING_M_S:.3}"
                );
                assert!(
                    (wr - v).abs() < 0.1 * v,
                    "{what}: not rolling at {t:.2} s: v_x {v:.3}, ω R {wr:.3} m/s"
                );
            }
        }
    }
}

#[test]
fn through_the_particle_barrier_a_ball_set_rolling_on_a_frictionless_plane_keeps_its_spin() {
    // Nothing tangential acts: the spin may change only by a normal support off the ball's
    // centre. The grid rule's support sat ahead of it and stopped the spin within 0.5 s; the
    // barrier's is about symmetric (measured 2026-11-26, set rolling at 0.4 m/s: ω R from
    // 0.38 m/s at 0.05 s to 0.27 m/s at 0.8 s, where the grid rule's is 0; what is left is lost
    // as the lumps of a ball of particles roll over the barrier).
    let run = throw((true, 0.0, 0.01), (0.0, true), SurfaceContact::Barrier, 0.8);
    let grid = throw((true, 0.0, 0.01), (0.0, true), SurfaceContact::Grid, 0.8);
    for ((t, v, wr), (_, _, wr_grid)) in run.iter().zip(&grid) {
        println!("{t:.2} s: v_x {v:.3} m/s, ω R {wr:.3} m/s (grid rule {wr_grid:.3})");
    }
    for &(t, _, wr) in &run {
        assert!(
            wr > 0.6 * V0_M_S,
            "the spin fell to ω R = {wr:.3} m/s at {t:.2} s"
        );
    }
    let (_, _, last_grid) = grid.last().copied().expect("frames");
    assert!(
        last_grid < 0.5 * V0_M_S,
        "the grid rule kept ω R = {last_grid:.3} m/s: this test no longer shows what it fixes"
    );
}

#[test]
fn a_jelly_ball_landing_obliquely_rolls_on_at_five_sevenths_of_its_sliding_speed() {
    // The 4 cm jelly ball landing at (1, 0, −1) m/s on a "separate" plane, μ = 0.2, e = 0, 1 cm
    // cells. A uniform rigid ball slides after the impact (rolling would take 2/7 of a 1 m/s
    // tangential impulse per kg, Coulomb allows μ times the 1 m/s normal one), then rolls at
    // 5/7 of 1 m/s, 0.714. The restitution law holds each impact's friction to μ times the
    // normal impulse the impact keeps: with the grid's friction acting through the elastic
    // rebound as well, the ball rolled on at 0.66 m/s.
    let scene = Scene::builder()
        .grid_dx_m(0.01)
        .frame_rate_hz(50.0)
        .duration_s(0.3)
        .sleep(false)
        .collider(
            ColliderSpec::plane("table", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
                .surface(Surface::Separate)
                .friction(0.2),
        )
        .object(
            SceneObject::sphere("ball", [0.0, 0.0, 0.045], R_M)
                .spacing_m(0.005)
                .material(MaterialSpec::jelly(2e5, 0.3, 1000.0))
                .restitution(0.0)
                .friction(0.2)
                .velocity([1.0, 0.0, -1.0]),
        )
        .build()
        .expect("scene");
    let mut w = World::from_scene(&scene).expect("world");
    let rolling = 5.0 / 7.0;
    let mut line = String::new();
    while !w.is_finished() {
        w.advance_frame().expect("step");
        let o = &w.objects()[0];
        let (v, spin) = (
            o.velocity_m_s[0],
            o.angular_velocity_rad_s[1] * f64::from(R_M),
        );
        line += &format!(" {:.2} s: {v:.3}/{spin:.3}", w.time_s());
        if w.time_s() > 0.119 {
            assert!(
                (v - rolling).abs() < 0.03 * rolling && (spin - rolling).abs() < 0.05 * rolling,
                "at {:.2} s: v_x {v:.3}, ω_y R {spin:.3} m/s;{line}",
                w.time_s()
            );
        }
    }
    println!("v_x/ω_y R (m/s):{line}");
}

/// Writes `table.ply` to `dir`: a captured table, 1 m × 0.4 m of opaque Gaussians 5 mm apart in
/// two layers, the top layer's centres at z = −2.5 mm, so that its level set's top face is
/// z = 0.
fn write_captured_table(dir: &std::path::Path) {
    let table = support::flat_capture([-0.3, -0.2], [200, 80], 0.005, 0.0, &[]);
    splatphys_core::formats::ply::write_ply(dir.join("table.ply"), &table, &[]).expect("ply");
}

/// [`throw`] on the captured table of [`write_captured_table`] (the scene's background, its
/// top at z = 0, cells `dx_m`, particles half a cell apart, μ 0.5 for the ball, the
/// background's own 0.5) under `contact` over `duration_s`.
fn throw_on_captured(contact: SurfaceContact, dx_m: f32, duration_s: f64) -> Vec<(f64, f64, f64)> {
    let dir = tempfile::tempdir().expect("tempdir");
    write_captured_table(dir.path());
    let text = format!(
        r#"
[simulation]
duration_s = {duration_s}
frame_rate_hz = 20.0
grid_dx_m = {dx_m}
sleep = false
surface_contact = "{contact}"

[[source]]
name = "table"
path = "table.ply"

[[object]]
name = "ball"
shape = {{ sphere = {{ center_m = [0.0, 0.0, {z}], radius_m = {R_M} }} }}
spacing_m = {spacing}
material = {{ model = "jelly", youngs_modulus_pa = 2e5, poisson_ratio = 0.3, density_kg_m3 = 1000.0 }}
friction = 0.5
velocity_m_s = [{V0_M_S}, 0.0, 0.0]
"#,
        z = R_M + 0.0005,
        spacing = dx_m / 2.0,
        contact = contact.name(),
    );
    let scene = splatphys_core::scene::load_scene_str(&text, dir.path()).expect("scene");
    let mut w = World::from_scene(&scene).expect("world");
    let mut out = Vec::new();
    while !w.is_finished() {
        w.advance_frame().expect("step");
        let o = &w.objects()[0];
        out.push((
            w.time_s(),
            o.velocity_m_s[0],
            o.angular_velocity_rad_s[1] * f64::from(R_M),
        ));
    }
    out
}
