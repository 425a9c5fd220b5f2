//! The built-in default scene, used when `splatphys run` is given no scene file: an elastic
//! jelly sphere dropping onto a table-top box, next to a snow cube, a sticky floor and a camera.
//! All procedural (see [`crate::procedural`]), about 9 000 particles.

use super::model::*;
use crate::material::MaterialModel;
use crate::procedural::{Shape, shape_gaussians};

impl Scene {
    /// The built-in default scene (see the module docs). Deterministic.
    pub fn builtin_default() -> Scene {
        let spacing = 0.01;
        let mk = |shape: Shape, color: [f32; 3], seed: u64| {
            // Fixed, valid parameters: filling cannot fail.
            (
                shape_gaussians(&shape, spacing, color, seed).unwrap_or_default(),
                Some(shape),
            )
        };
        let n_of = |c: &crate::gaussians::GaussianCloud| vec![true; c.len()];
        let (table, table_shape) = mk(
            Shape::Box {
                min_m: [-0.25, -0.25, 0.0],
                max_m: [0.25, 0.25, 0.06],
            },
            [0.55, 0.38, 0.22],
            1,
        );
        let (jelly, jelly_shape) = mk(
            Shape::Sphere {
                center_m: [0.0, 0.0, 0.35],
                radius_m: 0.06,
            },
            [0.9, 0.2, 0.3],
            2,
        );
        let (snow, snow_shape) = mk(
            Shape::Box {
                min_m: [0.1, -0.15, 0.06],
                max_m: [0.2, -0.05, 0.16],
            },
            [0.95, 0.95, 0.98],
            3,
        );
        let objects = vec![
            SceneObject {
                name: "table".into(),
                kind: ObjectKind::Static,
                material: MaterialSpec::new(MaterialModel::FixedCorotated, 1e7, 0.3, 800.0),
                restitution: 0.3,
                friction: 0.5,
                rolling_resistance_m: 0.0,
                velocity_m_s: [0.0; 3],
                visible: n_of(&table),
                gaussians: table,
                physics_spacing_m: None,
                grid_dx_m: None,
                shape: table_shape,
                shape_rotation: glam::Quat::IDENTITY,
                surface: Surface::Separate,
            },
            SceneObject {
                name: "jelly".into(),
                kind: ObjectKind::Deformable,
                material: MaterialSpec::new(MaterialModel::FixedCorotated, 2e5, 0.3, 1000.0),
                restitution: 0.5,
                friction: 0.3,
                rolling_resistance_m: 0.0,
                velocity_m_s: [0.0; 3],
                visible: n_of(&jelly),
                gaussians: jelly,
                physics_spacing_m: None,
                grid_dx_m: None,
                shape: jelly_shape,
                shape_rotation: glam::Quat::IDENTITY,
                surface: Surface::Separate,
            },
            SceneObject {
                name: "snow".into(),
                kind: ObjectKind::Deformable,
                material: MaterialSpec::new(MaterialModel::Snow, 1.4e5, 0.2, 400.0),
                restitution: 0.1,
                friction: 0.5,
                rolling_resistance_m: 0.0,
                velocity_m_s: [0.0; 3],
                visible: n_of(&snow),
                gaussians: snow,
                physics_spacing_m: None,
                grid_dx_m: None,
                shape: snow_shape,
                shape_rotation: glam::Quat::IDENTITY,
                surface: Surface::Separate,
            },
        ];
        Scene {
            simulation: SimulationSettings {
                method: Method::Com,
                device: super::model::Device::Cpu,
                duration_s: 2.0,
                frame_rate_hz: 30.0,
                grid_dx_m: 0.01,
                cfl: 0.5,
                dt_s: None,
                force_dt: false,
                gravity_m_s2: [0.0, 0.0, -9.81],
                domain_m: Some([[-0.5, -0.5, -0.02], [0.5, 0.5, 0.8]]),
                seed: 0,
                physics_spacing_m: None,
                sleep: true,
                islands: true,
                background_collision: true,
                background_min_opacity: 0.5,
                collision_dx_m: None,
                budget_fps: None,
                contact_solver: Default::default(),
                surface_contact: Default::default(),
            },
            objects,
            background: Default::default(),
            colliders: vec![ColliderSpec {
                name: "floor".into(),
                shape: ColliderShape::Plane {
                    point_m: [0.0, 0.0, 0.0],
                    normal: [0.0, 0.0, 1.0],
                },
                surface: Surface::Sticky,
                friction: 0.0,
                velocity_m_s: [0.0; 3],
                active_s: None,
            }],
            events: Vec::new(),
            cameras: vec![CameraSpec {
                name: "main".into(),
                position_m: [0.9, -0.9, 0.6],
                look_at_m: [0.0, 0.0, 0.12],
                up: [0.0, 0.0, 1.0],
                fov_y_deg: 45.0,
                width_px: 640,
                height_px: 480,
            }],
            warnings: Vec::new(),
        }
    }
}
