//! `splatphys bench sag`: the static sag of a deformable object resting under gravity, at
//! several grid cell sizes dx and physics-particle spacings h, against the first (finest) level.
//!
//! Each level runs the scene with `grid_dx_m = dx` and every moving object's `physics_spacing_m =
//! h` (none: every Gaussian and fill point a particle), then averages over the last `--window-s`
//! of the run, along gravity, for the first deformable object:
//! - **sag**: the drop of (COM height − lowest particle height) from the undeformed start. It
//!   does not see where the grid boundary lets the object rest (above a collider or in it by up
//!   to half a cell, depending on where its surface lies in a cell), only how far the object
//!   deforms;
//! - **height loss**: the drop of (highest − lowest particle height);
//! - the COM's swing (max − min) over the window, to tell a settled run from one still moving;
//! - **bottom**: the mean height of the object's lowest 2 % of particles (at least one) over the
//!   window, in the unshifted scene's frame: where it rests against its support.
//!
//! With `--shift-m`, every level runs again with the whole scene (sources, selections, procedural
//! shapes, colliders) moved along up by each shift, so that the support lies at another place in
//! the grid's cells; each shift compares its levels with its own first.
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
use splatphys_core::procedural::Shape;
use splatphys_core::scene::schema::{PlaneChoice, SceneFile};
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
    /// Shifts (m) of the whole scene along up (against gravity), comma-separated: each runs every
    /// level with the support at another place in the grid's cells. Shifts of a quarter, a half
    /// and three quarters of a level's cell show how its sag and rest depend on that place.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "0",
        allow_hyphen_values = true
    )]
    pub shift_m: Vec<f64>,
    /// Worker threads.
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Where `sag.csv` goes.
    #[arg(long, default_value = "docs/results/bench")]
    pub out_dir: PathBuf,
}

/// CSV columns, in order.
const COLUMNS: [&str; 12] = [
    "shift_m",
    "dx_m",
    "spacing_m",
    "particles",
    "mass_kg",
    "sag_m",
    "sag_vs_first",
    "height_loss_m",
    "com_swing_m",
    "bottom_m",
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
/// spacing `spacing_m` (m; 0 keeps the scene's), all of it moved by `shift_m` along up.
fn load_with_points(path: &Path, spacing_m: f64, shift_m: f64) -> Result<Scene> {
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
    if shift_m != 0.0 {
        shift(&mut parsed, shift_m as f32).with_context(context)?;
    }
    let base = path.parent().unwrap_or(Path::new("."));
    splatphys_core::scene::build_scene(path, base, &parsed).with_context(context)
}

/// Moves everything placed in `scene` by `by_m` along up (against its gravity).
///
/// # Errors
/// A scene without gravity, with events (their points are not moved), or with a collider plane
/// found automatically (it would not move with the shift's meaning).
fn shift(scene: &mut SceneFile, by_m: f32) -> Result<()> {
    let g = glam::Vec3::from(scene.simulation.gravity_m_s2);
    if !g.is_finite() || g.length_squared() == 0.0 {
        bail!("--shift-m needs gravity to say which way is up");
    }
    if !scene.event.is_empty() {
        bail!("--shift-m moves no event: the scene has [[event]] entries");
    }
    let d = -g.normalize() * by_m;
    let add = |p: &mut [f32; 3]| *p = (glam::Vec3::from(*p) + d).to_array();
    for s in &mut scene.source {
        add(&mut s.translation_m);
    }
    for o in &mut scene.object {
        if let Some(select) = o.select.as_mut() {
            if let Some(b) = select.box_m.as_mut() {
                b.iter_mut().for_each(add);
            }
            if let Some(sphere) = select.sphere.as_mut() {
                add(&mut sphere.center_m);
            }
        }
        match o.shape.as_mut() {
            Some(Shape::Sphere { center_m, .. }) => add(center_m),
            Some(Shape::Box { min_m, max_m }) => {
                add(min_m);
                add(max_m);
            }
            Some(Shape::Cylinder { base_m, .. }) => add(base_m),
            None => {}
        }
    }
    for c in &mut scene.collider {
        match c.plane.as_mut() {
            Some(PlaneChoice::Given(p)) => add(&mut p.point_m),
            Some(PlaneChoice::Keyword(k)) => {
                bail!(
                    "--shift-m: collider {:?} is plane = {k:?}; give its plane",
                    c.name
                )
            }
            None => {}
        }
        if let Some(b) = c.box_.as_mut() {
            add(&mut b.min_m);
            add(&mut b.max_m);
        }
    }
    Ok(())
}

/// (COM height − lowest, highest − lowest, COM height, the lowest 2 %'s mean height) of an
/// object along up (m).
type Heights = (f64, f64, f64, f64);

/// [`Heights`] along `up` of body `k`'s particles.
fn heights(w: &World, k: usize, up: DVec3) -> Heights {
    let p = w.bodies()[k].particles();
    let (mut m, mut mh, mut lo, mut hi) = (0.0f64, 0.0f64, f64::MAX, f64::MIN);
    let mut all = Vec::with_capacity(p.x.len());
    for (x, &mi) in p.x.iter().zip(&p.mass_kg) {
        let h = x.as_dvec3().dot(up);
        all.push(h);
        m += mi as f64;
        mh += mi as f64 * h;
        lo = lo.min(h);
        hi = hi.max(h);
    }
    let com = mh / m.max(f64::MIN_POSITIVE);
    let bottom = if all.is_empty() {
        lo
    } else {
        let n = (all.len() / 50).max(1);
        all.select_nth_unstable_by(n - 1, f64::total_cmp);
        all[..n].iter().sum::<f64>() / n as f64
    };
    (com - lo, hi - lo, com, bottom)
}

/// The scene of `a`, moved by `shift_m` along up, with the bench's overrides, and the index of
/// its first deformable object.
fn prepare(a: &SagBenchArgs, shift_m: f64) -> Result<(Scene, usize)> {
    let mut scene = load_with_points(&a.scene, a.point_spacing_m, shift_m)?;
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
    Ok((scene, k))
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
    if let Some(bad) = a.shift_m.iter().find(|d| !d.is_finite()) {
        bail!("--shift-m must be lengths (m), not {bad}");
    }
    let pool = thread_pool(a.threads)?;
    let mut rows: Vec<Value> = Vec::new();
    for &shift_m in &a.shift_m {
        let (scene, k) = prepare(a, shift_m)?;
        let duration = scene.simulation.duration_s;
        let up = -DVec3::from(scene.simulation.gravity_m_s2.map(f64::from)).normalize();
        let first_row = rows.len();
        for &(dx, h) in &levels {
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
                .get(first_row)
                .and_then(|r| r["sag_m"].as_f64())
                .unwrap_or(sag);
            let p = w.bodies()[k].particles();
            let row = json!({
                "bench": "sag",
                "shift_m": shift_m,
                "dx_m": dx,
                "spacing_m": h,
                "particles": p.len(),
                "mass_kg": p.mass_kg.iter().map(|&m| m as f64).sum::<f64>(),
                "sag_m": sag,
                "sag_vs_first": sag / first,
                "height_loss_m": loss,
                "com_swing_m": swing,
                "bottom_m": mean(|s| s.3) - shift_m,
                "substeps": w.stats().substeps,
                "wall_s": t.elapsed().as_secs_f64(),
            });
            println!("{row}");
            rows.push(row);
        }
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

    /// A scene file with one of everything `shift` moves, and gravity along `g`.
    fn placed(g: &str, extra: &str) -> SceneFile {
        let text = format!(
            r#"
[simulation]
gravity_m_s2 = {g}
[[source]]
name = "capture"
path = "capture.ply"
translation_m = [1.0, 2.0, 3.0]
[[object]]
name = "picked"
[object.select]
source = "capture"
box_m = [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]]
sphere = {{ center_m = [0.5, 0.5, 0.5], radius_m = 0.1 }}
[[object]]
name = "ball"
shape = {{ sphere = {{ center_m = [0.0, 0.0, 0.2], radius_m = 0.05 }} }}
[[object]]
name = "post"
[object.shape.cylinder]
base_m = [0.1, 0.0, 0.0]
axis = [0.0, 0.0, 1.0]
radius_m = 0.01
height_m = 0.1
[[collider]]
name = "table"
plane = {{ point_m = [0.0, 0.0, 0.1], normal = [0.0, 0.0, 1.0] }}
[[collider]]
name = "step"
box = {{ min_m = [0.0, 0.0, 0.0], max_m = [0.1, 0.1, 0.1] }}
{extra}
"#
        );
        splatphys_core::scene::parse_scene_toml(Path::new("t.toml"), &text).unwrap()
    }

    #[test]
    fn a_shift_moves_everything_placed_along_up_and_nothing_else() {
        let mut s = placed("[0.0, 0.0, -9.81]", "");
        shift(&mut s, 0.25).unwrap();
        assert_eq!(s.source[0].translation_m, [1.0, 2.0, 3.25]);
        let select = s.object[0].select.as_ref().unwrap();
        assert_eq!(select.box_m.unwrap(), [[0.0, 0.0, 0.25], [1.0, 1.0, 1.25]]);
        assert_eq!(select.sphere.unwrap().center_m, [0.5, 0.5, 0.75]);
        assert!(matches!(
            s.object[1].shape,
            Some(Shape::Sphere {
                center_m: [0.0, 0.0, 0.45],
                radius_m: 0.05
            })
        ));
        assert!(matches!(
            s.object[2].shape,
            Some(Shape::Cylinder {
                base_m: [0.1, 0.0, 0.25],
                axis: [0.0, 0.0, 1.0],
                ..
            })
        ));
        let Some(PlaneChoice::Given(plane)) = s.collider[0].plane else {
            panic!("the plane is given");
        };
        assert_eq!(
            (plane.point_m, plane.normal),
            ([0.0, 0.0, 0.35], [0.0, 0.0, 1.0])
        );
        let b = s.collider[1].box_.unwrap();
        assert_eq!((b.min_m, b.max_m), ([0.0, 0.0, 0.25], [0.1, 0.1, 0.35]));

        // Up is against gravity, whichever axis that is.
        let mut s = placed("[0.0, 9.81, 0.0]", "");
        shift(&mut s, 0.5).unwrap();
        assert_eq!(s.source[0].translation_m, [1.0, 1.5, 3.0]);
    }

    #[test]
    fn a_shift_refuses_what_it_cannot_move() {
        let no_gravity = shift(&mut placed("[0.0, 0.0, 0.0]", ""), 0.01).unwrap_err();
        assert!(no_gravity.to_string().contains("gravity"), "{no_gravity}");
        let events = r#"[[event]]
time_s = 0.1
command = "impulse"
object = "ball"
impulse_n_s = [0.0, 0.0, 1.0]"#;
        let e = shift(&mut placed("[0.0, 0.0, -9.81]", events), 0.01).unwrap_err();
        assert!(e.to_string().contains("event"), "{e}");
        let auto = "[[collider]]\nname = \"floor\"\nplane = \"auto\"";
        let e = shift(&mut placed("[0.0, 0.0, -9.81]", auto), 0.01).unwrap_err();
        assert!(e.to_string().contains("floor"), "{e}");
    }
}
