//! Tests of the level-of-detail choice, with cost models injected in place of timings.

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
        let dx = level.coarsest_cell_m();
        self.measured.push(dx);
        let r = dx / self.dx0;
        Ok(Measurement {
            wall_s_per_frame: 1.0 / (self.fps0 * r.powi(3)),
            com_error_m: Some((r - 1.0) * 1e-3),
            p95_error_m: Some((r - 1.0) * 2e-3),
            object_wall_s_per_frame: Vec::new(),
        })
    }
}

#[test]
fn candidates_keep_three_cells_across_the_thinnest_deformable_object() {
    let s = scene();
    let dxs: Vec<f64> = candidates(&s).iter().map(|c| c.coarsest_cell_m()).collect();
    // 0.0975 m / 3 = 32.5 mm: factors up to 6 (30 mm) qualify, 8 (40 mm) does not.
    let want = [0.005, 0.0075, 0.01, 0.015, 0.02, 0.025, 0.03];
    assert_eq!(dxs.len(), want.len(), "{dxs:?}");
    for (a, b) in dxs.iter().zip(want) {
        assert!((a - b).abs() < 1e-12, "{dxs:?}");
    }
    let coarse = &candidates(&s)[1];
    assert_eq!(coarse.collision_dx_m, 0.005);
    assert_eq!(
        coarse.grid_dx_m, 0.005,
        "the scene's grid (rigid objects) as written"
    );
    assert_eq!(coarse.objects.len(), 1, "only the deformable object");
    assert_eq!(coarse.objects[0].physics_spacing_m, Some(0.00375));
    assert_eq!(coarse.objects[0].grid_dx_m, Some(0.0075));
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
    assert!((c.chosen.coarsest_cell_m() - 0.015).abs() < 1e-12);
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
    assert!(
        (c.chosen.coarsest_cell_m() - 0.03).abs() < 1e-12,
        "the coarsest"
    );
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
    let level = LevelOfDetail::with_cells(&s, &[Some(0.02)]);
    let json = serde_json::to_string(&level).unwrap();
    let back: LevelOfDetail = serde_json::from_str(&json).unwrap();
    assert_eq!(back, level);
    let rigid_before = s.objects[1].clone();
    back.apply(&mut s).unwrap();
    assert_eq!(s.simulation.grid_dx_m, 0.005);
    assert_eq!(s.simulation.collision_cell_m(), 0.005);
    assert_eq!(s.objects[0].physics_spacing_m, Some(0.01));
    assert_eq!(s.objects[0].grid_dx_m(&s.simulation), 0.02);
    assert_eq!(s.objects[1], rigid_before);
    assert_eq!(LevelOfDetail::as_written(&s), level);
}

#[test]
fn apply_refuses_what_does_not_fit_the_scene_and_changes_nothing() {
    let s0 = scene();
    let level = LevelOfDetail::with_cells(&s0, &[Some(0.02)]);
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

/// A 20 cm jelly cube and a 4 cm one on a 5 mm grid: the small one's ladder is 5, 7.5 and
/// 10 mm (3 cells across its 3.5 cm), the large one's goes to 40 mm.
fn two_cubes(method: Method) -> Scene {
    Scene::builder()
        .grid_dx_m(0.005)
        .method(method)
        .object(
            SceneObject::cuboid("big", [0.0, 0.0, 0.0], [0.2, 0.2, 0.2])
                .spacing_m(0.005)
                .material(MaterialSpec::jelly(1e5, 0.3, 1000.0)),
        )
        .object(
            SceneObject::cuboid("small", [0.5, 0.0, 0.0], [0.54, 0.04, 0.04])
                .spacing_m(0.005)
                .material(MaterialSpec::jelly(1e5, 0.3, 1000.0)),
        )
        .build()
        .unwrap()
}

/// Per-object costs from a table: object o at cell d costs `scale[o]` × (5 mm / d)⁴ seconds
/// per frame (cells³ × substeps), plus 1 ms for the rest of the frame; a level with the
/// small cube finer than 10 mm and the big one coarser costs `mixed_penalty` times that
/// (what a prediction from uniform steps cannot see).
struct PerObject {
    scale: [f64; 2],
    mixed_penalty: f64,
    measured: Vec<[f64; 2]>,
    /// Levels whose cells are all this fine report no per-object times (a calibration run
    /// stopped within its first frame).
    unknown_at_m: Option<f64>,
}

impl CostModel for PerObject {
    type Error = String;
    fn measure(&mut self, level: &LevelOfDetail) -> Result<Measurement, String> {
        let cells: Vec<f64> = level
            .objects
            .iter()
            .map(|o| o.cell_m(level.grid_dx_m))
            .collect();
        self.measured.push([cells[0], cells[1]]);
        let object: Vec<f64> = (0..2)
            .map(|o| self.scale[o] * (0.005 / cells[o]).powi(4))
            .collect();
        let penalty = if cells[1] < 0.01 && cells[0] > cells[1] {
            self.mixed_penalty
        } else {
            1.0
        };
        let wall_s_per_frame = penalty * (1e-3 + object.iter().sum::<f64>());
        let unknown = self
            .unknown_at_m
            .is_some_and(|d| cells.iter().all(|c| *c <= d));
        Ok(Measurement {
            wall_s_per_frame,
            com_error_m: None,
            p95_error_m: None,
            object_wall_s_per_frame: if unknown { Vec::new() } else { object },
        })
    }
}

#[test]
fn ladders_stop_at_three_cells_across_each_object() {
    let s = two_cubes(Method::Com);
    let l = ladders(&s);
    let mm = |l: &Ladder| {
        l.cells_m
            .iter()
            .map(|d| (d * 1e4).round() / 10.0)
            .collect::<Vec<_>>()
    };
    assert_eq!(mm(&l[0]), [5.0, 7.5, 10.0, 15.0, 20.0, 25.0, 30.0, 40.0]);
    assert_eq!(mm(&l[1]), [5.0, 7.5, 10.0]);
    // Uniform steps: the small cube stays at 10 mm once its ladder ends.
    let c = candidates(&s);
    assert_eq!(c.len(), 8);
    assert_eq!(c[5].objects[0].grid_dx_m, Some(0.025));
    assert_eq!(c[5].objects[1].grid_dx_m, Some(0.01));
}

#[test]
fn each_object_gets_its_own_cell_and_the_small_one_the_finer() {
    let s = two_cubes(Method::Com);
    // Uniform: 1.26 s at 5 mm, 0.25 s at 7.5 mm, 0.080 s at 10 mm, 0.017 s at 15/10 mm
    // (the first within 1/30 s). Per object from there: the small cube (3.5 cells across at
    // 10 mm) refines to 7.5 mm (0.018 s) and then to 5 mm (0.026 s); the big one back to
    // 10 mm would cost 0.089 s.
    let mut model = PerObject {
        scale: [1.25, 0.01],
        mixed_penalty: 1.0,
        measured: Vec::new(),
        unknown_at_m: None,
    };
    let c = choose(&s, 30.0, &mut model).unwrap();
    assert!(c.budget_met);
    assert_eq!(
        c.calibration.len(),
        5,
        "four uniform steps and the per-object check"
    );
    assert_eq!(model.measured[3], [0.015, 0.01]);
    assert_eq!(model.measured[4], [0.015, 0.005]);
    assert_eq!(c.chosen, c.calibration[4].0);
    assert_eq!(c.chosen.objects[0].grid_dx_m, Some(0.015));
    assert_eq!(c.chosen.objects[0].physics_spacing_m, Some(0.0075));
    assert_eq!(
        c.chosen.objects[1].grid_dx_m, None,
        "the small cube as written"
    );
    assert!(
        (c.expected.wall_s_per_frame - 0.02643).abs() < 1e-4,
        "{:?}",
        c.expected
    );
}

#[test]
fn no_object_is_refined_into_a_rung_whose_times_are_unknown() {
    let s = two_cubes(Method::Com);
    // As above, but the 5 mm step reports no per-object times: the small cube stops at
    // 7.5 mm.
    let mut model = PerObject {
        scale: [1.25, 0.01],
        mixed_penalty: 1.0,
        measured: Vec::new(),
        unknown_at_m: Some(0.005),
    };
    let c = choose(&s, 30.0, &mut model).unwrap();
    assert!(c.budget_met);
    assert_eq!(model.measured[4], [0.015, 0.0075]);
    assert_eq!(c.chosen.objects[1].grid_dx_m, Some(0.0075));
}

#[test]
fn a_per_object_choice_that_measures_over_budget_falls_back_to_the_uniform_step() {
    let s = two_cubes(Method::Com);
    let mut model = PerObject {
        scale: [1.25, 0.01],
        mixed_penalty: 3.0,
        measured: Vec::new(),
        unknown_at_m: None,
    };
    let c = choose(&s, 30.0, &mut model).unwrap();
    assert!(c.budget_met);
    assert_eq!(c.calibration.len(), 5, "{:?}", model.measured);
    assert_eq!(
        c.chosen, c.calibration[3].0,
        "the uniform step that met the budget"
    );
}

#[test]
fn a_shared_grid_is_coarsened_as_one() {
    let s = two_cubes(Method::Mpm);
    let c = candidates(&s);
    assert_eq!(c.len(), 3, "as far as the small cube's ladder goes");
    assert_eq!(c[2].grid_dx_m, 0.01);
    assert!(c[2].objects.iter().all(|o| o.grid_dx_m.is_none()));
    let mut model = PerObject {
        scale: [0.2, 0.05],
        mixed_penalty: 1.0,
        measured: Vec::new(),
        unknown_at_m: None,
    };
    let chosen = choose(&s, 30.0, &mut model).unwrap();
    // 0.050 s at 7.5 mm, 0.017 s at 10 mm: no per-object step on a shared grid.
    assert_eq!(model.measured.len(), 3);
    assert_eq!(chosen.chosen, c[2]);
}
