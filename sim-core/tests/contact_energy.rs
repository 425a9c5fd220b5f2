//! Deformable pairs at e = 1: the contact impulse, half of it delivered as a velocity kick to the
//! particles of the contact zone, adds no kinetic energy beyond what the restitution law allows
//! (the law at e = 1 keeps the pair's kinetic energy; MPM's own transfers only lose some).

use splatphys_core::material::MaterialSpec;
use splatphys_core::scene::{Scene, SceneObject};
use splatphys_core::world::World;

/// Kinetic energy ½ Σ m |v|² of every particle (J).
fn kinetic_energy(w: &World) -> f64 {
    w.bodies()
        .iter()
        .map(|b| {
            let p = b.particles();
            (0..p.len())
                .map(|i| 0.5 * p.mass_kg[i] as f64 * p.v[i].as_dvec3().length_squared())
                .sum::<f64>()
        })
        .sum()
}

#[test]
fn an_elastic_impact_gains_no_kinetic_energy_head_on_or_grazing() {
    // Offsets across the approach: head-on, half the sum of radii, and a graze whose contact
    // zone is a few particles (the case where a zone kick of J/2 over a small mass would add
    // most energy).
    for offset_y in [0.0f32, 0.04, 0.075] {
        for rho_left in [1000.0, 4000.0] {
            let sphere = |name: &str, c: [f32; 3], rho: f64, vx: f32| {
                SceneObject::sphere(name, c, 0.04)
                    .spacing_m(0.005)
                    .material(MaterialSpec::jelly(2e5, 0.3, rho))
                    .restitution(1.0)
                    .friction(0.0)
                    .velocity([vx, 0.0, 0.0])
            };
            let scene = Scene::builder()
                .duration_s(0.12)
                .grid_dx_m(0.01)
                .gravity_m_s2([0.0, 0.0, 0.0])
                .object(sphere("left", [-0.06, 0.0, 0.0], rho_left, 1.0))
                .object(sphere("right", [0.06, offset_y, 0.0], 1000.0, -1.0))
                .build()
                .unwrap();
            let mut w = World::from_scene(&scene).unwrap();
            let e0 = kinetic_energy(&w);
            // Every substep, so that a kick's energy is seen before MPM turns it into strain.
            let mut peak: f64 = 0.0;
            while w.time_s() < 0.12 {
                w.substep(0.01).unwrap();
                peak = peak.max(kinetic_energy(&w));
            }
            let end = kinetic_energy(&w);
            println!(
                "offset {offset_y} m, density ratio {}: peak KE {:.4} of the start, end {:.4}",
                rho_left / 1000.0,
                peak / e0,
                end / e0
            );
            assert!(
                w.stats().contact_impulses > 0,
                "offset {offset_y}: no contact"
            );
            // The bound: never more than 1 % above the start.
            assert!(peak <= 1.01 * e0, "offset {offset_y}: peak {}", peak / e0);
            // And the spheres did bounce elastically: most of the energy is kinetic again.
            assert!(end >= 0.9 * e0, "offset {offset_y}: end {}", end / e0);
        }
    }
}
