//! A scene run in this process, frame by frame, and traced for comparison with another run of
//! it: the moving objects' centres of mass after every frame, their Gaussians at the end, and
//! the wall and CPU time of the frame loop. The level-of-detail calibration
//! ([`crate::calibration`]) and the benchmarks (`splatphys-bench realtime`, `subsets`) compare
//! runs with it.

use std::time::Instant;

use anyhow::{Context, Result};
use glam::{DVec3, Vec3A};
use indicatif::ProgressBar;
use splatphys_core::kinematics::GaussianState;
use splatphys_core::scene::{ObjectKind, Scene};
use splatphys_core::world::explain::Explanation;
use splatphys_core::world::{World, WorldError};

/// What one run of a scene leaves for a comparison with another run of it.
pub struct Trace {
    /// Frames simulated, a fraction when the run was stopped within a frame.
    pub frames_run: f64,
    /// `[frame][moving object]` COM (m), after each frame.
    pub com: Vec<Vec<DVec3>>,
    /// `[moving object]` COM (m) before the first frame.
    pub com0: Vec<DVec3>,
    /// Final published positions of the moving objects' Gaussians (m).
    pub gaussians: Vec<Vec3A>,
    /// Wall time of the frame loop (the world build not counted), s.
    pub wall_s: f64,
    /// CPU time of this process over the frame loop, all threads, s (`None` off Linux).
    pub cpu_s: Option<f64>,
    /// Wall time of the world build, s.
    pub build_s: f64,
    /// Physics particles of the moving objects.
    pub particles: usize,
    /// Substeps simulated.
    pub substeps: u64,
    /// `--explain`'s report at the end of the run.
    pub explain: Explanation,
    /// `[object]` wall seconds of each object's own MPM over the whole frames run (in the order
    /// of `explain.objects`); empty when the run was stopped within its first frame. A run
    /// stopped within a frame has stepped some islands of that frame and not others, so only
    /// whole frames count.
    pub object_mpm_s_whole_frames: Vec<f64>,
}

/// Indices of the objects that move (not static).
pub fn moving(scene: &Scene) -> Vec<usize> {
    (0..scene.objects.len())
        .filter(|&k| scene.objects[k].kind != ObjectKind::Static)
        .collect()
}

/// Runs `scene` to its end, frame by frame, on the calling thread pool.
pub fn run_scene(scene: &Scene, pb: &ProgressBar) -> Result<Trace> {
    run_scene_within(scene, pb, f64::INFINITY)
}

/// [`run_scene`], stopped within a substep once the frame loop has taken `max_wall_s` (the world
/// build not counted); then [`Trace::frames_run`] is below the scene's frame count.
pub fn run_scene_within(scene: &Scene, pb: &ProgressBar, max_wall_s: f64) -> Result<Trace> {
    let t = Instant::now();
    let mut w = World::from_scene(scene).context("building the world")?;
    if let Some(gpu) = crate::device::connect(&mut w) {
        gpu.map_err(anyhow::Error::msg)
            .context("the scene asks for device \"gpu\"")?;
    }
    let build_s = t.elapsed().as_secs_f64();
    let ids = moving(scene);
    let o0 = w.objects();
    let com0 = ids.iter().map(|&k| DVec3::from(o0[k].com_m)).collect();
    let mut com = Vec::new();
    let mut wall_s = 0.0;
    let cpu0 = process_cpu_s();
    let started = Instant::now();
    let mut object_mpm_s_whole_frames = Vec::new();
    while !w.is_finished() {
        let t = Instant::now();
        let mut keep_going = || started.elapsed().as_secs_f64() < max_wall_s;
        match w.advance_frame_with(&mut keep_going) {
            Ok(_) => {}
            Err(WorldError::Interrupted { .. }) => {
                wall_s += t.elapsed().as_secs_f64();
                break;
            }
            Err(e) => return Err(e.into()),
        }
        wall_s += t.elapsed().as_secs_f64();
        let o = w.objects();
        com.push(ids.iter().map(|&k| DVec3::from(o[k].com_m)).collect());
        object_mpm_s_whole_frames.clear();
        object_mpm_s_whole_frames.extend(w.bodies().iter().map(|b| b.stats().mpm_wall_s));
        pb.inc(1);
    }
    // Whole loop (the per-frame COM measurement is a few 0.1 ms of it): /proc counts in 10 ms
    // ticks, which per-frame differences would add up.
    let cpu = cpu0.zip(process_cpu_s()).map(|(a, b)| b - a);
    let mut out = vec![GaussianState::default(); w.published_count()];
    w.write_gaussians(&mut out);
    // Published order: each object's visible Gaussians in object order, then the background.
    let mut gaussians = Vec::new();
    let mut at = 0;
    for b in w.bodies() {
        let n = b.visible().iter().filter(|v| **v).count();
        if b.kind() != ObjectKind::Static {
            gaussians.extend(out[at..at + n].iter().map(|s| Vec3A::from(s.position_m)));
        }
        at += n;
    }
    Ok(Trace {
        frames_run: w.time_s() / w.frame_dt_s(),
        com,
        com0,
        gaussians,
        wall_s,
        cpu_s: cpu,
        build_s,
        particles: ids.iter().map(|&k| w.bodies()[k].particles().len()).sum(),
        substeps: w.stats().substeps,
        explain: w.explain(),
        object_mpm_s_whole_frames,
    })
}

/// CPU time of this process so far, user + system over all threads (s); `None` off Linux.
/// /proc reports clock ticks, 100 per second on every Linux this runs on (`getconf CLK_TCK`).
pub fn process_cpu_s() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = f.get(11)?.parse::<u64>().ok()? + f.get(12)?.parse::<u64>().ok()?;
    Some(ticks as f64 / 100.0)
}

/// Largest distance (m) between matching points of two `[frame][object]` tracks.
pub fn max_distance(a: &[Vec<DVec3>], b: &[Vec<DVec3>]) -> f64 {
    a.iter()
        .zip(b)
        .flat_map(|(p, q)| p.iter().zip(q).map(|(x, y)| (*x - *y).length()))
        .fold(0.0, f64::max)
}

/// Mean, 95th percentile and largest distance between `t`'s and `reference`'s final Gaussian
/// positions, in cells of side `cell_m`.
pub fn gaussian_errors_cells(t: &Trace, reference: &Trace, cell_m: f64) -> (f64, f64, f64) {
    let mut errors: Vec<f64> = t
        .gaussians
        .iter()
        .zip(&reference.gaussians)
        .map(|(p, q)| (*p - *q).length() as f64 / cell_m)
        .collect();
    let mean = errors.iter().sum::<f64>() / errors.len().max(1) as f64;
    let p95 = percentile(&mut errors, 0.95);
    let max = errors.last().copied().unwrap_or(0.0);
    (mean, p95, max)
}

/// Nearest-rank percentile `q` in 0..=1 of `v` (sorted in place); 0 when empty.
pub fn percentile(v: &mut [f64], q: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_unstable_by(f64::total_cmp);
    let i = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1;
    v[i]
}
