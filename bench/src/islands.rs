//! `splatphys bench islands`: what stepping islands apart saves, and what it changes.
//!
//! Runs a scene with `[simulation] islands` on and off, alternating, `--repeat` times each, and
//! reports per object the substeps it took and their range, its particle-substeps, and how far
//! its COM and its particles went from the run stepped as one (largest over the frames, and the
//! COM at the end), and per
//! setting the wall time of the stepping (building the world excluded). An object alone in its
//! island steps exactly as it would alone in the scene; one that took a longer substep than the
//! stiffest object's differs from the run stepped as one by MPM's own dependence on dt.
//!
//! JSON lines on stdout; `islands.csv` in `--out-dir`.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use glam::DVec3;
use serde_json::{Value, json};
use splatphys_core::scene::Scene;
use splatphys_core::world::World;

use crate::{chart, thread_pool};

/// Arguments of `bench islands`.
#[derive(Args, Debug)]
pub struct IslandsBenchArgs {
    /// The scene: objects of different stiffness out of each other's reach.
    #[arg(long, default_value = "scenes/stiff_and_soft.toml")]
    pub scene: PathBuf,
    /// Simulated time per run (s); default: the scene's duration.
    #[arg(long)]
    pub duration_s: Option<f64>,
    /// Runs of each setting, alternating (wall times are reported as a range).
    #[arg(long, default_value_t = 2)]
    pub repeat: usize,
    /// Worker threads.
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Where `islands.csv` goes.
    #[arg(long, default_value = "docs/results/bench")]
    pub out_dir: PathBuf,
}

/// CSV columns, in order.
const COLUMNS: [&str; 13] = [
    "islands",
    "object",
    "youngs_modulus_pa",
    "particles",
    "substeps",
    "dt_min_s",
    "dt_max_s",
    "particle_substeps",
    "com_off_max_m",
    "com_off_final_m",
    "particle_off_max_m",
    "wall_min_s",
    "wall_max_s",
];

/// One run: the world at its end, the stepping's wall time (s), and per frame every object's
/// COM and particle positions (m).
struct Run {
    world: World,
    wall_s: f64,
    frames: Vec<Vec<(DVec3, Vec<glam::Vec3A>)>>,
}

fn run_once(scene: &Scene) -> Result<Run> {
    let mut world = World::from_scene(scene)?;
    let mut frames = Vec::new();
    let mut wall_s = 0.0;
    while !world.is_finished() {
        let t = Instant::now();
        world.advance_frame()?;
        wall_s += t.elapsed().as_secs_f64();
        frames.push(
            world
                .objects()
                .iter()
                .zip(world.bodies())
                .map(|(o, b)| (DVec3::from(o.com_m), b.particle_positions()))
                .collect(),
        );
    }
    Ok(Run {
        world,
        wall_s,
        frames,
    })
}

/// Largest distance over the frames between object `k`'s COM in `a` and in `b`, and between
/// its particles, and the distance between its COMs at the last frame (m).
fn offsets(a: &Run, b: &Run, k: usize) -> (f64, f64, f64) {
    let mut com = 0.0f64;
    let mut particle = 0.0f64;
    for (fa, fb) in a.frames.iter().zip(&b.frames) {
        com = com.max(fa[k].0.distance(fb[k].0));
        for (x, y) in fa[k].1.iter().zip(&fb[k].1) {
            particle = particle.max(f64::from(x.distance(*y)));
        }
    }
    let last = match (a.frames.last(), b.frames.last()) {
        (Some(fa), Some(fb)) => fa[k].0.distance(fb[k].0),
        _ => 0.0,
    };
    (com, particle, last)
}

/// Runs `bench islands`.
///
/// # Errors
/// An unreadable scene, `--repeat 0`, a failed run, an unwritable output folder.
pub fn run(a: &IslandsBenchArgs) -> Result<()> {
    if a.repeat == 0 {
        bail!("--repeat must be at least 1");
    }
    let mut scene: Scene = splatphys_core::scene::load_scene(&a.scene)
        .with_context(|| format!("loading {}", a.scene.display()))?;
    if let Some(d) = a.duration_s {
        scene.simulation.duration_s = d;
    }
    let pool = thread_pool(a.threads)?;
    let mut runs: [Vec<Run>; 2] = [Vec::new(), Vec::new()];
    for r in 0..a.repeat {
        for (i, islands) in [true, false].into_iter().enumerate() {
            let mut s = scene.clone();
            s.simulation.islands = islands;
            eprintln!(
                "run {}/{}, islands {}: {} s simulated",
                r + 1,
                a.repeat,
                if islands { "on" } else { "off" },
                s.simulation.duration_s
            );
            runs[i].push(pool.install(|| run_once(&s))?);
        }
    }
    let whole = &runs[1][0];
    let mut rows: Vec<Value> = Vec::new();
    for (i, islands) in [true, false].into_iter().enumerate() {
        let walls: Vec<f64> = runs[i].iter().map(|r| r.wall_s).collect();
        let wall_min = walls.iter().copied().fold(f64::INFINITY, f64::min);
        let wall_max = walls.iter().copied().fold(0.0, f64::max);
        let w = &runs[i][0].world;
        for (k, b) in w.bodies().iter().enumerate() {
            let (com_off, particle_off, com_final) = offsets(&runs[i][0], whole, k);
            let row = json!({
                "bench": "islands",
                "islands": islands,
                "object": b.name(),
                "youngs_modulus_pa": scene.objects[k].material.youngs_modulus_pa,
                "particles": b.particles().len(),
                "substeps": b.stats().substeps_taken,
                "dt_min_s": if b.stats().substeps_taken > 0 { b.stats().dt_range_s[0] } else { 0.0 },
                "dt_max_s": b.stats().dt_range_s[1],
                "particle_substeps": (b.stats().substeps_taken - b.stats().substeps_skipped) * b.particles().len() as u64,
                "com_off_max_m": com_off,
                "com_off_final_m": com_final,
                "particle_off_max_m": particle_off,
                "wall_min_s": wall_min,
                "wall_max_s": wall_max,
                "island_escapes": w.stats().island_escapes,
            });
            println!("{row}");
            rows.push(row);
        }
    }
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("creating {}", a.out_dir.display()))?;
    chart::write_columns_csv(&a.out_dir.join("islands.csv"), &COLUMNS, &rows)?;
    Ok(())
}
