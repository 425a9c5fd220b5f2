//! A material edit changes only the fields it names: the wire's edit, a scene event and the
//! server all go through `World::apply`.

use splatphys_core::material::{MaterialModel, MaterialSpec};
use splatphys_core::scene::{Command, Scene, SceneObject};
use splatphys_core::world::World;
use splatphys_types::MaterialEdit;

/// A snow ball whose model parameters are all off their defaults.
fn snow_world() -> World {
    let mut snow = MaterialSpec::new(MaterialModel::Snow, 1.4e5, 0.2, 400.0);
    snow.hardening = Some(7.0);
    snow.critical_compression = Some(3.0e-2);
    snow.critical_stretch = Some(6.0e-3);
    let scene = Scene::builder()
        .duration_s(0.1)
        .object(
            SceneObject::sphere("ball", [0.0, 0.0, 0.2], 0.03)
                .spacing_m(0.01)
                .material(snow),
        )
        .build()
        .unwrap();
    World::from_scene(&scene).unwrap()
}

#[test]
fn editing_youngs_modulus_of_snow_keeps_its_model_parameters() {
    let mut world = snow_world();
    let before = world.bodies()[0].material().spec();
    world
        .apply(&Command::EditMaterial {
            object: 0,
            edit: MaterialEdit {
                youngs_modulus_pa: Some(2.0e5),
                ..MaterialEdit::default()
            },
        })
        .unwrap();
    let after = world.bodies()[0].material().spec();
    assert_eq!(after.model, MaterialModel::Snow);
    assert_eq!(after.youngs_modulus_pa, 2.0e5);
    // The solver keeps f32: compare what it holds.
    assert_eq!(after.hardening.map(|v| v as f32), Some(7.0));
    assert_eq!(after.critical_compression.map(|v| v as f32), Some(3.0e-2));
    assert_eq!(after.critical_stretch.map(|v| v as f32), Some(6.0e-3));
    assert_eq!(after.poisson_ratio, before.poisson_ratio);
    assert_eq!(after.density_kg_m3, before.density_kg_m3);
}

#[test]
fn an_edit_of_contact_coefficients_leaves_the_material_alone() {
    let mut world = snow_world();
    let before = world.bodies()[0].material().clone();
    world
        .apply(&Command::EditMaterial {
            object: 0,
            edit: MaterialEdit {
                restitution: Some(0.25),
                friction: Some(0.6),
                ..MaterialEdit::default()
            },
        })
        .unwrap();
    assert_eq!(world.bodies()[0].material(), &before);
    assert_eq!(world.bodies()[0].restitution(), 0.25);
    assert_eq!(world.bodies()[0].friction(), 0.6);
}
