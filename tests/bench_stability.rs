//! `splatphys bench stability --quick` end to end: the binary sweeps every method ×
//! material on the small quick planes and writes one CSV row per run. Checked on the files it
//! writes: as many rows as the sweep has runs, no NaN and at most 1 % energy growth anywhere with
//! automatic time stepping, and at least one failure at the largest forced CFL number (so the
//! failure detector fires). Nothing here depends on wall-clock time.

use splatphys_tests::{num, read_csv, run_bench};

/// Methods × materials of the default sweep.
const COMBOS: usize = 3 * 7;
/// Runs per method × material in the quick sweep: auto_speed 2 × 2, auto_poisson 2 × 2,
/// forced_cfl 2 C values × 2 E values.
const QUICK_RUNS_PER_COMBO: usize = 4 + 4 + 4;

#[test]
fn quick_stability_map_is_clean_with_automatic_dt_and_fails_at_the_largest_forced_cfl() {
    let dir = tempfile::tempdir().unwrap();
    let stdout = run_bench(&["stability", "--quick", "--threads", "2"], dir.path());
    let plan: serde_json::Value = stdout
        .lines()
        .find(|l| l.contains("\"stability_plan\""))
        .map(|l| serde_json::from_str(l).unwrap())
        .expect("plan line");
    assert_eq!(plan["runs"], COMBOS * QUICK_RUNS_PER_COMBO, "{plan}");

    let mut rows = 0;
    for plane in ["auto_speed", "auto_poisson", "forced_cfl"] {
        let csv = read_csv(&dir.path().join(format!("stability_{plane}.csv")));
        let planned = plan["planes"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["plane"] == plane)
            .unwrap_or_else(|| panic!("{plane} missing from {plan}"));
        assert_eq!(
            csv.len() as u64,
            planned["runs"].as_u64().unwrap(),
            "{plane}"
        );
        assert_eq!(csv.len(), COMBOS * 4, "{plane}");
        rows += csv.len();
        // One JSON line per run on stdout too.
        let lines = stdout
            .lines()
            .filter(|l| l.contains("\"bench\":\"stability\"") && l.contains(plane))
            .count();
        assert_eq!(lines, csv.len(), "{plane}: JSON lines");
        let svg = dir.path().join(format!("stability_{plane}.svg"));
        assert!(std::fs::metadata(&svg).unwrap().len() > 1000, "{svg:?}");

        if plane.starts_with("auto") {
            for r in &csv {
                let what = format!("{plane} {r:?}");
                assert_eq!(r["dt_policy"], "auto", "{what}");
                assert_eq!(r["finished"], "true", "{what}");
                assert_eq!(r["failure"], "", "{what}");
                // The automatic policy's promise: energy never grows by more than 1 %.
                assert!(num(r, "energy_growth") <= 0.01, "{what}");
                assert_eq!(r["stable"], "true", "{what}");
            }
        } else {
            let largest = csv.iter().map(|r| num(r, "cfl")).fold(0.0, f64::max);
            assert_eq!(largest, 2.0);
            let failed = csv
                .iter()
                .filter(|r| num(r, "cfl") == largest && !r["failure"].is_empty())
                .count();
            assert!(failed > 0, "no forced run failed at C = {largest}");
            // Failures say when: the substeps completed before it was detected.
            for r in csv.iter().filter(|r| !r["failure"].is_empty()) {
                assert!(num(r, "failure_substep") >= 0.0, "{r:?}");
                assert_eq!(r["finished"], "false", "{r:?}");
            }
        }
    }
    assert_eq!(rows, COMBOS * QUICK_RUNS_PER_COMBO);
    let cstar = read_csv(&dir.path().join("stability_cstar.csv"));
    assert_eq!(cstar.len(), COMBOS);
}
