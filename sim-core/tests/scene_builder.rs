//! `Scene::builder()`: a builder scene equals the scene of the TOML file with the same content,
//! and a bad value gives the error (variant and key path) the file would.

use std::path::Path;

use splatphys_core::material::{MaterialModel, MaterialSpec};
use splatphys_core::scene::{
    CameraSpec, ColliderSpec, Command, EventSpec, Method, ObjectKind, Scene, SceneBuilder,
    SceneError, SceneObject, Surface, load_scene_str,
};

const TOML: &str = r#"
[simulation]
method = "multi-field"
duration_s = 0.75
frame_rate_hz = 40.0
grid_dx_m = 0.008
cfl = 0.4
dt_s = 2e-4
gravity_m_s2 = [0.0, -1.0, -9.0]
domain_m = [[-0.5, -0.5, -0.1], [0.5, 0.5, 0.9]]
seed = 7
physics_spacing_m = 0.02

[[object]]
name = "ball"
shape = { sphere = { center_m = [0.0, 0.0, 0.3], radius_m = 0.05 } }
spacing_m = 0.006
color = [0.9, 0.2, 0.3]
material = { model = "snow", youngs_modulus_pa = 1.4e5, poisson_ratio = 0.2, density_kg_m3 = 400.0, hardening = 10.0, critical_compression = 0.025, critical_stretch = 0.0075 }
restitution = 0.25
friction = 0.6
velocity_m_s = [1.0, 0.0, -0.5]

[[object]]
name = "table"
kind = "static"
shape = { box = { min_m = [-0.3, -0.3, 0.0], max_m = [0.3, 0.3, 0.05] } }
material = { model = "jelly", youngs_modulus_pa = 1e7, poisson_ratio = 0.3, density_kg_m3 = 800.0 }

[[object]]
name = "can"
kind = "rigid"
shape = { cylinder = { base_m = [0.2, 0.0, 0.05], axis = [0.0, 1.0, 1.0], radius_m = 0.03, height_m = 0.1 } }
spacing_m = 0.005
physics_spacing_m = 0.01

[[collider]]
name = "floor"
plane = { point_m = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 2.0] }

[[collider]]
name = "pusher"
box = { min_m = [-0.5, -0.1, 0.0], max_m = [-0.4, 0.1, 0.1] }
surface = "slip"
friction = 0.2
velocity_m_s = [0.5, 0.0, 0.0]
active_s = [0.1, 0.4]

[[event]]
at_s = 0.3
command = "set-velocity"
object = "ball"
velocity_m_s = [0.0, 0.0, 1.0]

[[event]]
at_s = 0.2
command = "impulse"
object = "can"
impulse_n_s = [0.0, 0.01, 0.0]
point_m = [0.2, 0.0, 0.1]

[[camera]]
name = "main"
position_m = [0.9, -0.9, 0.6]
look_at_m = [0.0, 0.0, 0.12]
fov_y_deg = 50.0
width_px = 320
height_px = 240
"#;

fn snow() -> MaterialSpec {
    MaterialSpec {
        hardening: Some(10.0),
        critical_compression: Some(0.025),
        critical_stretch: Some(0.0075),
        ..MaterialSpec::new(MaterialModel::Snow, 1.4e5, 0.2, 400.0)
    }
}

/// The builder form of [`TOML`].
fn builder() -> SceneBuilder {
    Scene::builder()
        .method(Method::MultiField)
        .duration_s(0.75)
        .frame_rate_hz(40.0)
        .grid_dx_m(0.008)
        .cfl(0.4)
        .dt_s(2e-4)
        .gravity_m_s2([0.0, -1.0, -9.0])
        .domain_m([-0.5, -0.5, -0.1], [0.5, 0.5, 0.9])
        .seed(7)
        .physics_spacing_m(0.02)
        .object(
            SceneObject::sphere("ball", [0.0, 0.0, 0.3], 0.05)
                .spacing_m(0.006)
                .color([0.9, 0.2, 0.3])
                .material(snow())
                .restitution(0.25)
                .friction(0.6)
                .velocity([1.0, 0.0, -0.5]),
        )
        .object(
            SceneObject::cuboid("table", [-0.3, -0.3, 0.0], [0.3, 0.3, 0.05])
                .kind(ObjectKind::Static)
                .material(MaterialSpec::jelly(1e7, 0.3, 800.0)),
        )
        .object(
            SceneObject::cylinder("can", [0.2, 0.0, 0.05], [0.0, 1.0, 1.0], 0.03, 0.1)
                .kind(ObjectKind::Rigid)
                .spacing_m(0.005)
                .physics_spacing_m(0.01),
        )
        .collider(ColliderSpec::plane("floor", [0.0; 3], [0.0, 0.0, 2.0]))
        .collider(
            ColliderSpec::cuboid("pusher", [-0.5, -0.1, 0.0], [-0.4, 0.1, 0.1])
                .surface(Surface::Slip)
                .friction(0.2)
                .velocity([0.5, 0.0, 0.0])
                .active_s(0.1, 0.4),
        )
        .event(EventSpec {
            at_s: 0.3,
            command: Command::SetVelocity {
                object: "ball".into(),
                velocity_m_s: [0.0, 0.0, 1.0],
                angular_velocity_rad_s: None,
            },
        })
        .event(EventSpec {
            at_s: 0.2,
            command: Command::Impulse {
                object: "can".into(),
                impulse_n_s: [0.0, 0.01, 0.0],
                point_m: Some([0.2, 0.0, 0.1]),
            },
        })
        .camera(
            CameraSpec::new("main", [0.9, -0.9, 0.6], [0.0, 0.0, 0.12])
                .fov_y_deg(50.0)
                .size_px(320, 240),
        )
}

#[test]
fn builder_scene_equals_the_toml_scene_with_the_same_content() {
    let from_toml = load_scene_str(TOML, Path::new(".")).expect("TOML scene");
    let built = builder().build().expect("builder scene");
    assert_eq!(built.simulation, from_toml.simulation);
    assert_eq!(built.objects.len(), 3);
    assert_eq!(built.objects.len(), from_toml.objects.len());
    for (b, t) in built.objects.iter().zip(&from_toml.objects) {
        assert_eq!(b.name, t.name);
        assert_eq!(b.kind, t.kind);
        assert_eq!(b.material, t.material);
        assert_eq!(
            (b.restitution, b.friction, b.velocity_m_s),
            (t.restitution, t.friction, t.velocity_m_s)
        );
        assert_eq!(b.physics_spacing_m, t.physics_spacing_m, "{}", b.name);
        assert!(!b.gaussians.is_empty(), "{}", b.name);
        // Same lattice, same jitter seed: the very same positions, bit for bit.
        assert_eq!(b.gaussians.positions, t.gaussians.positions, "{}", b.name);
        assert_eq!(b.gaussians, t.gaussians, "{}", b.name);
    }
    assert_eq!(built.colliders, from_toml.colliders);
    assert_eq!(built.events, from_toml.events);
    assert_eq!(built.cameras, from_toml.cameras);
    assert_eq!(built, from_toml);
    // The defaults the builder leaves unset are the file's: the static table takes no
    // physics spacing, the can its own, the ball the scene's; events sorted by time.
    let spacing: Vec<_> = built.objects.iter().map(|o| o.physics_spacing_m).collect();
    assert_eq!(spacing, [Some(0.02), None, Some(0.01)]);
    assert_eq!(built.events[0].at_s, 0.2);
}

#[test]
fn an_empty_builder_gives_the_empty_files_scene() {
    let built = Scene::builder().build().unwrap();
    assert_eq!(built, load_scene_str("", Path::new(".")).unwrap());
}

/// The variant and key path of a scene error.
fn what_and_where(e: SceneError) -> (&'static str, String) {
    match e {
        SceneError::Invalid { key_path, .. } => ("invalid", key_path),
        SceneError::Procedural { key_path, .. } => ("procedural", key_path),
        SceneError::Selection { key_path, .. } => ("selection", key_path),
        SceneError::Source { key_path, .. } => ("source", key_path),
        SceneError::Toml { key_path, .. } => ("toml", key_path),
        SceneError::Io { .. } => ("io", String::new()),
    }
}

const SPHERE: &str = "[[object]]\nname = \"a\"\nshape = { sphere = { center_m = [0.0, 0.0, 0.0], radius_m = 0.05 } }\nspacing_m = 0.01\n";

fn sphere() -> splatphys_core::scene::ObjectBuilder {
    SceneObject::sphere("a", [0.0; 3], 0.05).spacing_m(0.01)
}

#[test]
fn bad_values_give_the_error_the_toml_file_gives() {
    let cases: Vec<(String, SceneBuilder, (&str, &str))> = vec![
        (
            "[[object]]\nname = \"a\"\nshape = { sphere = { center_m = [0.0, 0.0, 0.0], radius_m = -0.05 } }\n".into(),
            Scene::builder().object(SceneObject::sphere("a", [0.0; 3], -0.05)),
            ("procedural", "object[0].shape"),
        ),
        (
            format!("{SPHERE}material = {{ model = \"jelly\", youngs_modulus_pa = 1e5, poisson_ratio = 0.5, density_kg_m3 = 1.0 }}\n"),
            Scene::builder().object(sphere().material(MaterialSpec::jelly(1e5, 0.5, 1.0))),
            ("invalid", "object[0].material.poisson_ratio"),
        ),
        (
            format!("{SPHERE}restitution = 1.5\n"),
            Scene::builder().object(sphere().restitution(1.5)),
            ("invalid", "object[0].restitution"),
        ),
        (
            format!("{SPHERE}physics_spacing_m = -0.01\n"),
            Scene::builder().object(sphere().physics_spacing_m(-0.01)),
            ("invalid", "object[0].physics_spacing_m"),
        ),
        (
            format!("{SPHERE}physics_spacing_m = nan\n"),
            Scene::builder().object(sphere().physics_spacing_m(f32::NAN)),
            ("invalid", "object[0].physics_spacing_m"),
        ),
        (
            format!("{SPHERE}kind = \"static\"\nphysics_spacing_m = 0.01\n"),
            Scene::builder().object(sphere().kind(ObjectKind::Static).physics_spacing_m(0.01)),
            ("invalid", "object[0].physics_spacing_m"),
        ),
        (
            format!("{SPHERE}color = [1.5, 0.0, 0.0]\n"),
            Scene::builder().object(sphere().color([1.5, 0.0, 0.0])),
            ("invalid", "object[0].color"),
        ),
        (
            format!("{SPHERE}{SPHERE}"),
            Scene::builder().object(sphere()).object(sphere()),
            ("invalid", "object[1].name"),
        ),
        (
            "[simulation]\ncfl = 0.0\n".into(),
            Scene::builder().cfl(0.0),
            ("invalid", "simulation.cfl"),
        ),
        (
            "[simulation]\nphysics_spacing_m = 0.0\n".into(),
            Scene::builder().physics_spacing_m(0.0),
            ("invalid", "simulation.physics_spacing_m"),
        ),
        (
            "[[collider]]\nname = \"c\"\nbox = { min_m = [0.0, 0.0, 0.0], max_m = [1.0, -1.0, 1.0] }\n".into(),
            Scene::builder().collider(ColliderSpec::cuboid("c", [0.0; 3], [1.0, -1.0, 1.0])),
            ("invalid", "collider[0].box"),
        ),
        (
            format!("{SPHERE}\n[[event]]\nat_s = 0.1\ncommand = \"impulse\"\nobject = \"b\"\nimpulse_n_s = [0.0, 0.0, 1.0]\n"),
            Scene::builder().object(sphere()).event(EventSpec {
                at_s: 0.1,
                command: Command::Impulse {
                    object: "b".into(),
                    impulse_n_s: [0.0, 0.0, 1.0],
                    point_m: None,
                },
            }),
            ("invalid", "event[0].object"),
        ),
        (
            "[[camera]]\nname = \"c\"\nposition_m = [1.0, 0.0, 0.0]\nlook_at_m = [0.0, 0.0, 0.0]\nfov_y_deg = 180.0\n".into(),
            Scene::builder().camera(CameraSpec::new("c", [1.0, 0.0, 0.0], [0.0; 3]).fov_y_deg(180.0)),
            ("invalid", "camera[0].fov_y_deg"),
        ),
    ];
    for (text, builder, (what, key)) in cases {
        let from_toml = what_and_where(load_scene_str(&text, Path::new(".")).unwrap_err());
        assert_eq!(from_toml, (what, key.to_string()), "TOML:\n{text}");
        let from_builder = what_and_where(builder.build().unwrap_err());
        assert_eq!(from_builder, (what, key.to_string()), "builder for {key}");
    }
}
