//! Physics-particle subsets (`physics_spacing_m`, `world::carry`): without the key nothing
//! changes; the subset keeps the object's mass and centre of mass; affine and rigid motions carry
//! every Gaussian exactly; free fall matches the full-particle run; thread count changes no bit.

use std::path::{Path, PathBuf};

use glam::{Mat3A, Quat, Vec3, Vec3A};
use splatphys_core::kinematics::{GaussianState, gaussian_state, pack_symmetric};
use splatphys_core::material::MaterialSpec;
use splatphys_core::scene::{
    ColliderSpec, ObjectBuilder, ObjectKind, Scene, SceneBuilder, SceneError, SceneObject, Surface,
    load_scene,
};
use splatphys_core::world::{World, measure};

/// A jelly sphere "ball" (radius 5 cm, 5 mm lattice, ~4,200 Gaussians) centred at height `z_m`.
fn ball(z_m: f32) -> ObjectBuilder {
    SceneObject::sphere("ball", [0.0, 0.0, z_m], 0.05)
        .spacing_m(0.005)
        .material(MaterialSpec::jelly(1e5, 0.3, 1000.0))
}

/// `ball` alone at 60 frames per second on a 1 cm grid, optionally over a sticky floor at z = 0.
fn sphere_scene(ball: ObjectBuilder, floor: bool, duration_s: f64) -> SceneBuilder {
    let scene = Scene::builder()
        .duration_s(duration_s)
        .frame_rate_hz(60.0)
        .grid_dx_m(0.01)
        .object(ball);
    if floor {
        scene.collider(ColliderSpec::ground("floor").surface(Surface::Sticky))
    } else {
        scene
    }
}

fn world(scene: SceneBuilder) -> World {
    let scene = scene.build().expect("scene");
    World::from_scene(&scene).expect("world")
}

fn finish(w: &mut World) {
    while !w.is_finished() {
        w.advance_frame().expect("step");
    }
}

fn published(w: &World) -> Vec<GaussianState> {
    let mut out = vec![GaussianState::default(); w.published_count()];
    w.write_gaussians(&mut out);
    out
}

fn particle_bits(w: &World) -> Vec<u32> {
    w.bodies()
        .iter()
        .flat_map(|b| {
            let p = b.particles();
            p.x.iter()
                .chain(&p.v)
                .flat_map(|v| v.to_array())
                .chain(p.f.iter().chain(&p.c).flat_map(|m| m.to_cols_array()))
                .chain(p.mass_kg.iter().copied())
        })
        .map(f32::to_bits)
        .collect()
}

fn state_bits(s: &[GaussianState]) -> Vec<u32> {
    bytemuck::cast_slice::<GaussianState, u32>(s).to_vec()
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

#[test]
fn without_physics_spacing_every_gaussian_is_its_own_particle_bit_for_bit() {
    // The code path: no key, no carry, one particle per Gaussian at its centre, and every
    // published Gaussian is exactly its particle's state.
    let mut plain = world(sphere_scene(ball(0.08), true, 0.15));
    let b = &plain.bodies()[0];
    assert!(b.carry().is_none());
    assert_eq!(b.particles().len(), b.gaussians().len());
    for (&j, p) in b.gaussian_particle().iter().zip(&b.gaussians().positions) {
        assert_eq!(b.particles().x[j as usize].to_array(), *p);
    }
    // Particles are stored in block order, Gaussians in the scene's: the lattice's x-fastest
    // order is not block order, and frames still publish Gaussian g as the scene's g-th.
    assert!(
        b.gaussian_particle()
            .iter()
            .enumerate()
            .any(|(g, &j)| g != j as usize)
    );
    let at_rest: Vec<[f32; 3]> = published(&plain).iter().map(|o| o.position_m).collect();
    assert_eq!(at_rest, plain.bodies()[0].gaussians().positions);
    // A spacing of 0.1 mm puts each Gaussian of the 5 mm lattice in a cube of its own: the
    // subset construction (volume-weighted mean and summed volume) must give back the very
    // same particles, and the run must match bit for bit, through a landing on the floor.
    let mut tiny = world(sphere_scene(
        ball(0.08).physics_spacing_m(0.0001),
        true,
        0.15,
    ));
    assert!(tiny.bodies()[0].carry().is_none());
    assert_eq!(particle_bits(&plain), particle_bits(&tiny));
    finish(&mut plain);
    finish(&mut tiny);
    assert_eq!(particle_bits(&plain), particle_bits(&tiny));
    let out = published(&plain);
    assert_eq!(state_bits(&out), state_bits(&published(&tiny)));
    let b = &plain.bodies()[0];
    for (i, o) in out.iter().enumerate() {
        let j = b.gaussian_particle()[i] as usize;
        let want = gaussian_state(b.particles().x[j], b.particles().f[j], b.sigma0()[i]);
        assert_eq!(state_bits(&[*o]), state_bits(&[want]), "Gaussian {i}");
    }
}

/// Mass and COM of a subset against the full object, for each spacing: relative mass error
/// within 1e-6 (f32 masses, one rounding each, summed in f64: ~6e-8 at worst) and COM within
/// 1 µm (the means are f64, stored as f32 coordinates near 0.3 m: ~3e-8 m each).
fn check_mass_and_com(scene: &Scene, spacings: &[f32]) {
    let full = World::from_scene(scene).expect("world");
    let dx = full.dx_m();
    for &h in spacings {
        let mut s = scene.clone();
        s.objects
            .iter_mut()
            .for_each(|o| o.physics_spacing_m = Some(h));
        let sub = World::from_scene(&s).expect("world");
        for (a, b) in full.bodies().iter().zip(sub.bodies()) {
            assert!(b.carry().is_some(), "h = {h}: no subset built");
            assert!(b.particles().len() < a.particles().len());
            let (ma, mb) = (measure(a.particles(), dx), measure(b.particles(), dx));
            let rel = (mb.mass_kg - ma.mass_kg).abs() / ma.mass_kg;
            assert!(
                rel <= 1e-6,
                "h = {h}: mass {} vs {} ({rel:e})",
                mb.mass_kg,
                ma.mass_kg
            );
            let d = (mb.com_m - ma.com_m).length();
            assert!(d <= 1e-6, "h = {h}: COM moved by {d} m");
        }
    }
}

#[test]
fn subset_keeps_the_objects_mass_and_centre_of_mass() {
    let scene = sphere_scene(ball(0.3), false, 0.1).build().unwrap();
    check_mass_and_com(&scene, &[0.006, 0.01, 0.02, 0.05]);
    // The captured donut: a surface-only shell where cells hold different Gaussian counts.
    let path = repo().join("scenes/donut_drop.toml");
    if !repo().join("../shared/data/v3dg_donut.ply").exists() {
        println!("skipping the donut: ../shared/data not found");
        return;
    }
    let donut = load_scene(&path).unwrap();
    check_mass_and_com(&donut, &[0.005, 0.008, 0.016]);
}

/// Sets the particles of object 0 to x_j = A X_j⁰ + t, F_j = A and checks every published
/// Gaussian against x_g = A X_g + t and Σ_g = A Σ0_g Aᵀ.
fn check_affine(w: &mut World, a: Mat3A, t: Vec3A) {
    let b = w.body_mut(0).expect("object 0");
    let carry = b.carry().cloned().expect("a subset");
    let rest_g = carry.rest_gaussians.clone();
    for (j, x0) in carry.rest_particles.iter().enumerate() {
        b.particles_mut().x[j] = a * *x0 + t;
        b.particles_mut().f[j] = a;
    }
    let out = published(w);
    let b = &w.bodies()[0];
    assert_eq!(out.len(), b.gaussians().len());
    let mut worst = (0.0f32, 0.0f32);
    for (g, o) in out.iter().enumerate() {
        let want = a * rest_g[g] + t;
        worst.0 = worst
            .0
            .max((Vec3A::from(o.position_m) - want).abs().max_element());
        let cov = pack_symmetric(a * b.sigma0()[g] * a.transpose());
        let scale = cov.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        for (c, e) in o.covariance_m2.iter().zip(cov) {
            worst.1 = worst.1.max((c - e).abs() / scale);
        }
    }
    // Positions near 1 m in f32 with 8 weights: rounding ~1e-7 m; 1e-5 m is 1 % of a cell.
    assert!(worst.0 <= 1e-5, "position off by {} m", worst.0);
    assert!(worst.1 <= 1e-5, "covariance off by {} (relative)", worst.1);
}

#[test]
fn affine_motion_of_the_particles_carries_every_gaussian_exactly() {
    let mut w = world(sphere_scene(ball(0.3).physics_spacing_m(0.02), false, 0.1));
    let b = &w.bodies()[0];
    // 2 cm cubes over a 5 mm lattice: about 1/64 as many particles as Gaussians (more at the
    // surface, where cubes are partly empty).
    assert!(
        b.particles().len() * 20 < b.gaussians().len(),
        "{}",
        b.particles().len()
    );
    // Rigid: rotation about a tilted axis plus a translation.
    let r = Mat3A::from_quat(Quat::from_axis_angle(
        Vec3::new(1.0, -2.0, 0.5).normalize(),
        1.1,
    ));
    check_affine(&mut w, r, Vec3A::new(0.3, -0.2, 0.7));
    // Any affine map: stretch and shear.
    let a = Mat3A::from_cols(
        Vec3A::new(1.2, 0.1, 0.0),
        Vec3A::new(-0.3, 0.9, 0.05),
        Vec3A::new(0.0, 0.2, 0.7),
    );
    check_affine(&mut w, a, Vec3A::new(-0.1, 0.0, 0.05));
}

#[test]
fn rigid_subset_object_carries_its_gaussians_with_the_rigid_pose() {
    let mut w = world(sphere_scene(
        ball(1.0).kind(ObjectKind::Rigid).physics_spacing_m(0.015),
        false,
        0.3,
    ));
    assert!(w.bodies()[0].carry().is_some());
    let com0 = w.bodies()[0].rigid().com_m.as_vec3a();
    let rest: Vec<Vec3A> = w.bodies()[0]
        .gaussians()
        .positions
        .iter()
        .map(|p| Vec3A::from(*p))
        .collect();
    // Spin it about an off-axis direction while it falls.
    w.apply_impulse(
        0,
        Vec3A::new(0.05, 0.0, 0.0),
        Some(com0 + Vec3A::new(0.0, 0.02, 0.03)),
    )
    .unwrap();
    finish(&mut w);
    let b = &w.bodies()[0];
    let q = b.rigid().orientation;
    assert!(q.angle_between(Quat::IDENTITY) > 0.1, "it did not turn");
    let r = Mat3A::from_quat(q);
    let com = b.rigid().com_m.as_vec3a();
    let out = published(&w);
    let worst = out
        .iter()
        .zip(&rest)
        .map(|(o, x0)| (Vec3A::from(o.position_m) - (com + r * (*x0 - com0))).length())
        .fold(0.0f32, f32::max);
    // Known answer x = c + R (X - c0); f32 rounding near z ~ 0.6 m.
    assert!(worst <= 1e-5, "off the rigid pose by {worst} m");
}

#[test]
fn free_fall_of_a_subset_matches_the_full_run() {
    let mut full = world(sphere_scene(ball(1.0), false, 0.4));
    // On the scene's grid, so that both take the same substeps.
    let sub_ball = ball(1.0).physics_spacing_m(0.01).grid_dx_m(0.01);
    let mut sub = world(sphere_scene(sub_ball, false, 0.4));
    let ratio =
        full.bodies()[0].particles().len() as f64 / sub.bodies()[0].particles().len() as f64;
    assert!(ratio > 4.0, "ratio {ratio}");
    let dx = full.dx_m();
    let (m_full, m_sub) = (
        measure(full.bodies()[0].particles(), dx).mass_kg,
        measure(sub.bodies()[0].particles(), dx).mass_kg,
    );
    assert!(
        (m_sub - m_full).abs() <= 1e-6 * m_full,
        "{m_sub} vs {m_full}"
    );
    let z0 = full.objects()[0].com_m[2];
    while !full.is_finished() {
        full.advance_frame().unwrap();
        sub.advance_frame().unwrap();
        let (a, b) = (full.objects()[0].com_m[2], sub.objects()[0].com_m[2]);
        // Same CFL substeps (the wave speed does not depend on particle count) and uniform
        // gravity: only rounding separates them; 1e-3 relative is the bound.
        assert!(
            (a - b).abs() <= 1e-3 * a.abs(),
            "frame {}: {b} vs {a}",
            full.frame()
        );
    }
    let t = full.time_s();
    let exact = z0 - 0.5 * 9.81 * t * t;
    let z = sub.objects()[0].com_m[2];
    // Symplectic Euler lags the closed form by g t dt / 2 (~0.7 mm here); allow twice that.
    let lag = 9.81 * t * sub.stats().dt_max_s;
    assert!((z - exact).abs() <= lag, "{z} vs {exact} (allowed {lag} m)");
    // The carried Gaussians fall with the particles: within a hundredth of a cell of the
    // full run's (uniform motion, F = I: the carry is exact).
    let (a, b) = (published(&full), published(&sub));
    let worst = a
        .iter()
        .zip(&b)
        .map(|(p, q)| (Vec3A::from(p.position_m) - Vec3A::from(q.position_m)).length())
        .fold(0.0f32, f32::max);
    assert!(worst <= 0.01 * dx, "Gaussians {worst} m apart");
}

#[test]
fn a_coarse_subset_gets_a_grid_of_two_spacings_and_still_falls_as_the_closed_form() {
    let dx_of = |b: ObjectBuilder| world(sphere_scene(b, false, 0.1)).bodies()[0].dx_m();
    // Two particles per cell per axis when that is coarser than the scene's 1 cm cell; never
    // finer than it by default; an explicit cell wins.
    assert_eq!(dx_of(ball(1.0).physics_spacing_m(0.02)), 0.04);
    assert_eq!(dx_of(ball(1.0).physics_spacing_m(0.004)), 0.01);
    assert_eq!(dx_of(ball(1.0)), 0.01);
    assert_eq!(
        dx_of(ball(1.0).physics_spacing_m(0.02).grid_dx_m(0.03)),
        0.03
    );
    // The baselines share one grid: the scene's.
    let shared = sphere_scene(ball(1.0).physics_spacing_m(0.02), false, 0.1)
        .method(splatphys_core::scene::Method::Mpm);
    assert_eq!(world(shared).bodies()[0].dx_m(), 0.01);

    let mut w = world(sphere_scene(ball(1.0).physics_spacing_m(0.02), false, 0.4));
    let m_full = measure(
        world(sphere_scene(ball(1.0), false, 0.1)).bodies()[0].particles(),
        0.01,
    );
    let s0 = measure(w.bodies()[0].particles(), w.bodies()[0].dx_m());
    assert!((s0.mass_kg - m_full.mass_kg).abs() <= 1e-6 * m_full.mass_kg);
    let z0 = s0.com_m.z;
    finish(&mut w);
    let t = w.time_s();
    let z = w.objects()[0].com_m[2];
    let exact = z0 - 0.5 * 9.81 * t * t;
    // Symplectic Euler lags the closed form by g t dt / 2 at its own, 4x longer, substep.
    let lag = 9.81 * t * w.bodies()[0].stats().dt_range_s[1];
    assert!((z - exact).abs() <= lag, "{z} vs {exact} (allowed {lag} m)");
    // The same subset on the scene's 1 cm grid takes about 4x the substeps (CFL: dx / c_p).
    let mut fine = world(sphere_scene(
        ball(1.0).physics_spacing_m(0.02).grid_dx_m(0.01),
        false,
        0.4,
    ));
    finish(&mut fine);
    let (coarse_n, fine_n) = (
        w.bodies()[0].stats().substeps_taken,
        fine.bodies()[0].stats().substeps_taken,
    );
    assert!(coarse_n * 5 < fine_n * 2, "{coarse_n} vs {fine_n} substeps");
}

#[test]
fn an_object_grid_under_a_shared_grid_method_is_refused_with_its_key_path() {
    let scene = sphere_scene(ball(1.0).grid_dx_m(0.02), false, 0.1)
        .method(splatphys_core::scene::Method::MultiField);
    match scene.build() {
        Err(SceneError::Invalid {
            key_path, message, ..
        }) => {
            assert_eq!(key_path, "object[0].grid_dx_m");
            assert!(message.contains("com"), "{message}");
        }
        other => panic!("expected an Invalid error, got {other:?}"),
    }
    let bad = sphere_scene(ball(1.0).grid_dx_m(-1.0), false, 0.1).build();
    assert!(
        matches!(bad, Err(SceneError::Invalid { ref key_path, .. }) if key_path == "object[0].grid_dx_m"),
        "{bad:?}"
    );
}

fn subset_run_bits(threads: usize) -> (Vec<u32>, Vec<u32>) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let mut w = world(sphere_scene(ball(0.08).physics_spacing_m(0.008), true, 0.2));
        finish(&mut w);
        (particle_bits(&w), state_bits(&published(&w)))
    })
}

#[test]
fn subset_world_is_bit_identical_for_1_and_2_threads() {
    let (p1, g1) = subset_run_bits(1);
    let (p2, g2) = subset_run_bits(2);
    assert_eq!(p1, p2, "particles");
    assert_eq!(g1, g2, "published Gaussians");
}

#[test]
fn physics_spacing_is_validated_with_its_key_path() {
    let bad = |scene: SceneBuilder, key: &str| match scene.build() {
        Err(SceneError::Invalid { key_path, .. }) => assert_eq!(key_path, key),
        other => panic!("{key}: expected an Invalid error, got {other:?}"),
    };
    bad(
        sphere_scene(ball(0.3).physics_spacing_m(-0.01), false, 0.1),
        "object[0].physics_spacing_m",
    );
    bad(
        sphere_scene(ball(0.3).physics_spacing_m(f32::NAN), false, 0.1),
        "object[0].physics_spacing_m",
    );
    bad(
        sphere_scene(
            ball(0.3).kind(ObjectKind::Static).physics_spacing_m(0.01),
            false,
            0.1,
        ),
        "object[0].physics_spacing_m",
    );
    bad(
        sphere_scene(ball(0.3), false, 0.1).physics_spacing_m(0.0),
        "simulation.physics_spacing_m",
    );
    // The simulation-level default reaches deformable objects, not static ones.
    let s = sphere_scene(ball(0.3), false, 0.1)
        .physics_spacing_m(0.02)
        .object(
            SceneObject::cuboid("slab", [-0.2, -0.2, 0.0], [0.2, 0.2, 0.02])
                .kind(ObjectKind::Static),
        )
        .build()
        .unwrap();
    assert_eq!(s.objects[0].physics_spacing_m, Some(0.02));
    assert_eq!(s.objects[1].physics_spacing_m, None);
    let w = World::from_scene(&s).unwrap();
    assert!(w.bodies()[0].carry().is_some() && w.bodies()[1].carry().is_none());
}

#[test]
fn becoming_rigid_keeps_the_carried_gaussians_where_they_are() {
    // Land a subset jelly ball so that it deforms, then make it rigid: the carried state becomes
    // the rest state (Σ0 ← F Σ0 Fᵀ, X ← x), so nothing published may jump.
    let mut w = world(sphere_scene(ball(0.08).physics_spacing_m(0.01), true, 0.15));
    finish(&mut w);
    let strain = w.bodies()[0]
        .particles()
        .f
        .iter()
        .flat_map(|f| (*f - Mat3A::IDENTITY).to_cols_array())
        .map(f32::abs)
        .fold(0.0f32, f32::max);
    assert!(strain > 1e-3, "the ball did not deform ({strain})");
    let before = published(&w);
    w.set_kind(0, ObjectKind::Rigid).unwrap();
    let after = published(&w);
    for (g, (a, b)) in before.iter().zip(&after).enumerate() {
        let d = (Vec3A::from(a.position_m) - Vec3A::from(b.position_m)).length();
        // f32 rounding of one more weighted sum near 5 cm: ~1e-8 m.
        assert!(d <= 1e-6, "Gaussian {g} moved {d} m");
        let scale = a.covariance_m2.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        for (x, y) in a.covariance_m2.iter().zip(&b.covariance_m2) {
            assert!((x - y).abs() <= 1e-4 * scale, "Gaussian {g}: Σ {x} → {y}");
        }
    }
}
