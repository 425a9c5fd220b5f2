//! The scene file: every file in scenes/ and the issue's example load; unknown keys and wrong
//! types fail naming the key path and line; transforms, clones and the built-in scene.

use std::path::{Path, PathBuf};

use splatphys_core::scene::{
    self, ColliderShape, Command, Method, ObjectKind, Scene, SceneError, Surface,
};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn have_data() -> bool {
    let ok = root().join("../shared/data/v3dg_donut.ply").exists();
    if !ok {
        println!("skipping real-data scenes: ../shared/data not found");
    }
    ok
}

const ISSUE_EXAMPLE: &str = r#"
[simulation]
method = "com"                     # "com" | "mpm" | "multi-field"
duration_s = 1.0
frame_rate_hz = 30.0
grid_dx_m = 0.01
cfl = 0.5                          # or a fixed `dt_s = 1e-4`
gravity_m_s2 = [0.0, 0.0, -9.81]

[[source]]
name = "donut"
path = "../shared/data/v3dg_donut.ply"
scale = 1.0
rotation_deg = [0.0, 0.0, 0.0]     # x, y, z Euler angles applied in that order
translation_m = [0.0, 0.0, 0.30]

[[object]]
name = "donut"
select = { source = "donut" }      # or { box_m = [[x0, y0, z0], [x1, y1, z1]] }, { auto = 0 }, { query = "vase", features = "f.npy", embeddings = "q.json" }
kind = "deformable"                # "deformable" | "rigid" | "static"
material = { model = "jelly", youngs_modulus_pa = 2e5, poisson_ratio = 0.3, density_kg_m3 = 1000.0 }
restitution = 0.5
friction = 0.3
velocity_m_s = [0.0, 0.0, 0.0]

[[object]]
name = "ball"
shape = { sphere = { center_m = [0.0, 0.3, 0.5], radius_m = 0.05 } }   # also box = { min_m, max_m }, cylinder = { base_m, axis, radius_m, height_m }
spacing_m = 0.005
color = [0.8, 0.2, 0.2]
kind = "deformable"
material = { model = "snow", youngs_modulus_pa = 1.4e5, poisson_ratio = 0.2, density_kg_m3 = 400.0 }
velocity_m_s = [0.0, -1.0, 0.0]

[[collider]]
name = "table"
plane = { point_m = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0] }   # also box = { min_m, max_m }
surface = "sticky"                 # "sticky" | "slip" | "separate"
friction = 0.0

[[event]]
at_s = 0.2
command = "impulse"                # also set-velocity, edit-material, set-kind: the timeline keys
object = "ball"
impulse_n_s = [0.0, 1.0, 0.0]      # optional point_m

[[camera]]
name = "main"
position_m = [1.0, -1.0, 0.6]
look_at_m = [0.0, 0.0, 0.1]
fov_y_deg = 45.0
width_px = 640
height_px = 480
"#;

#[test]
fn issue_example_loads_as_written() {
    if !have_data() {
        // Still check that it parses.
        scene::parse_scene_toml(Path::new("example.toml"), ISSUE_EXAMPLE).unwrap();
        return;
    }
    let s = scene::load_scene_str(ISSUE_EXAMPLE, &root()).unwrap();
    assert_eq!(s.simulation.method, Method::Com);
    assert_eq!(s.objects.len(), 2);
    let donut = &s.objects[0];
    assert_eq!(donut.gaussians.len(), 45_624);
    assert!(s.background.is_empty());
    // Translation applied: file z in [-0.0091, 0.0862] → world [0.2909, 0.3862].
    let zmin = donut
        .gaussians
        .positions
        .iter()
        .map(|p| p[2])
        .fold(f32::INFINITY, f32::min);
    assert!((zmin - 0.2909).abs() < 1e-3, "{zmin}");
    let ball = &s.objects[1];
    // Sphere volume / spacing³ = 4/3 π 0.05³ / 0.005³ ≈ 4189 particles (jitter moves a few).
    let n = ball.gaussians.len() as f32;
    assert!((n - 4189.0).abs() / 4189.0 < 0.03, "{n}");
    assert!(ball.visible.iter().all(|&v| v));
    assert_eq!(s.colliders[0].surface, Surface::Sticky);
    assert_eq!(
        s.events[0].command,
        Command::Impulse {
            object: "ball".into(),
            impulse_n_s: [0.0, 1.0, 0.0],
            point_m: None
        }
    );
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(s.cameras[0].width_px, 640);
}

#[test]
fn every_file_in_scenes_loads() {
    let dir = root().join("scenes");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.retain(|p| p.extension().is_some_and(|e| e == "toml"));
    files.sort();
    assert!(files.len() >= 6, "{files:?}");
    let data = have_data();
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap();
        let parsed = scene::parse_scene_toml(&f, &text).unwrap_or_else(|e| panic!("{e}"));
        if !parsed.source.is_empty() && !data {
            continue;
        }
        let t = std::time::Instant::now();
        let s = scene::load_scene(&f).unwrap_or_else(|e| panic!("{e}"));
        println!(
            "{}: {} objects [{}], {} particles, {} background Gaussians, built in {:.2} s",
            f.file_name().unwrap().to_string_lossy(),
            s.objects.len(),
            s.objects
                .iter()
                .map(|o| format!("{} {}", o.name, o.gaussians.len()))
                .collect::<Vec<_>>()
                .join(", "),
            s.particle_count(),
            s.background.len(),
            t.elapsed().as_secs_f64()
        );
        assert!(!s.objects.is_empty());
        // Scenes for the CPU stay light; a scene written for the GPU may be large.
        let light = s.simulation.device == scene::Device::Cpu;
        for o in &s.objects {
            assert_eq!(o.visible.len(), o.gaussians.len());
            assert!(
                !light || o.gaussians.len() < 60_000,
                "{} has {} particles in a CPU scene",
                o.name,
                o.gaussians.len()
            );
        }
    }
}

#[test]
fn guitar_is_upright_and_about_one_metre() {
    if !have_data() {
        return;
    }
    let s = scene::load_scene(root().join("scenes/guitar_topple.toml")).unwrap();
    let g = &s.objects[0].gaussians;
    let [lo, hi] = splatphys_core::formats::inspect::bounds(g);
    println!("guitar world bounds {lo:?} .. {hi:?}");
    let height = hi[2] - lo[2];
    assert!((0.9..1.1).contains(&height), "{height}");
    assert!(lo[2] >= 0.0 && lo[2] < 0.05, "base at {}", lo[2]);
}

#[test]
fn clones_share_one_file_at_two_transforms() {
    if !have_data() {
        return;
    }
    let s = scene::load_scene(root().join("scenes/donut_clones_collide.toml")).unwrap();
    let (a, b) = (&s.objects[0].gaussians, &s.objects[1].gaussians);
    let ca = a.positions.iter().map(|p| p[0]).sum::<f32>() / a.len() as f32;
    let cb = b.positions.iter().map(|p| p[0]).sum::<f32>() / b.len() as f32;
    assert!(ca < -0.1 && cb > 0.1, "{ca} {cb}");
}

fn toml_err(text: &str) -> (String, usize, String) {
    match scene::parse_scene_toml(Path::new("bad.toml"), text) {
        Err(SceneError::Toml {
            key_path,
            line,
            message,
            ..
        }) => (key_path, line, message),
        other => panic!("expected a TOML error, got {other:?}"),
    }
}

#[test]
fn unknown_key_fails_with_key_path_and_line() {
    let text = "[simulation]\nduration_s = 1.0\n\n[[object]]\nname = \"a\"\nshape = { sphere = { center_m = [0.0, 0.0, 0.0], radius_m = 0.1 } }\nmaterial = { model = \"jelly\", youngs_modulus_pa = 1e5, poisson_ratio = 0.3, density_kg_m3 = 1000.0, colour = 1 }\n";
    let (path, line, msg) = toml_err(text);
    println!("{path} line {line}: {msg}");
    assert!(path.starts_with("object[0].material"), "{path}");
    assert!(msg.contains("colour"), "{msg}");
    assert_eq!(line, 7);
    let (path, line, msg) = toml_err("[simulation]\nduration = 1.0\n");
    assert!(path.starts_with("simulation"), "{path}");
    assert!(msg.contains("duration"), "{msg}");
    assert_eq!(line, 2);
}

#[test]
fn wrong_type_fails_with_key_path_and_line() {
    let text = "[simulation]\nduration_s = 1.0\n\n[[collider]]\nname = \"floor\"\nplane = { point_m = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0] }\nfriction = \"high\"\n";
    let (path, line, msg) = toml_err(text);
    println!("{path} line {line}: {msg}");
    assert_eq!(path, "collider[0].friction");
    assert_eq!(line, 7);
    let err = scene::parse_scene_toml(Path::new("bad.toml"), text)
        .unwrap_err()
        .to_string();
    assert!(err.starts_with("bad.toml:7:"), "{err}");
}

#[test]
fn invalid_values_name_the_key() {
    let base = "[[object]]\nname = \"a\"\nshape = { sphere = { center_m = [0.0, 0.0, 0.0], radius_m = 0.05 } }\nspacing_m = 0.01\n";
    let cases = [
        (
            format!(
                "{base}material = {{ model = \"jelly\", youngs_modulus_pa = 1e5, poisson_ratio = 0.5, density_kg_m3 = 1.0 }}\n"
            ),
            "object[0].material.poisson_ratio",
        ),
        (
            format!(
                "{base}\n[[event]]\nat_s = 0.1\ncommand = \"impulse\"\nobject = \"b\"\nimpulse_n_s = [0.0, 0.0, 1.0]\n"
            ),
            "event[0].object",
        ),
        (
            format!(
                "{base}\n[[event]]\nat_s = 0.1\nimpulse = {{ object = \"b\", vector_n_s = [0.0, 0.0, 1.0] }}\n"
            ),
            "event[0].object",
        ),
        (
            format!("{base}\n[[event]]\nat_s = 0.1\ncommand = \"pause\"\n"),
            "event[0].command",
        ),
        (
            format!("{base}\n[[collider]]\nname = \"c\"\n"),
            "collider[0]",
        ),
        (
            format!("{base}rotation_deg = [0.0, nan, 0.0]\n"),
            "object[0].rotation_deg",
        ),
        (
            format!(
                "{base}\n[[event]]\nat_s = 0.1\ncommand = \"set-pose\"\nobject = \"a\"\nposition_m = [0.0, 0.0, 0.0]\norientation_wxyz = [1.0, 0.0, 0.0, 0.0]\n"
            ),
            "event[0].object",
        ),
        (
            "[[object]]\nname = \"a\"\nselect = { source = \"nope\" }\n".to_string(),
            "object[0].select.source",
        ),
        (
            format!("{base}fill = {{ spacing_m = 0.01, max_seal_cells = 17 }}\n"),
            "object[0].fill.max_seal_cells",
        ),
        (
            format!(
                "{base}material = {{ model = \"jelly\", youngs_modulus_pa = 1e5, poisson_ratio = 0.3, density_kg_m3 = 1000.0, damping_viscosity_pa_s = -1.0 }}\n"
            ),
            "object[0].material.damping_viscosity_pa_s",
        ),
        (
            format!(
                "{base}material = {{ model = \"jelly\", youngs_modulus_pa = 1e5, poisson_ratio = 0.3, density_kg_m3 = 1000.0, damping_viscosity_pa_s = 1e7 }}\n"
            ),
            "object[0].material.damping_viscosity_pa_s",
        ),
        (
            format!("{base}rolling_resistance_m = -0.001\n"),
            "object[0].rolling_resistance_m",
        ),
        (
            format!("{base}rolling_resistance_m = nan\n"),
            "object[0].rolling_resistance_m",
        ),
    ];
    for (text, key) in cases {
        match scene::load_scene_str(&text, Path::new(".")) {
            Err(SceneError::Invalid { key_path, .. }) => assert_eq!(key_path, key),
            other => panic!("{key}: expected Invalid, got {other:?}"),
        }
    }
    // An unknown model fails to parse (the model is an enum, `MaterialModel`): a TOML error at
    // the same key, with its line.
    let text = format!(
        "{base}material = {{ model = \"rubber\", youngs_modulus_pa = 1e5, poisson_ratio = 0.3, density_kg_m3 = 1.0 }}\n"
    );
    match scene::load_scene_str(&text, Path::new(".")) {
        Err(SceneError::Toml { key_path, line, .. }) => {
            assert_eq!(key_path, "object[0].material.model");
            assert_eq!(line, 5);
        }
        other => panic!("object[0].material.model: expected a TOML error, got {other:?}"),
    }
}

#[test]
fn builtin_default_is_procedural_and_sane() {
    let s = Scene::builtin_default();
    assert_eq!(s.objects.len(), 3);
    assert_eq!(s.objects[0].kind, ObjectKind::Static);
    assert!(matches!(s.colliders[0].shape, ColliderShape::Plane { .. }));
    assert_eq!(s.colliders[0].surface, Surface::Sticky);
    assert_eq!(s.cameras.len(), 1);
    let n = s.particle_count();
    println!("builtin default: {n} particles");
    assert!((5_000..50_000).contains(&n), "{n}");
    assert_eq!(Scene::builtin_default(), s, "deterministic");
}

#[test]
fn source_transform_rotates_scales_and_translates() {
    use glam::{Quat, Vec3};
    use splatphys_core::procedural::isotropic_gaussians;
    use splatphys_core::scene::transform::{apply_similarity, euler_xyz_deg};
    let mut c = isotropic_gaussians(vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], 0.1, [0.5; 3]);
    // -90° about x maps +y to -z; then scale 2 and lift by 1 m.
    apply_similarity(
        &mut c,
        2.0,
        euler_xyz_deg([-90.0, 0.0, 90.0]),
        Vec3::new(0.0, 0.0, 1.0),
    );
    // x first: (1,0,0) stays, then 90° about z: → (0,1,0) ·2 + (0,0,1).
    let p0 = Vec3::from(c.positions[0]);
    assert!(p0.abs_diff_eq(Vec3::new(0.0, 2.0, 1.0), 1e-5), "{p0}");
    let p1 = Vec3::from(c.positions[1]);
    assert!(p1.abs_diff_eq(Vec3::new(0.0, 0.0, -1.0), 1e-5), "{p1}");
    assert!((c.scale(0).x - 0.2).abs() < 1e-6);
    let q = c.rotation(0);
    assert!(
        q.abs_diff_eq(euler_xyz_deg([-90.0, 0.0, 90.0]), 1e-6)
            || q.abs_diff_eq(-euler_xyz_deg([-90.0, 0.0, 90.0]), 1e-6)
    );
    let _ = Quat::IDENTITY;
}

#[test]
fn deprecated_event_tables_load_with_a_warning_as_the_same_commands() {
    let base = "[[object]]\nname = \"b\"\nshape = { sphere = { center_m = [0.0, 0.0, 0.1], radius_m = 0.02 } }\nspacing_m = 0.01\n";
    let old = format!(
        "{base}[[event]]\nat_s = 0.1\nimpulse = {{ object = \"b\", vector_n_s = [0.0, 0.0, 1.0], point_m = [0.0, 0.0, 0.1] }}\n\
         [[event]]\nat_s = 0.2\nset_velocity = {{ object = \"b\", velocity_m_s = [1.0, 0.0, 0.0] }}\n\
         [[event]]\nat_s = 0.3\nset_material = {{ object = \"b\", material = {{ model = \"snow\", youngs_modulus_pa = 1e5, poisson_ratio = 0.2, density_kg_m3 = 400.0 }}, friction = 0.5 }}\n"
    );
    let new = format!(
        "{base}[[event]]\nat_s = 0.1\ncommand = \"impulse\"\nobject = \"b\"\nimpulse_n_s = [0.0, 0.0, 1.0]\npoint_m = [0.0, 0.0, 0.1]\n\
         [[event]]\nat_s = 0.2\ncommand = \"set-velocity\"\nobject = \"b\"\nvelocity_m_s = [1.0, 0.0, 0.0]\n\
         [[event]]\nat_s = 0.3\ncommand = \"edit-material\"\nobject = \"b\"\nmodel = \"snow\"\nyoungs_modulus_pa = 1e5\npoisson_ratio = 0.2\ndensity_kg_m3 = 400.0\nfriction = 0.5\n"
    );
    let (a, b) = (
        scene::load_scene_str(&old, Path::new(".")).unwrap(),
        scene::load_scene_str(&new, Path::new(".")).unwrap(),
    );
    assert_eq!(a.events, b.events);
    assert_eq!(a.warnings.len(), 3, "{:?}", a.warnings);
    assert!(
        a.warnings[0].contains("deprecated") && a.warnings[0].contains("command = \"impulse\"")
    );
    assert!(b.warnings.is_empty());
    // A model parameter cannot be carried by an edit: refused, naming the key.
    let hard = format!(
        "{base}[[event]]\nat_s = 0.3\nset_material = {{ object = \"b\", material = {{ model = \"snow\", youngs_modulus_pa = 1e5, poisson_ratio = 0.2, density_kg_m3 = 400.0, hardening = 5.0 }} }}\n"
    );
    match scene::load_scene_str(&hard, Path::new(".")) {
        Err(SceneError::Invalid { key_path, .. }) => {
            assert_eq!(key_path, "event[0].set_material.material")
        }
        other => panic!("expected Invalid, got {other:?}"),
    }
}
