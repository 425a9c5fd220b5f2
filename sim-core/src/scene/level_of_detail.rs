//! Level of detail by budget: choose how coarsely each of a scene's deformable objects is
//! simulated so that the scene runs at a given number of simulated frames per wall second.
//!
//! The systems that make deformable Gaussian objects interactive simulate a coarse proxy and
//! carry the Gaussians along (VR-GS, Jiang et al. 2024; PhysTwin, Jiang et al. 2025). Here the
//! proxy is the object's physics-particle subset ([`SceneObject::physics_spacing_m`], carried by
//! `crate::world::carry`) on a coarser MPM grid of its own: a [`LevelOfDetail`] sets each
//! deformable object's grid cell and spacing (half a cell: two particles per cell per axis,
//! MLS-MPM's usual eight per cell).
//!
//! Every deformable object has its own ladder of cells ([`object_ladder`]): as written, then
//! [`DX_FACTORS`] × the scene's cell while [`MIN_CELLS_ACROSS`] cells still fit across its
//! thinnest extent. [`choose`] measures candidates through a [`CostModel`] (timed calibration
//! runs in `splatphys run`, a table in tests) in two phases:
//!
//! 1. Uniform steps: every object one rung further down its ladder at a time (an object at the
//!    bottom of its ladder stays there), from the scene as written, stopping at the first
//!    candidate that meets the budget. None does: the fastest, flagged.
//! 2. Per object (method `com`, where every deformable object has its own grid, with two or more
//!    of them): from that candidate, objects are refined one rung at a time while a model of the
//!    frame time predicts the budget still holds. The model is each object's own MPM time per
//!    frame at each rung, measured in phase 1, plus the rest of the frame (contacts, rigid
//!    bodies) as measured at the finest rung in use. The object refined next is the one with the
//!    fewest cells across its thinnest extent (between equals, the one whose refinement costs
//!    least), so a small object that costs little gets a fine grid, and of two equal objects the
//!    cheap one (a soft material, with longer substeps) is refined before the costly one. The
//!    result is measured once more; it is chosen only if that measurement meets the budget,
//!    else phase 1's candidate is.
//!
//! The cost is assumed to fall as a grid coarsens. What a level of detail never changes: rigid,
//! static and kinematic objects keep their particles and their collision surfaces (sampled
//! surfaces keep the written grid's cell through [`SimulationSettings::collision_dx_m`]). Under
//! the baselines (methods `mpm`, `multi-field`) every object shares one grid, so only phase 1
//! runs, and it coarsens that shared grid.

use serde::{Deserialize, Serialize};

use super::{Method, ObjectKind, Scene, SceneObject, SimulationSettings};

/// Candidate grid cells, as multiples of the scene's own `grid_dx_m`, finest first.
pub const DX_FACTORS: [f64; 7] = [1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0];

/// Grid cells a candidate keeps across a deformable object's thinnest extent (its axis-aligned
/// bounds): fewer and MPM no longer resolves the object's shape.
pub const MIN_CELLS_ACROSS: f64 = 3.0;

/// Physics-particle spacing of a coarsened deformable object, as a fraction of the grid cell.
pub const SPACING_PER_DX: f64 = 0.5;

/// How coarsely a scene's deformable objects are simulated: the scene's grid cell and each
/// deformable object's physics-particle spacing and grid cell. Serialised into `summary.json` so
/// that a run can be reproduced exactly (`splatphys run --spacing-from summary.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LevelOfDetail {
    /// The scene's MPM grid cell, m (under method `com` the cell of objects without their own).
    pub grid_dx_m: f64,
    /// Cell of collision surfaces sampled from points, m (the written scene's, so that solid
    /// objects keep their surfaces).
    pub collision_dx_m: f64,
    /// Every deformable object, in scene order.
    pub objects: Vec<ObjectSpacing>,
}

/// One deformable object's physics-particle spacing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObjectSpacing {
    /// The object's name in the scene.
    pub name: String,
    /// Physics-particle spacing, m; `None`: every Gaussian is a particle.
    pub physics_spacing_m: Option<f32>,
    /// Its own grid cell, m; `None`: from its spacing and the scene's grid
    /// ([`SceneObject::grid_dx_m`]).
    #[serde(default)]
    pub grid_dx_m: Option<f64>,
}

impl ObjectSpacing {
    /// Its MPM grid cell, m, in a level whose scene cell is `scene_dx_m` under method `com`
    /// (the rule of [`SceneObject::grid_dx_m`]).
    pub fn cell_m(&self, scene_dx_m: f64) -> f64 {
        match (self.grid_dx_m, self.physics_spacing_m) {
            (Some(dx), _) => dx,
            (None, Some(h)) => scene_dx_m.max(2.0 * f64::from(h)),
            (None, None) => scene_dx_m,
        }
    }
}

/// What a calibration run of one level of detail measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Measurement {
    /// Wall seconds per simulated frame.
    pub wall_s_per_frame: f64,
    /// Largest distance between a moving object's COM and the scene-as-written's, over the
    /// calibration frames, m; `None` when not measured.
    pub com_error_m: Option<f64>,
    /// 95th percentile of the distance between the moving Gaussians and the scene-as-written's at
    /// the end of the calibration, m; `None` when not measured.
    pub p95_error_m: Option<f64>,
    /// Wall seconds per simulated frame spent in each deformable object's own MPM substeps, in
    /// the order of [`LevelOfDetail::objects`]; empty when not measured (a per-object choice
    /// then never refines an object into this candidate's rung).
    #[serde(default)]
    pub object_wall_s_per_frame: Vec<f64>,
}

impl Measurement {
    /// Simulated frames per wall second.
    pub fn frames_per_wall_s(&self) -> f64 {
        1.0 / self.wall_s_per_frame.max(1e-12)
    }
}

/// Measures a level of detail of one scene (calibration runs, or a model in tests).
pub trait CostModel {
    /// Why a measurement failed.
    type Error;

    /// Cost and error of the scene at `level`; errors are against the scene as written.
    ///
    /// # Errors
    /// Whatever the measurement hits (a world that cannot be built, a failing step).
    fn measure(&mut self, level: &LevelOfDetail) -> Result<Measurement, Self::Error>;
}

/// The outcome of [`choose`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Choice {
    /// The frames per wall second asked for.
    pub budget_fps: f64,
    /// Whether the chosen level of detail met it in calibration.
    pub budget_met: bool,
    /// The chosen level of detail.
    pub chosen: LevelOfDetail,
    /// What it measured: its speed and the error it is expected to cost.
    pub expected: Measurement,
    /// Every candidate measured, in the order measured: the uniform steps finest first, then
    /// the per-object choice when one was tried.
    pub calibration: Vec<(LevelOfDetail, Measurement)>,
}

/// Why a level of detail cannot be applied to a scene.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LevelOfDetailError {
    /// A cell or spacing is not a positive number.
    #[error("level of detail: {what} = {value} must be a positive number")]
    NotPositive {
        /// Which value.
        what: String,
        /// The value.
        value: f64,
    },
    /// It names an object the scene does not have.
    #[error("level of detail: the scene has no object {name:?}")]
    UnknownObject {
        /// The name.
        name: String,
    },
    /// It names an object that is not deformable (a level of detail never changes those).
    #[error(
        "level of detail: object {name:?} is {kind:?}, not deformable: its spacing is not changed"
    )]
    NotDeformable {
        /// The name.
        name: String,
        /// Its kind in the scene.
        kind: ObjectKind,
    },
    /// A deformable object of the scene is missing from it.
    #[error("level of detail: deformable object {name:?} is not listed")]
    Missing {
        /// The name.
        name: String,
    },
}

fn deformable(o: &SceneObject) -> bool {
    o.kind == ObjectKind::Deformable
}

/// Whether every deformable object has a grid of its own (method `com`).
fn per_object(scene: &Scene) -> bool {
    scene.simulation.method == Method::Com
}

impl LevelOfDetail {
    /// The scene as written.
    pub fn as_written(scene: &Scene) -> Self {
        let s = &scene.simulation;
        Self {
            grid_dx_m: s.grid_dx_m,
            collision_dx_m: s.collision_cell_m(),
            objects: scene
                .objects
                .iter()
                .filter(|o| deformable(o))
                .map(|o| ObjectSpacing {
                    name: o.name.clone(),
                    physics_spacing_m: o.physics_spacing_m,
                    grid_dx_m: o.grid_dx_m,
                })
                .collect(),
        }
    }

    /// The scene with deformable object i (in [`Self::objects`] order) on cell `cells[i]` (m) at
    /// [`SPACING_PER_DX`] of it, or as written for `None`. Under the baselines the shared grid
    /// takes the coarsest cell given.
    fn with_cells(scene: &Scene, cells: &[Option<f64>]) -> Self {
        let mut level = Self::as_written(scene);
        let spacing = |dx: f64| Some((dx * SPACING_PER_DX) as f32);
        if per_object(scene) {
            for (o, cell) in level.objects.iter_mut().zip(cells) {
                if let Some(dx) = *cell {
                    o.physics_spacing_m = spacing(dx);
                    o.grid_dx_m = Some(dx);
                }
            }
        } else if let Some(dx) = cells.iter().flatten().copied().reduce(f64::max) {
            level.grid_dx_m = dx;
            for o in &mut level.objects {
                o.physics_spacing_m = spacing(dx);
                o.grid_dx_m = None;
            }
        }
        level
    }

    /// Whether it leaves `scene` as written.
    pub fn is_as_written(&self, scene: &Scene) -> bool {
        *self == Self::as_written(scene)
    }

    /// The coarsest grid cell of its deformable objects under method `com`, m (the scene's cell
    /// when it has none).
    pub fn coarsest_cell_m(&self) -> f64 {
        self.objects
            .iter()
            .map(|o| o.cell_m(self.grid_dx_m))
            .fold(self.grid_dx_m, f64::max)
    }

    /// Sets the scene's grid cell, collision cell and deformable objects' spacings.
    ///
    /// # Errors
    /// [`LevelOfDetailError`]: a value that is not positive, an object the scene lacks or that
    /// is not deformable, a deformable object not listed. Nothing is changed then.
    pub fn apply(&self, scene: &mut Scene) -> Result<(), LevelOfDetailError> {
        let positive = |what: &str, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(LevelOfDetailError::NotPositive {
                    what: what.to_owned(),
                    value,
                })
            }
        };
        positive("grid_dx_m", self.grid_dx_m)?;
        positive("collision_dx_m", self.collision_dx_m)?;
        let mut index = Vec::with_capacity(self.objects.len());
        for spacing in &self.objects {
            let Some(k) = scene.objects.iter().position(|o| o.name == spacing.name) else {
                return Err(LevelOfDetailError::UnknownObject {
                    name: spacing.name.clone(),
                });
            };
            let o = &scene.objects[k];
            if !deformable(o) {
                return Err(LevelOfDetailError::NotDeformable {
                    name: o.name.clone(),
                    kind: o.kind,
                });
            }
            if let Some(h) = spacing.physics_spacing_m {
                positive(&format!("{}.physics_spacing_m", o.name), f64::from(h))?;
            }
            if let Some(dx) = spacing.grid_dx_m {
                positive(&format!("{}.grid_dx_m", o.name), dx)?;
            }
            index.push(k);
        }
        if let Some(o) = scene
            .objects
            .iter()
            .enumerate()
            .find(|(k, o)| deformable(o) && !index.contains(k))
        {
            return Err(LevelOfDetailError::Missing {
                name: o.1.name.clone(),
            });
        }
        for (spacing, k) in self.objects.iter().zip(index) {
            scene.objects[k].physics_spacing_m = spacing.physics_spacing_m;
            scene.objects[k].grid_dx_m = spacing.grid_dx_m;
        }
        let s: &mut SimulationSettings = &mut scene.simulation;
        s.grid_dx_m = self.grid_dx_m;
        s.collision_dx_m = Some(self.collision_dx_m);
        Ok(())
    }
}

/// One deformable object's rungs: the grid cells it may be simulated on, finest first.
#[derive(Debug, Clone, PartialEq)]
pub struct Ladder {
    /// Its thinnest extent (axis-aligned bounds of its Gaussians), m.
    pub thinnest_m: f64,
    /// Rung 0 is the object as written (its written cell); then [`DX_FACTORS`] × the scene's
    /// cell, coarser than the written one, keeping [`MIN_CELLS_ACROSS`] cells across.
    pub cells_m: Vec<f64>,
}

impl Ladder {
    /// Cell of rung `r` as a level of detail gives it: `None` for the object as written.
    fn cell(&self, r: usize) -> Option<f64> {
        (r > 0).then(|| self.cells_m[r])
    }

    /// Cells across its thinnest extent at rung `r`.
    fn cells_across(&self, r: usize) -> f64 {
        self.thinnest_m / self.cells_m[r]
    }

    fn last(&self) -> usize {
        self.cells_m.len() - 1
    }
}

/// The ladder of deformable object `o` of `scene` (see [`Ladder`]).
pub fn object_ladder(scene: &Scene, o: &SceneObject) -> Ladder {
    let (lo, hi) = o.gaussians.positions.iter().fold(
        ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
        |(mut lo, mut hi), p| {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
            (lo, hi)
        },
    );
    let thinnest_m = (0..3)
        .map(|k| f64::from(hi[k] - lo[k]))
        .fold(f64::INFINITY, f64::min);
    let written = o.grid_dx_m(&scene.simulation);
    let mut cells_m = vec![written];
    if thinnest_m.is_finite() {
        let dx = scene.simulation.grid_dx_m;
        cells_m.extend(
            DX_FACTORS
                .iter()
                .map(|f| f * dx)
                .filter(|d| *d > written && d * MIN_CELLS_ACROSS <= thinnest_m),
        );
    }
    Ladder {
        thinnest_m,
        cells_m,
    }
}

/// The ladders of `scene`'s deformable objects, in scene order.
pub fn ladders(scene: &Scene) -> Vec<Ladder> {
    scene
        .objects
        .iter()
        .filter(|o| deformable(o))
        .map(|o| object_ladder(scene, o))
        .collect()
}

/// The level with deformable object i at rung `rungs[i]` of `ladders[i]`.
fn at_rungs(scene: &Scene, ladders: &[Ladder], rungs: &[usize]) -> LevelOfDetail {
    let cells: Vec<Option<f64>> = ladders.iter().zip(rungs).map(|(l, &r)| l.cell(r)).collect();
    LevelOfDetail::with_cells(scene, &cells)
}

/// Every object's rung at uniform step `k` (an object at the bottom of its ladder stays there).
fn uniform_rungs(ladders: &[Ladder], k: usize) -> Vec<usize> {
    ladders.iter().map(|l| k.min(l.last())).collect()
}

/// The uniform levels of detail worth measuring for `scene`, finest first: the scene as
/// written, then every deformable object one rung further down its ladder at a time. Under
/// the baselines (one shared grid) only while every object's ladder has that rung. Only the
/// scene as written when it has no deformable object.
pub fn candidates(scene: &Scene) -> Vec<LevelOfDetail> {
    let ladders = ladders(scene);
    let lengths = ladders.iter().map(|l| l.cells_m.len());
    let steps = if per_object(scene) {
        lengths.max()
    } else {
        lengths.min()
    };
    (0..steps.unwrap_or(1))
        .map(|k| at_rungs(scene, &ladders, &uniform_rungs(&ladders, k)))
        .collect()
}

/// Chooses a level of detail of `scene` that runs at `budget_fps` or faster by `model`, in the
/// two phases of the module docs; when no uniform candidate meets the budget, the fastest
/// measured, with `budget_met` false.
///
/// # Errors
/// The first error of `model`.
pub fn choose<M: CostModel>(
    scene: &Scene,
    budget_fps: f64,
    model: &mut M,
) -> Result<Choice, M::Error> {
    let meets = |m: &Measurement| m.frames_per_wall_s() >= budget_fps;
    let mut calibration: Vec<(LevelOfDetail, Measurement)> = Vec::new();
    for level in candidates(scene) {
        let m = model.measure(&level)?;
        let met = meets(&m);
        calibration.push((level, m));
        if met {
            break;
        }
    }
    // The last measured is the first that meets the budget, if any did; else the fastest.
    let mut best = calibration.len() - 1;
    if meets(&calibration[best].1) {
        let ladders = ladders(scene);
        let uniform: Vec<&Measurement> = calibration.iter().map(|(_, m)| m).collect();
        if per_object(scene)
            && let Some(rungs) = refine(&ladders, &uniform, 1.0 / budget_fps)
        {
            let level = at_rungs(scene, &ladders, &rungs);
            let m = model.measure(&level)?;
            let met = meets(&m);
            calibration.push((level, m));
            if met {
                best = calibration.len() - 1;
            }
        }
    } else {
        for (k, (_, m)) in calibration.iter().enumerate() {
            if m.frames_per_wall_s() > calibration[best].1.frames_per_wall_s() {
                best = k;
            }
        }
    }
    let (chosen, expected) = calibration[best].clone();
    Ok(Choice {
        budget_fps,
        budget_met: meets(&expected),
        chosen,
        expected,
        calibration,
    })
}

/// Phase 2 of [`choose`]: from the last of the `uniform` measurements (step k, which met the
/// budget), refines objects one rung at a time, fewest cells across first (between equals, the
/// cheaper refinement), while the predicted wall time per frame stays within `budget_s`. A step
/// without per-object times counts as too slow. `None` when there is nothing to refine (fewer
/// than two objects, k = 0, no per-object times at step k) or no refinement fits.
fn refine(ladders: &[Ladder], uniform: &[&Measurement], budget_s: f64) -> Option<Vec<usize>> {
    let k = uniform.len().checked_sub(1)?;
    let known = |m: &Measurement| m.object_wall_s_per_frame.len() == ladders.len();
    if ladders.len() < 2 || k == 0 || !known(uniform[k]) {
        return None;
    }
    // Object o at rung r costs what it cost at uniform step r (where it stood at rung r, or at
    // the bottom of its ladder, which r then is); the rest of the frame is taken from the
    // finest step in use.
    let object_s = |o: usize, r: usize| {
        if known(uniform[r]) {
            uniform[r].object_wall_s_per_frame[o]
        } else {
            f64::INFINITY
        }
    };
    let rest_s = |j: usize| {
        let m = uniform[j];
        if !known(m) {
            return f64::INFINITY;
        }
        (m.wall_s_per_frame - m.object_wall_s_per_frame.iter().sum::<f64>()).max(0.0)
    };
    let predicted_s = |rungs: &[usize]| {
        let finest = rungs.iter().copied().min().unwrap_or(0);
        rest_s(finest) + (0..rungs.len()).map(|o| object_s(o, rungs[o])).sum::<f64>()
    };
    let start = uniform_rungs(ladders, k);
    let mut rungs = start.clone();
    loop {
        let mut order: Vec<usize> = (0..ladders.len()).filter(|&o| rungs[o] > 0).collect();
        // Fewest cells across first; between equals, the cheaper refinement.
        let extra_s = |o: usize| object_s(o, rungs[o] - 1) - object_s(o, rungs[o]);
        order.sort_by(|&a, &b| {
            let across = |o: usize| ladders[o].cells_across(rungs[o]);
            across(a)
                .total_cmp(&across(b))
                .then(extra_s(a).total_cmp(&extra_s(b)))
        });
        let refined = order.into_iter().find_map(|o| {
            let mut finer = rungs.clone();
            finer[o] -= 1;
            (predicted_s(&finer) <= budget_s).then_some(finer)
        });
        match refined {
            Some(finer) => rungs = finer,
            None => break,
        }
    }
    (rungs != start).then_some(rungs)
}

#[cfg(test)]
mod tests;
