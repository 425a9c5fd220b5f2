//! The world's device interface (`World::set_device`) with a stand-in device that runs the CPU
//! solver: where particles live between substeps, the report the COM layer reads, the rigid
//! field of the restitution law, commands and the hand-over to the CPU near a solid are checked
//! on any machine (the GPU's own checks, `splatphys-gpu/tests/gpu_world.rs`, need an adapter).
//! A world on it must follow the CPU world exactly (the same solver; measured 0 apart).

use std::sync::Arc;

use glam::{DVec3, Mat3A, Vec3A};
use splatphys_core::material::MaterialSpec;
use splatphys_core::mpm::{MpmSystem, Particles, SubstepInput};
use splatphys_core::scene::{ColliderSpec, Command, Device, ObjectKind, Scene, SceneObject};
use splatphys_core::world::measure::measure_bounds;
use splatphys_core::world::{
    BodyState, DeviceBackend, DeviceError, DeviceMpm, DeviceReport, World, measure,
};

/// A device that keeps the particles in its own memory and steps them with the CPU solver.
#[derive(Debug)]
struct CpuStandIn;

#[derive(Debug)]
struct OnStandIn {
    sys: MpmSystem,
}

impl DeviceBackend for CpuStandIn {
    fn name(&self) -> String {
        "CPU stand-in".into()
    }

    fn upload(
        &self,
        system: &MpmSystem,
        _extent_m: (Vec3A, Vec3A),
    ) -> Result<Box<dyn DeviceMpm>, DeviceError> {
        Ok(Box::new(OnStandIn {
            sys: system.clone(),
        }))
    }
}

impl OnStandIn {
    fn state(&self) -> (BodyState, f32) {
        let (p, dx) = (&self.sys.particles, self.sys.solver.dx_m);
        let mut s = measure(p, dx);
        let b = measure_bounds(p, dx);
        (s.aabb_m, s.radius_m) = (b.aabb_m, b.radius_m);
        let speed = p.v.iter().map(|v| v.length()).fold(0.0, f32::max);
        (s, speed)
    }
}

impl DeviceMpm for OnStandIn {
    fn write_particles(&mut self, particles: &Particles) -> Result<(), DeviceError> {
        self.sys.particles = particles.clone();
        Ok(())
    }

    fn substep(
        &mut self,
        dt_s: f32,
        time_s: f64,
        _reference_m: Vec3A,
    ) -> Result<DeviceReport, DeviceError> {
        let input = SubstepInput {
            materials: &self.sys.materials,
            colliders: &self.sys.colliders,
            gravity_m_s2: self.sys.gravity_m_s2,
            dt_s,
            time_s,
            barrier: false,
        };
        self.sys
            .solver
            .substep(&mut self.sys.particles, &input)
            .map_err(|e| DeviceError::Failed(e.to_string()))?;
        let (state, max_speed_m_s) = self.state();
        Ok(DeviceReport {
            state,
            max_speed_m_s,
            min_plastic: self
                .sys
                .particles
                .plastic
                .iter()
                .copied()
                .fold(f32::MAX, f32::min),
            impulses_n_s: self.sys.solver.collider_impulses_n_s().to_vec(),
            friction_n_s: self.sys.solver.collider_friction_n_s().to_vec(),
            nodes: self.sys.solver.collider_nodes().to_vec(),
        })
    }

    fn moments(&mut self, _reference_m: Vec3A) -> Result<(BodyState, f32), DeviceError> {
        Ok(self.state())
    }

    fn recentre(&mut self, _extent_m: (Vec3A, Vec3A)) -> bool {
        true
    }

    fn rigid_field(&mut self, dv: Vec3A, dw: Vec3A, about: Vec3A) {
        let skew = Mat3A::from_cols(
            Vec3A::new(0.0, dw.z, -dw.y),
            Vec3A::new(-dw.z, 0.0, dw.x),
            Vec3A::new(dw.y, -dw.x, 0.0),
        );
        let p = &mut self.sys.particles;
        for i in 0..p.len() {
            p.v[i] += dv + dw.cross(p.x[i] - about);
            p.c[i] += skew;
        }
    }

    fn read_particles(&mut self, into: &mut Particles) -> Result<(), DeviceError> {
        *into = self.sys.particles.clone();
        Ok(())
    }
}

/// A jelly ball (R 4 cm, e = 0.5) dropped onto a plane on a 1 cm grid, thrown sideways, and,
/// when `slab`, a static slab in its way.
fn scene(slab: bool) -> Scene {
    let mut s = Scene::builder()
        .grid_dx_m(0.01)
        .duration_s(0.5)
        .frame_rate_hz(30.0)
        .sleep(false)
        .device(Device::Gpu)
        .collider(ColliderSpec::plane(
            "floor",
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 1.0],
        ))
        .object(
            SceneObject::sphere("ball", [0.0, 0.0, 0.1], 0.04)
                .spacing_m(0.005)
                .material(MaterialSpec::jelly(2e5, 0.3, 1000.0))
                .restitution(0.5)
                .friction(0.3)
                .rolling_resistance_m(0.002)
                .velocity([0.3, 0.0, 0.0]),
        );
    if slab {
        s = s.object(
            SceneObject::cuboid("slab", [0.1, -0.1, 0.0], [0.2, 0.1, 0.05])
                .kind(ObjectKind::Static)
                .friction(0.3),
        );
    }
    s.build().expect("scene")
}

/// The ball's COM and velocity after every frame, with an impulse after frame 6.
fn run(mut w: World) -> (Vec<DVec3>, Vec<DVec3>, World) {
    let push = Command::Impulse {
        object: 0,
        impulse_n_s: [0.0, 0.05, 0.0],
        point_m: None,
    };
    let (mut com, mut vel) = (Vec::new(), Vec::new());
    while !w.is_finished() {
        w.advance_frame().expect("frame");
        let o = &w.objects()[0];
        com.push(DVec3::from(o.com_m));
        vel.push(DVec3::from(o.velocity_m_s));
        if w.frame() == 6 {
            w.apply(&push).expect("command");
        }
    }
    (com, vel, w)
}

fn worst(a: &[DVec3], b: &[DVec3]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(a, b)| (*a - *b).length())
        .fold(0.0, f64::max)
}

#[test]
fn a_world_on_a_device_follows_the_cpu_world_through_bounces_a_command_and_a_hand_over() {
    for slab in [false, true] {
        let cpu = World::from_scene(&scene(slab)).expect("world");
        let mut device = cpu.clone();
        device.set_device(Some(Arc::new(CpuStandIn)));
        let (com_c, vel_c, _) = run(cpu);
        let (com_d, vel_d, w) = run(device);
        let b = &w.bodies()[0];
        let (on, all) = (b.device_substeps(), b.stats().substeps_taken);
        let (dc, dv) = (worst(&com_c, &com_d), worst(&vel_c, &vel_d));
        println!(
            "slab {slab}: {on} of {all} substeps on the device; COM {dc:.2e} m, v {dv:.2e} m/s apart"
        );
        // The stand-in runs the CPU's own solver: measured bit-identical (0 apart).
        assert!(dc < 1e-9 && dv < 1e-9, "slab {slab}: {dc} m, {dv} m/s");
        // It bounced (the restitution law applied its field on the device) and took the push.
        assert!(vel_d.iter().any(|v| v.z > 0.1), "{vel_d:?}");
        assert!(vel_d[7].y > 0.1, "{:?}", vel_d[7]);
        if slab {
            assert!(on > 0 && on < all, "{on} of {all}");
        } else {
            assert_eq!(on, all);
        }
    }
}
