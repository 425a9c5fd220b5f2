//! Plastic models carry their Gaussians with the total deformation (release build): a soft
//! metal cube thrown onto a floor squashes plastically, and each Gaussian's deformation maps
//! the rest offsets of its particle's neighbours onto where they are now, as the elastic part
//! alone does not.

use glam::{Mat3A, Vec3A};
use splatphys_core::material::MaterialSpec;
use splatphys_core::scene::{ColliderSpec, Scene, SceneObject, Surface};
use splatphys_core::world::World;

/// Mean over neighbour pairs (j, k) 1 cm apart at rest of |F_j (X_k − X_j) − (x_k − x_j)| /
/// |X_k − X_j|, with F_j = `deformation(j)`.
fn mapping_error(rest: &[Vec3A], now: &[Vec3A], deformation: impl Fn(usize) -> Mat3A) -> f64 {
    let (mut sum, mut n) = (0.0f64, 0usize);
    for j in 0..rest.len() {
        for k in 0..rest.len() {
            let d0 = rest[k] - rest[j];
            if k == j || (d0.length() - 0.01).abs() > 1e-4 {
                continue;
            }
            let d = now[k] - now[j];
            sum += ((deformation(j) * d0 - d).length() / d0.length()) as f64;
            n += 1;
        }
    }
    sum / n as f64
}

#[test]
fn a_squashed_metal_cube_carries_its_gaussians_with_the_plastic_flow() {
    let scene = Scene::builder()
        .grid_dx_m(0.01)
        .duration_s(0.3)
        .frame_rate_hz(20.0)
        .sleep(false)
        .collider(
            ColliderSpec::plane("floor", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
                .surface(Surface::Separate)
                .friction(0.0),
        )
        .object(
            SceneObject::cuboid("cube", [-0.03, -0.03, 0.005], [0.03, 0.03, 0.065])
                .spacing_m(0.01)
                .material(MaterialSpec {
                    yield_stress_pa: Some(2e4),
                    ..MaterialSpec::new(
                        splatphys_core::material::MaterialModel::Metal,
                        1e6,
                        0.3,
                        2000.0,
                    )
                })
                .velocity([0.0, 0.0, -4.0]),
        )
        .build()
        .expect("scene");
    let mut w = World::from_scene(&scene).expect("world");
    let rest = w.bodies()[0].particles().x.clone();
    while !w.is_finished() {
        w.advance_frame().expect("step");
    }
    let b = &w.bodies()[0];
    let p = b.particles();
    let height = |x: &[Vec3A]| {
        let (lo, hi) = x
            .iter()
            .fold((f32::MAX, f32::MIN), |(l, h), x| (l.min(x.z), h.max(x.z)));
        hi - lo
    };
    println!("height {:.4} m -> {:.4} m", height(&rest), height(&p.x));
    // It flowed: a good part of its height is gone for good.
    assert!(
        height(&p.x) < 0.8 * height(&rest),
        "the cube did not squash"
    );
    // Each Gaussian sits on one particle here (procedural objects): its deformation is F F_p.
    let gaussian_of: Vec<usize> = {
        let mut g = vec![usize::MAX; p.len()];
        for (gi, &j) in b.gaussian_particle().iter().enumerate() {
            g[j as usize] = gi;
        }
        g
    };
    let total = mapping_error(&rest, &p.x, |j| b.gaussian_pose(gaussian_of[j]).1);
    let elastic = mapping_error(&rest, &p.x, |j| p.f[j]);
    println!("neighbour offsets mapped with F F_p: {total:.3} error, with F alone {elastic:.3}");
    assert!(
        total < 0.2,
        "F F_p maps the neighbours with a {total:.3} error"
    );
    assert!(
        elastic > 2.0 * total,
        "F alone: {elastic:.3}, F F_p: {total:.3}"
    );
}
