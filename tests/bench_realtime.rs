//! `splatphys bench realtime` end to end on a tiny run: the validation
//! free-fall sphere for 0.02 s at two grid cell sizes and as a rigid body. Checked on the CSV it
//! writes: one reference row with zero error, one row per cell size, then the rigid row; errors
//! finite and in reference cells, coarser grid with fewer particles and substeps, the rigid run
//! with no grid and free fall's closed-form agreement. Nothing here depends on wall-clock time.

use splatphys_tests::{num, read_csv, run_bench, workspace};

#[test]
fn realtime_sweep_writes_a_zero_error_reference_one_row_per_cell_size_and_a_rigid_row() {
    let dir = tempfile::tempdir().unwrap();
    let scene = workspace().join("scenes/validation_free_fall.toml");
    let args = [
        "realtime",
        "--scenes",
        scene.to_str().expect("UTF-8 path"),
        "--duration-s",
        "0.02",
        "--dx-m",
        "0.01,0.02",
        "--threads",
        "2",
    ];
    let stdout = run_bench(&args, dir.path());
    let summary: serde_json::Value = stdout
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .find(|v| v["bench"] == "realtime-summary")
        .expect("a summary line");
    assert_eq!(
        summary["error_unit"],
        "cells of the reference grid, dx_ref = 10 mm"
    );
    let rows = read_csv(&dir.path().join("realtime.csv"));
    assert_eq!(rows.len(), 4, "reference + 2 cell sizes + rigid: {rows:?}");
    assert!(dir.path().join("realtime.svg").exists());
    let reference = &rows[0];
    assert_eq!(reference["setting"], "reference");
    for key in [
        "com_error_m",
        "com_error_cells",
        "com_initial_offset_cells",
        "com_displacement_error_cells",
        "gaussian_error_mean_cells",
        "gaussian_error_p95_cells",
        "gaussian_error_max_cells",
    ] {
        assert_eq!(num(reference, key), 0.0, "reference {key}");
    }
    assert_eq!(reference["passes"], "true");
    for r in &rows {
        assert_eq!(num(r, "dx_ref_m"), 0.01);
        assert_eq!(num(r, "frames"), 2.0, "0.02 s at 100 frames/s");
        assert_eq!(r["gaussians"], reference["gaussians"]);
        for key in ["com_error_cells", "gaussian_error_p95_cells", "wall_s"] {
            assert!(num(r, key).is_finite(), "{key} in {r:?}");
        }
        // Errors are in reference cells: m / dx_ref.
        let cells = num(r, "com_error_m") / 0.01;
        assert!((num(r, "com_error_cells") - cells).abs() <= 1e-12 * cells.max(1.0));
    }
    let (fine, coarse, rigid) = (&rows[1], &rows[2], &rows[3]);
    assert_eq!((num(fine, "dx_m"), num(coarse, "dx_m")), (0.01, 0.02));
    assert_eq!(num(coarse, "spacing_m"), 0.01, "spacing = dx / 2");
    // Free fall at dx_ref with h = 5 mm (the sphere's own lattice): the reference again.
    assert_eq!(fine["particles"], reference["particles"]);
    assert!(num(coarse, "particles") < num(fine, "particles"));
    assert!(num(coarse, "substeps") < num(fine, "substeps"));
    // Free fall moves every particle alike: the coarse run stays well inside a cell.
    assert!(num(coarse, "gaussian_error_p95_cells") < 0.1, "{coarse:?}");
    // The same fall as one rigid body: the COM layer alone, no MPM grid, same Gaussians.
    assert_eq!(rigid["setting"], "rigid (COM layer only)");
    assert_eq!(num(rigid, "grid_blocks"), 0.0);
    assert_eq!(rigid["limited_by"], "none (no MPM)");
    // A rigid body keeps no live particles: its Gaussians are placed from its pose.
    assert_eq!(num(rigid, "particles"), 0.0, "{rigid:?}");
    assert_eq!(rigid["gaussians"], reference["gaussians"]);
    // Semi-implicit Euler at the frame step (dt = 0.01 s, no MPM bound) falls g dt t / 2 =
    // 0.98 mm = 0.098 cells further than the closed form by t = 0.02 s; the MPM reference, at
    // its much smaller CFL step, is within 1e-3 of a cell of it.
    let euler_cells = 9.81 * 0.01 * 0.02 / 2.0 / 0.01;
    for key in ["com_error_cells", "gaussian_error_p95_cells"] {
        assert!(
            (num(rigid, key) - euler_cells).abs() < 0.01,
            "{key}: {rigid:?}"
        );
    }
}
