//! `splatphys bench islands` end to end on a tiny run: a soft and a stiff jelly sphere far apart
//! in free fall for 0.05 s, stepped with islands on and off. Checked on the CSV it writes: one
//! row per object and setting; apart, the soft sphere takes fewer substeps than the stiff one,
//! and the stiff one as many as the whole scene stepped as one; the run stepped as one is its own
//! reference (zero offsets). Nothing here depends on wall-clock time.

use splatphys_tests::{num, read_csv, run_bench};

const SCENE: &str = r#"
[simulation]
method = "com"
duration_s = 0.05
frame_rate_hz = 60.0
grid_dx_m = 0.01
cfl = 0.5

[[object]]
name = "soft"
shape = { sphere = { center_m = [-0.3, 0.0, 0.5], radius_m = 0.04 } }
spacing_m = 0.01
material = { model = "jelly", youngs_modulus_pa = 1e4, poisson_ratio = 0.3, density_kg_m3 = 1000.0 }

[[object]]
name = "stiff"
shape = { sphere = { center_m = [0.3, 0.0, 0.5], radius_m = 0.04 } }
spacing_m = 0.01
material = { model = "jelly", youngs_modulus_pa = 1e6, poisson_ratio = 0.3, density_kg_m3 = 1000.0 }
"#;

#[test]
fn islands_bench_writes_a_row_per_object_and_setting_and_the_soft_sphere_steps_less() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("two.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let args = [
        "islands",
        "--scene",
        scene.to_str().expect("UTF-8 path"),
        "--repeat",
        "1",
        "--threads",
        "2",
    ];
    let stdout = run_bench(&args, dir.path());
    assert_eq!(stdout.lines().count(), 4, "{stdout}");
    let rows = read_csv(&dir.path().join("islands.csv"));
    assert_eq!(rows.len(), 4, "{rows:?}");
    let row = |islands: &str, object: &str| {
        rows.iter()
            .find(|r| r["islands"] == islands && r["object"] == object)
            .unwrap_or_else(|| panic!("no row {islands} {object}: {rows:?}"))
    };
    let (soft, stiff) = (row("true", "soft"), row("true", "stiff"));
    let (whole_soft, whole_stiff) = (row("false", "soft"), row("false", "stiff"));
    // c_p grows with sqrt(E): 10x; both fall at the same speed, so the soft sphere's substep
    // is several times the stiff one's.
    assert!(
        num(soft, "substeps") * 3.0 < num(stiff, "substeps"),
        "{soft:?} {stiff:?}"
    );
    assert_eq!(num(stiff, "substeps"), num(whole_stiff, "substeps"));
    assert_eq!(num(whole_soft, "substeps"), num(whole_stiff, "substeps"));
    for r in [whole_soft, whole_stiff] {
        assert_eq!(num(r, "com_off_max_m"), 0.0, "{r:?}");
        assert_eq!(num(r, "particle_off_max_m"), 0.0, "{r:?}");
    }
    // Free fall depends on the substep only through symplectic Euler's lag behind the closed
    // form, g t dt / 2 (0.3 mm at the soft sphere's dt, 0.03 mm at the stiff one's): the soft
    // sphere's COM stays within g t dt of the run as one, and is not the same to the bit.
    let lag = 9.81 * 0.05 * num(soft, "dt_max_s");
    let off = num(soft, "com_off_max_m");
    assert!(off > 0.0 && off < lag, "{off} m against {lag} m: {soft:?}");
    assert!(num(soft, "wall_min_s").is_finite() && num(soft, "wall_min_s") > 0.0);
    assert!(stdout.contains("\"island_escapes\":0"), "{stdout}");
}
