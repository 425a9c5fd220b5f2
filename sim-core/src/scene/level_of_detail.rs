//! Level of detail by budget: choose how coarsely a scene's deformable objects are simulated so
//! that it runs at a given number of simulated frames per wall second.
//!
//! The systems that make deformable Gaussian objects interactive simulate a coarse proxy and
//! carry the Gaussians along (VR-GS, Jiang et al. 2024; PhysTwin, Jiang et al. 2025). Here the
//! proxy is the object's physics-particle subset ([`SceneObject::physics_spacing_m`], carried by
//! `crate::world::carry`) on a coarser MPM grid: a [`LevelOfDetail`] sets the grid cell and each
//! deformable object's spacing (half a cell: two particles per cell per axis, MLS-MPM's usual
//! eight per cell).
//!
//! [`choose`] measures candidates through a [`CostModel`] (timed calibration runs in
//! `splatphys run`, a table in tests), from the scene as written to coarser grids, and keeps the
//! finest that meets the budget; if none does, the fastest, flagged. The cost is assumed to fall
//! as the grid coarsens, so the search stops at the first candidate that meets the budget.
//!
//! What a level of detail never changes: rigid, static and kinematic objects keep their particles
//! and their collision surfaces (sampled surfaces keep the written grid's cell through
//! [`SimulationSettings::collision_dx_m`]). They do step with the coarser grid's substeps, since
//! the whole scene shares one time step.

use serde::{Deserialize, Serialize};

use super::{ObjectKind, Scene, SceneObject, SimulationSettings};

/// Candidate grid cells, as multiples of the scene's own `grid_dx_m`, finest first.
pub const DX_FACTORS: [f64; 7] = [1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0];

/// Grid cells a candidate keeps across every deformable object's thinnest extent (its
/// axis-aligned bounds): fewer and MPM no longer resolves the object's shape.
pub const MIN_CELLS_ACROSS: f64 = 3.0;

/// Physics-particle spacing of a coarsened deformable object, as a fraction of the grid cell.
pub const SPACING_PER_DX: f64 = 0.5;

/// How coarsely a scene's deformable objects are simulated: the grid cell and each deformable
/// object's physics-particle spacing. Serialised into `summary.json` so that a run can be
/// reproduced exactly (`splatphys run --spacing-from summary.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LevelOfDetail {
    /// MPM grid cell, m.
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

/// What a calibration run of one level of detail measured.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Measurement {
    /// Wall seconds per simulated frame.
    pub wall_s_per_frame: f64,
    /// Largest distance between a moving object's COM and the scene-as-written's, over the
    /// calibration frames, m; `None` when not measured.
    pub com_error_m: Option<f64>,
    /// 95th percentile of the distance between the moving Gaussians and the scene-as-written's at
    /// the end of the calibration, m; `None` when not measured.
    pub p95_error_m: Option<f64>,
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
    /// Every candidate measured, finest first.
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

    /// The scene on a grid of cell `grid_dx_m`, every deformable object at [`SPACING_PER_DX`] of
    /// it, collision surfaces as written.
    pub fn coarsened(scene: &Scene, grid_dx_m: f64) -> Self {
        let mut level = Self::as_written(scene);
        level.grid_dx_m = grid_dx_m;
        for o in &mut level.objects {
            o.physics_spacing_m = Some((grid_dx_m * SPACING_PER_DX) as f32);
            o.grid_dx_m = None;
        }
        level
    }

    /// Whether it leaves `scene` as written.
    pub fn is_as_written(&self, scene: &Scene) -> bool {
        *self == Self::as_written(scene)
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

/// The levels of detail worth measuring for `scene`, finest first: the scene as written, then
/// grids of [`DX_FACTORS`] × its cell that keep [`MIN_CELLS_ACROSS`] cells across every
/// deformable object. Only the scene as written when it has no deformable object.
pub fn candidates(scene: &Scene) -> Vec<LevelOfDetail> {
    let mut out = vec![LevelOfDetail::as_written(scene)];
    let thinnest = scene
        .objects
        .iter()
        .filter(|o| deformable(o))
        .map(|o| {
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
            (0..3)
                .map(|k| f64::from(hi[k] - lo[k]))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(f64::INFINITY, f64::min);
    if !thinnest.is_finite() {
        return out;
    }
    let dx = scene.simulation.grid_dx_m;
    out.extend(
        DX_FACTORS
            .iter()
            .map(|f| f * dx)
            .filter(|d| d * MIN_CELLS_ACROSS <= thinnest)
            .map(|d| LevelOfDetail::coarsened(scene, d)),
    );
    out
}

/// Chooses the finest of [`candidates`] that runs at `budget_fps` or faster by `model`, measuring
/// from the finest and stopping at the first that meets the budget; when none does, the fastest
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
        calibration.push((level, m));
        if meets(&m) {
            break;
        }
    }
    // The last measured is the first that meets the budget, if any did; else the fastest.
    let mut best = calibration.len() - 1;
    if !meets(&calibration[best].1) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::MaterialSpec;

    /// A 10 cm jelly cube (thinnest extent about 9.5 cm between its outer Gaussians) and a rigid
    /// box, on a 5 mm grid.
    fn scene() -> Scene {
        Scene::builder()
            .grid_dx_m(0.005)
            .object(
                SceneObject::cuboid("jelly", [0.0, 0.0, 0.0], [0.1, 0.1, 0.1])
                    .spacing_m(0.005)
                    .material(MaterialSpec::jelly(1e5, 0.3, 1000.0)),
            )
            .object(
                SceneObject::cuboid("crate", [0.3, 0.0, 0.0], [0.4, 0.1, 0.1])
                    .kind(ObjectKind::Rigid)
                    .spacing_m(0.005),
            )
            .build()
            .unwrap()
    }

    /// A cost model from a table: frames per wall second falls with the number of cells, as
    /// (dx / dx0)^3 × `fps0`; error grows linearly with dx.
    struct Table {
        fps0: f64,
        dx0: f64,
        measured: Vec<f64>,
    }

    impl CostModel for Table {
        type Error = String;
        fn measure(&mut self, level: &LevelOfDetail) -> Result<Measurement, String> {
            self.measured.push(level.grid_dx_m);
            let r = level.grid_dx_m / self.dx0;
            Ok(Measurement {
                wall_s_per_frame: 1.0 / (self.fps0 * r.powi(3)),
                com_error_m: Some((r - 1.0) * 1e-3),
                p95_error_m: Some((r - 1.0) * 2e-3),
            })
        }
    }

    #[test]
    fn candidates_keep_three_cells_across_the_thinnest_deformable_object() {
        let s = scene();
        let dxs: Vec<f64> = candidates(&s).iter().map(|c| c.grid_dx_m).collect();
        // 0.0975 m / 3 = 32.5 mm: factors up to 6 (30 mm) qualify, 8 (40 mm) does not.
        let want = [0.005, 0.0075, 0.01, 0.015, 0.02, 0.025, 0.03];
        assert_eq!(dxs.len(), want.len(), "{dxs:?}");
        for (a, b) in dxs.iter().zip(want) {
            assert!((a - b).abs() < 1e-12, "{dxs:?}");
        }
        let coarse = &candidates(&s)[1];
        assert_eq!(coarse.collision_dx_m, 0.005);
        assert_eq!(coarse.objects.len(), 1, "only the deformable object");
        assert_eq!(coarse.objects[0].physics_spacing_m, Some(0.00375));
    }

    #[test]
    fn choose_takes_the_finest_candidate_that_meets_the_budget_and_stops_there() {
        let s = scene();
        // 2 fps at 5 mm: 2 × 1.5³ = 6.75 at 7.5 mm, 16 at 10 mm, 54 at 15 mm.
        let mut model = Table {
            fps0: 2.0,
            dx0: 0.005,
            measured: Vec::new(),
        };
        let c = choose(&s, 30.0, &mut model).unwrap();
        assert!(c.budget_met);
        assert!((c.chosen.grid_dx_m - 0.015).abs() < 1e-12);
        assert!((c.expected.frames_per_wall_s() - 54.0).abs() < 1e-9);
        assert!((c.expected.com_error_m.unwrap() - 2e-3).abs() < 1e-12);
        assert_eq!(model.measured.len(), 4, "no candidate past the chosen one");
        assert_eq!(c.calibration.len(), 4);
    }

    #[test]
    fn choose_keeps_the_scene_as_written_when_it_already_meets_the_budget() {
        let s = scene();
        let mut model = Table {
            fps0: 100.0,
            dx0: 0.005,
            measured: Vec::new(),
        };
        let c = choose(&s, 30.0, &mut model).unwrap();
        assert!(c.budget_met && c.chosen.is_as_written(&s));
        assert_eq!(model.measured.len(), 1);
    }

    #[test]
    fn choose_falls_back_to_the_fastest_when_no_candidate_meets_the_budget() {
        let s = scene();
        let mut model = Table {
            fps0: 0.01,
            dx0: 0.005,
            measured: Vec::new(),
        };
        let c = choose(&s, 30.0, &mut model).unwrap();
        assert!(!c.budget_met);
        assert!((c.chosen.grid_dx_m - 0.03).abs() < 1e-12, "the coarsest");
        assert_eq!(model.measured.len(), 7);
    }

    #[test]
    fn a_scene_without_deformable_objects_is_measured_once_and_kept() {
        let s = Scene::builder()
            .object(SceneObject::sphere("ball", [0.0; 3], 0.05).kind(ObjectKind::Rigid))
            .build()
            .unwrap();
        let mut model = Table {
            fps0: 0.01,
            dx0: 0.01,
            measured: Vec::new(),
        };
        let c = choose(&s, 30.0, &mut model).unwrap();
        assert!(c.chosen.is_as_written(&s) && !c.budget_met);
        assert_eq!(model.measured, vec![0.01]);
    }

    #[test]
    fn apply_sets_only_deformable_objects_and_the_grid_and_round_trips_through_json() {
        let mut s = scene();
        let level = LevelOfDetail::coarsened(&s, 0.02);
        let json = serde_json::to_string(&level).unwrap();
        let back: LevelOfDetail = serde_json::from_str(&json).unwrap();
        assert_eq!(back, level);
        let rigid_before = s.objects[1].clone();
        back.apply(&mut s).unwrap();
        assert_eq!(s.simulation.grid_dx_m, 0.02);
        assert_eq!(s.simulation.collision_cell_m(), 0.005);
        assert_eq!(s.objects[0].physics_spacing_m, Some(0.01));
        assert_eq!(s.objects[1], rigid_before);
        assert_eq!(LevelOfDetail::as_written(&s), level);
    }

    #[test]
    fn apply_refuses_what_does_not_fit_the_scene_and_changes_nothing() {
        let s0 = scene();
        let level = LevelOfDetail::coarsened(&s0, 0.02);
        let cases: [(LevelOfDetail, &str); 4] = [
            (
                LevelOfDetail {
                    grid_dx_m: -1.0,
                    ..level.clone()
                },
                "grid_dx_m = -1 must be a positive number",
            ),
            (
                LevelOfDetail {
                    objects: vec![ObjectSpacing {
                        name: "crate".into(),
                        physics_spacing_m: Some(0.01),
                        grid_dx_m: None,
                    }],
                    ..level.clone()
                },
                "object \"crate\" is Rigid, not deformable",
            ),
            (
                LevelOfDetail {
                    objects: vec![ObjectSpacing {
                        name: "ghost".into(),
                        physics_spacing_m: Some(0.01),
                        grid_dx_m: None,
                    }],
                    ..level.clone()
                },
                "no object \"ghost\"",
            ),
            (
                LevelOfDetail {
                    objects: Vec::new(),
                    ..level.clone()
                },
                "deformable object \"jelly\" is not listed",
            ),
        ];
        for (bad, why) in cases {
            let mut s = s0.clone();
            let e = bad.apply(&mut s).unwrap_err().to_string();
            assert!(e.contains(why), "{e}");
            assert_eq!(s, s0);
        }
    }
}
