//! Builds a scene in code and steps it in-process, with no server and no files: a rigid box and a
//! jelly ball dropped on a static slab, the ball pushed sideways half-way through.
//!
//! ```text
//! cargo run --release -p splatphys-core --example step_scene
//! ```
//!
//! It prints every object's centre of mass and speed ten times a second, and how many Gaussians a
//! renderer would draw each frame (`World::write_gaussians` fills them).

use splatphys_core::prelude::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let scene = Scene::builder()
        .duration_s(1.0)
        .frame_rate_hz(30.0)
        .grid_dx_m(0.01)
        .object(
            SceneObject::cuboid("slab", [-0.3, -0.3, 0.0], [0.3, 0.3, 0.03])
                .kind(ObjectKind::Static)
                .friction(0.5),
        )
        .object(
            SceneObject::cuboid("box", [-0.15, -0.05, 0.1], [-0.05, 0.05, 0.2])
                .kind(ObjectKind::Rigid)
                .material(MaterialSpec::jelly(1e5, 0.3, 500.0))
                .friction(0.5),
        )
        .object(
            SceneObject::sphere("ball", [0.1, 0.0, 0.15], 0.04)
                .spacing_m(0.005)
                .material(MaterialSpec::jelly(2e5, 0.3, 1000.0))
                .friction(0.5),
        )
        .build()?;
    let mut world = World::from_scene(&scene)?;
    let ball = world.object_index("ball").ok_or("no ball")?;
    let mut gaussians = vec![GaussianState::default(); world.published_count()];
    while !world.is_finished() {
        if world.frame() == 15 {
            // 0.02 N s sideways at the ball's centre of mass.
            world.apply_impulse(ball, glam::Vec3A::new(0.02, 0.0, 0.0), None)?;
        }
        world.advance_frame()?;
        world.write_gaussians(&mut gaussians);
        if world.frame() % 3 == 0 {
            let rows: Vec<String> = world
                .objects()
                .iter()
                .map(|o| {
                    let [x, y, z] = o.com_m;
                    let speed = o.velocity_m_s.iter().map(|v| v * v).sum::<f64>().sqrt();
                    format!(
                        "{} at ({x:+.3}, {y:+.3}, {z:+.3}) m, {speed:.3} m/s",
                        o.name
                    )
                })
                .collect();
            println!("t = {:.2} s: {}", world.time_s(), rows.join("; "));
        }
    }
    println!(
        "{} frames, {} Gaussians each, {} live particles",
        world.frame(),
        gaussians.len(),
        world.particle_count()
    );
    Ok(())
}
