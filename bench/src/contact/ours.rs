//! The splatphys side of `bench contact`: a [`ContactScene`] through the scene builder into a
//! [`World`] (sleeping off: `[simulation] sleep = false`, so nothing at rest has its velocity
//! zeroed), stepped frame by frame with the substeps the world picks (CFL).

use std::time::Instant;

use anyhow::{Context, Result};
use glam::{DQuat, DVec3};
use splatphys_core::world::World;

use super::scenes::{ContactScene, ContactSettings};
use super::{EngineRun, FinalBody, MassProps, Progress};
use splatphys::trace::process_cpu_s;

/// Builds the world of `scene` for `duration_s` and the mass properties it gives each body (the
/// rapier side copies them).
///
/// # Errors
/// When the scene or the world cannot be built.
pub fn build(
    scene: &ContactScene,
    settings: &ContactSettings,
    duration_s: f64,
) -> Result<(World, Vec<MassProps>)> {
    let name = scene.kind.name();
    let s = scene
        .to_scene(settings, duration_s)
        .with_context(|| format!("building the {name} scene"))?;
    let world = World::from_scene(&s).with_context(|| format!("building the {name} world"))?;
    let mass = world
        .bodies()
        .iter()
        .map(|b| {
            let m = b.state();
            MassProps {
                mass_kg: m.mass_kg,
                com_m: m.com_m,
                inertia_kg_m2: m.inertia,
            }
        })
        .collect();
    Ok((world, mass))
}

/// Runs `world` to its end; wall time counts the frame steps only.
///
/// # Errors
/// When a substep fails.
pub fn run(world: &mut World, progress: &Progress<'_>) -> Result<EngineRun> {
    let mut wall_s = 0.0;
    let cpu0 = process_cpu_s();
    while !world.is_finished() {
        let t = Instant::now();
        world
            .advance_frame()
            .with_context(|| format!("splatphys world at t = {:.3} s", world.time_s()))?;
        wall_s += t.elapsed().as_secs_f64();
        progress.at(world.time_s());
    }
    let cpu_s = cpu0.zip(process_cpu_s()).map(|(a, b)| b - a);
    let bodies = world
        .objects()
        .iter()
        .map(|o| {
            let [w, x, y, z] = o.orientation_wxyz.map(f64::from);
            FinalBody {
                com_m: DVec3::from(o.com_m),
                orientation: DQuat::from_xyzw(x, y, z, w).normalize(),
                velocity_m_s: DVec3::from(o.velocity_m_s),
                omega_rad_s: DVec3::from(o.angular_velocity_rad_s),
                asleep: o.sleeping,
            }
        })
        .collect();
    let st = &world.stats();
    Ok(EngineRun {
        steps: st.substeps,
        simulated_s: world.time_s(),
        dt_range_s: [st.dt_min_s, st.dt_max_s],
        wall_s,
        cpu_s,
        particles: Some(world.particle_count()),
        bodies,
    })
}
