//! `World::explain`: per object, what was modelled and which material sets the substep.

use splatphys_core::material::{MaterialModel, MaterialSpec};
use splatphys_core::scene::{Method, ObjectKind, Scene, SceneObject};
use splatphys_core::world::World;

fn scene() -> Scene {
    let stiff = MaterialSpec::jelly(1e9, 0.3, 1000.0);
    Scene::builder()
        .method(Method::Com)
        .duration_s(0.02)
        .frame_rate_hz(100.0)
        .grid_dx_m(0.01)
        .cfl(0.4)
        .object(
            SceneObject::sphere("soft", [0.0, 0.0, 0.3], 0.04)
                .spacing_m(0.005)
                .material(MaterialSpec::jelly(2e4, 0.3, 1000.0)),
        )
        .object(
            SceneObject::sphere("stiff", [0.5, 0.0, 0.3], 0.04)
                .spacing_m(0.005)
                .material(MaterialSpec::new(MaterialModel::Snow, 1.4e5, 0.2, 400.0)),
        )
        .object(
            SceneObject::cuboid("block", [-0.5, -0.05, 0.0], [-0.4, 0.05, 0.1])
                .kind(ObjectKind::Rigid)
                .spacing_m(0.01)
                .material(stiff.clone()),
        )
        .object(
            SceneObject::cuboid("shelf", [0.3, 0.3, 0.0], [0.4, 0.4, 0.1])
                .kind(ObjectKind::Static)
                .spacing_m(0.01)
                .material(stiff),
        )
        .build()
        .unwrap()
}

#[test]
fn explanation_names_what_was_modelled_and_what_sets_dt() {
    let scene = scene();
    let mut w = World::from_scene(&scene).unwrap();
    while !w.is_finished() {
        w.advance_frame().unwrap();
    }
    let e = w.explain();
    println!("{}", e.to_table());
    assert_eq!(e.method, "com");
    assert_eq!(e.time_step, "cfl 0.4");
    assert_eq!(e.objects.len(), 4);
    let [soft, stiff, block, shelf] = [0, 1, 2, 3].map(|i| &e.objects[i]);
    assert_eq!(
        (soft.kind.as_str(), block.kind.as_str(), shelf.kind.as_str()),
        ("deformable", "rigid", "static")
    );
    assert_eq!(soft.particles_simulated, soft.gaussians_carried);
    assert!(soft.particles_simulated > 100);
    assert_eq!(
        (block.particles_simulated, shelf.particles_simulated),
        (0, 0)
    );
    assert!(block.gaussians_carried > 0 && shelf.gaussians_carried > 0);
    // Every object is out of every other's reach: each moving one steps in its own island,
    // the snowball at the substep of its much higher wave speed, the rigid block at the longest
    // substep; the static shelf steps in none.
    assert_eq!(shelf.substeps, 0);
    assert_eq!(block.substeps_slept, block.substeps);
    assert_eq!(soft.substeps_computed, soft.substeps);
    assert!(soft.substeps * 2 < stiff.substeps, "{soft:?} {stiff:?}");
    assert_eq!(e.substeps, soft.substeps + stiff.substeps + block.substeps);
    assert!(soft.dt_range_s[0] > stiff.dt_range_s[1]);
    assert_eq!((soft.dx_m, stiff.dx_m), (0.01, 0.01));
    assert!(soft.grid_blocks > 0 && block.grid_blocks == 0);
    // Each object's own MPM time is recorded; objects without MPM take none.
    assert!(soft.mpm_wall_s > 0.0 && stiff.mpm_wall_s > 0.0);
    assert_eq!((block.mpm_wall_s, shelf.mpm_wall_s), (0.0, 0.0));

    // c_p = sqrt((λ + 2μ) / ρ); snow's bound uses its moduli hardened as at its hardest
    // particle (plus a margin for the coming substep), so a falling snowball's is at least the
    // unhardened value and far above the soft jelly's.
    let cp = |e: f32, nu: f32, rho: f32| {
        let mu = e / (2.0 * (1.0 + nu));
        let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        ((lambda + 2.0 * mu) / rho).sqrt()
    };
    let soft_cp = soft.wave_speed_m_s.unwrap();
    assert!((soft_cp - cp(2e4, 0.3, 1000.0)).abs() < 1e-3 * soft_cp);
    assert!(stiff.wave_speed_m_s.unwrap() >= cp(1.4e5, 0.2, 400.0) * 0.999);
    let want = 0.4 * 0.01 / (soft_cp + soft.max_speed_m_s);
    assert!((soft.dt_limit_s.unwrap() - want).abs() < 1e-6 * want);
    assert_eq!(e.limited_by.as_deref(), Some("stiff (snow)"));
    assert!(block.dt_limit_s.is_none());
    // No substep of a deformable object exceeded its material's limit at rest, C dx / c_p.
    for o in [soft, stiff] {
        let rest_limit = 0.4 * 0.01 / o.wave_speed_m_s.unwrap();
        assert!(o.dt_range_s[1] <= f64::from(rest_limit) * 1.0001, "{o:?}");
    }
    assert!(e.to_table().contains("dt set by stiff (snow)"));
}
