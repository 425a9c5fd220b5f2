//! Commands that would make the next step non-finite or stall it are refused with a reason;
//! ordinary ones still apply (release build).

use splatphys_core::material::MaterialSpec;
use splatphys_core::scene::{ObjectKind, Scene, SceneObject};
use splatphys_core::world::{World, WorldError};
use splatphys_types::{Command, MaterialEdit};

fn ball(kind: ObjectKind) -> World {
    let scene = Scene::builder()
        .grid_dx_m(0.01)
        .duration_s(0.5)
        .gravity_m_s2([0.0; 3])
        .object(
            SceneObject::sphere("ball", [0.0, 0.0, 0.2], 0.05)
                .kind(kind)
                .material(MaterialSpec::jelly(2e5, 0.3, 1000.0)),
        )
        .build()
        .expect("scene");
    World::from_scene(&scene).expect("world")
}

fn refused(r: Result<(), WorldError>, needle: &str) {
    match r {
        Err(WorldError::Refused { reason, .. }) => {
            assert!(
                reason.contains(needle),
                "reason {reason:?} lacks {needle:?}"
            )
        }
        other => panic!("expected a refusal naming {needle:?}, got {other:?}"),
    }
}

#[test]
fn an_absurd_youngs_modulus_is_refused_and_the_world_keeps_stepping() {
    let mut w = ball(ObjectKind::Deformable);
    for e in [1e39, 1e14] {
        let edit = MaterialEdit {
            youngs_modulus_pa: Some(e),
            ..Default::default()
        };
        refused(
            w.apply(&Command::EditMaterial { object: 0, edit }),
            "youngs_modulus_pa",
        );
    }
    // Below the modulus cap, but c_p ≈ 8e4 m/s asks for substeps of ~6e-8 s: about 3x the
    // default particle-substep budget for this ~500-particle ball at 30 frames/s.
    let edit = MaterialEdit {
        youngs_modulus_pa: Some(5e12),
        ..Default::default()
    };
    refused(
        w.apply(&Command::EditMaterial { object: 0, edit }),
        "particle-substeps per frame",
    );
    // An ordinary edit applies.
    let edit = MaterialEdit {
        youngs_modulus_pa: Some(5e5),
        ..Default::default()
    };
    w.apply(&Command::EditMaterial { object: 0, edit })
        .expect("accepted");
    w.advance_frame().expect("steps");
}

#[test]
fn an_impulse_with_a_far_lever_arm_is_refused_by_the_speed_it_would_cause() {
    for kind in [ObjectKind::Deformable, ObjectKind::Rigid] {
        let mut w = ball(kind);
        // The millimetre typo: the point 1000 m away spins the 1 kg ball far beyond 100 m/s.
        refused(
            w.apply(&Command::Impulse {
                object: 0,
                impulse_n_s: [1000.0, 0.0, 0.0],
                point_m: Some([1000.0, 0.0, 0.0]),
            }),
            "m/s",
        );
        // A 1 N s push at the COM (about 2 m/s on this ~0.5 kg ball) applies.
        w.apply(&Command::Impulse {
            object: 0,
            impulse_n_s: [1.0, 0.0, 0.0],
            point_m: None,
        })
        .expect("accepted");
        refused(
            w.apply(&Command::SetVelocity {
                object: 0,
                velocity_m_s: [500.0, 0.0, 0.0],
                angular_velocity_rad_s: None,
            }),
            "limit",
        );
        w.advance_frame().expect("steps");
        assert!(
            w.objects()[0].velocity_m_s[0] > 1.0,
            "{kind:?}: the push did not apply"
        );
    }
}
