//! `splatphys bench sag`: the static sag of a deformable object resting under gravity, at
//! several grid cell sizes dx and physics-particle spacings h, against the first (finest) level.
//!
//! Each level runs the scene with `grid_dx_m = dx` and every moving object's `physics_spacing_m =
//! h` (none: every Gaussian and fill point a particle), then averages over the last `--window-s`
//! of the run, along gravity, for the first deformable object:
//! - **sag**: the drop of (COM height − lowest particle height) from the undeformed start. It
//!   does not see where the grid boundary lets the object rest (about half a cell above a
//!   collider, growing with dx), only how far the object deforms;
//! - **height loss**: the drop of (highest − lowest particle height);
//! - the COM's swing (max − min) over the window, to tell a settled run from one still moving.
//!
//! Every object's interior points (a capture's fill, a procedural shape's lattice) are placed at
//! `--point-spacing-m` (2.5 mm by default), so that every level subsets the same particles and
//! the first (dx 5 mm) has two per cell per axis.
//!
//! JSON lines on stdout; `sag.csv` in `--out-dir`.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use glam::DVec3;
use serde_json::{Value, json};
use splatphys_core::scene::{ObjectKind, Scene};
use splatphys_core::world::World;

use crate::{chart, thread_pool};
use splatphys::trace::moving;

/// Arguments of `bench sag`.
#[derive(Args, Debug)]
pub struct SagBenchArgs {
    /// The scene: a deformable object settling on a support.
    #[arg(long, default_value = "scenes/donut_rest.toml")]
    pub scene: PathBuf,
    /// Levels as dx or dx:h in metres (h: physics spacing; none: every point a particle). The
    /// first is the reference. Keep two particles per cell per axis (h = dx/2): with one per
    /// cell MPM under-integrates the stress, and a jelly cube sags half again as much as its
    /// closed form (`scenes/validation_cube_sag.toml`).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "0.005:0.0025,0.01:0.005,0.02:0.01,0.04:0.02,0.08:0.04"
    )]
    pub levels: Vec<String>,
    /// Kelvin–Voigt damping viscosity (Pa·s) of every deformable object while it settles: it
    /// leaves the static sag as it is and damps the vibration about it (dynamic relaxation).
    /// 0: the scene's own.
    #[arg(long, default_value_t = 0.0)]
    pub damping_viscosity_pa_s: f64,
    /// Override the scene's Young's modulus of every deformable object (Pa).
    #[arg(long)]
    pub youngs_modulus_pa: Option<f64>,
    /// Spacing (m) of every object's interior points for all levels (a capture's interior fill,
    /// a procedural shape's lattice): fine enough that the first level has two particles per
    /// cell per axis. 0: the scene's own.
    #[arg(long, default_value_t = 0.0025)]
    pub point_spacing_m: f64,
    /// Simulated time per level (s); default: the scene's duration.
    #[arg(long)]
    pub duration_s: Option<f64>,
    /// The averaging window at the end of each run (s): several periods of the object's
    /// undamped vibration on its support.
    #[arg(long, default_value_t = 1.0)]
    pub window_s: f64,
    /// Worker threads.
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Where `sag.csv` goes.
    #[arg(long, default_value = "docs/results/bench")]
    pub out_dir: PathBuf,
}

/// CSV columns, in order.
const COLUMNS: [&str; 10] = [
    "dx_m",
    "spacing_m",
    "particles",
    "mass_kg",
    "sag_m",
    "sag_vs_first",
    "height_loss_m",
    "com_swing_m",
    "substeps",
    "wall_s",
];

/// One level: grid cell (m) and physics spacing (m, `None`: every point a particle).
fn parse_level(s: &str) -> Result<(f64, Option<f64>)> {
    let bad = || format!("--levels: {s:?} is not dx or dx:h with positive metres");
    let mut parts = s.split(':');
    let dx: f64 = parts
        .next()
        .unwrap_or("")
        .trim()
        .parse()
        .with_context(bad)?;
    let h: Option<f64> = parts
        .next()
        .map(|h| h.trim().parse())
        .transpose()
        .with_context(bad)?;
    let positive = |v: f64| v.is_finite() && v > 0.0;
    if parts.next().is_some() || !positive(dx) || h.is_some_and(|h| !positive(h)) {
        bail!(bad());
    }
    Ok((dx, h))
}

/// The scene at `path`, every object's interior fill and every procedural shape's lattice at
/// spacing `spacing_m` (m; 0 keeps the scene's).
fn load_with_points(path: &Path, spacing_m: f64) -> Result<Scene> {
    let context = || format!("loading {}", path.display());
    if !(spacing_m.is_finite() && spacing_m >= 0.0) {
        bail!("--point-spacing-m must be a length >= 0 (m), not {spacing_m}");
    }
    let text = std::fs::read_to_string(path).with_context(context)?;
    let mut parsed = splatphys_core::scene::parse_scene_toml(path, &text).with_context(context)?;
    if spacing_m > 0.0 {
        for o in &mut parsed.object {
            if let Some(fill) = o.fill.as_mut() {
                fill.spacing_m = spacing_m as f32;
            }
            if o.shape.is_some() {
                o.spacing_m = Some(spacing_m as f32);
            }
        }
    }
    let base = path.parent().unwrap_or(Path::new("."));
    splatphys_core::scene::build_scene(path, base, &parsed).with_context(context)
}

/// (COM height − lowest, highest − lowest, COM height) of an object along gravity (m).
type Heights = (f64, f64, f64);

/// [`Heights`] along `up` of body `k`'s particles.
fn heights(w: &World, k: usize, up: DVec3) -> Heights {
    let p = w.bodies()[k].particles();
    let (mut m, mut mh, mut lo, mut hi) = (0.0f64, 0.0f64, f64::MAX, f64::MIN);
    for (x, &mi) in p.x.iter().zip(&p.mass_kg) {
        let h = x.as_dvec3().dot(up);
        m += mi as f64;
        mh += mi as f64 * h;
        lo = lo.min(h);
        hi = hi.max(h);
    }
    let com = mh / m.max(f64::MIN_POSITIVE);
    (com - lo, hi - lo, com)
}

/// Runs `bench sag`.
///
/// # Errors
/// A bad level, an unreadable scene or one without a deformable object, a failed run, an
/// unwritable output folder.
pub fn run(a: &SagBenchArgs) -> Result<()> {
    let levels = a
        .levels
        .iter()
        .map(|s| parse_level(s))
        .collect::<Result<Vec<_>>>()?;
    if levels.is_empty() {
        bail!("--levels is empty");
    }
    if !(a.damping_viscosity_pa_s.is_finite() && a.damping_viscosity_pa_s >= 0.0) {
        bail!(
            "--damping-viscosity-pa-s must be a viscosity >= 0 (Pa·s), not {}",
            a.damping_viscosity_pa_s
        );
    }
    let mut scene = load_with_points(&a.scene, a.point_spacing_m)?;
    let Some(k) = scene
        .objects
        .iter()
        .position(|o| o.kind == ObjectKind::Deformable)
    else {
        bail!("{} has no deformable object", a.scene.display());
    };
    if let Some(d) = a.duration_s {
        scene.simulation.duration_s = d;
    }
    for o in &mut scene.objects {
        if o.kind == ObjectKind::Deformable {
            if let Some(e) = a.youngs_modulus_pa {
                o.material.youngs_modulus_pa = e;
            }
            if a.damping_viscosity_pa_s > 0.0 {
                o.material.damping_viscosity_pa_s = Some(a.damping_viscosity_pa_s);
            }
        }
    }
    scene.simulation.sleep = false;
    let g = DVec3::from(scene.simulation.gravity_m_s2.map(f64::from));
    if g.length() == 0.0 {
        bail!("{}: the sag needs gravity", a.scene.display());
    }
    let up = -g.normalize();
    let duration = scene.simulation.duration_s;
    let pool = thread_pool(a.threads)?;
    let mut rows: Vec<Value> = Vec::new();
    for (dx, h) in levels {
        let mut s = scene.clone();
        s.simulation.grid_dx_m = dx;
        for m in moving(&s) {
            s.objects[m].physics_spacing_m = h.map(|h| h as f32);
            s.objects[m].grid_dx_m = Some(dx);
        }
        eprintln!(
            "dx {:.1} mm, spacing {}: running {duration} s",
            dx * 1e3,
            h.map_or("every point".to_string(), |h| format!("{:.1} mm", h * 1e3))
        );
        let t = Instant::now();
        let (w, window) = pool.install(|| -> Result<(World, Vec<Heights>)> {
            let mut w = World::from_scene(&s)?;
            let mut window = vec![heights(&w, k, up)];
            while !w.is_finished() {
                w.advance_frame()?;
                if w.time_s() > duration - a.window_s {
                    window.push(heights(&w, k, up));
                }
            }
            Ok((w, window))
        })?;
        let (start, settled) = window.split_first().context("no frames")?;
        if settled.is_empty() {
            bail!("--window-s {} holds no frame of the run", a.window_s);
        }
        let mean =
            |f: fn(&Heights) -> f64| settled.iter().map(f).sum::<f64>() / settled.len() as f64;
        let sag = start.0 - mean(|s| s.0);
        let loss = start.1 - mean(|s| s.1);
        let coms = settled.iter().map(|s| s.2);
        let swing = coms.clone().fold(f64::MIN, f64::max) - coms.fold(f64::MAX, f64::min);
        let first = rows
            .first()
            .and_then(|r| r["sag_m"].as_f64())
            .unwrap_or(sag);
        let p = w.bodies()[k].particles();
        let row = json!({
            "bench": "sag",
            "dx_m": dx,
            "spacing_m": h,
            "particles": p.len(),
            "mass_kg": p.mass_kg.iter().map(|&m| m as f64).sum::<f64>(),
            "sag_m": sag,
            "sag_vs_first": sag / first,
            "height_loss_m": loss,
            "com_swing_m": swing,
            "substeps": w.stats().substeps,
            "wall_s": t.elapsed().as_secs_f64(),
        });
        println!("{row}");
        rows.push(row);
    }
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("creating {}", a.out_dir.display()))?;
    chart::write_columns_csv(&a.out_dir.join("sag.csv"), &COLUMNS, &rows)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_parse_and_bad_ones_are_named() {
        assert_eq!(parse_level("0.01").unwrap(), (0.01, None));
        assert_eq!(parse_level("0.02:0.01").unwrap(), (0.02, Some(0.01)));
        for bad in ["", "x", "0.01:", "0:0.01", "0.01:-1", "0.01:0.005:1"] {
            let e = parse_level(bad).unwrap_err().to_string();
            assert!(e.contains("--levels"), "{bad:?}: {e}");
        }
    }
}
