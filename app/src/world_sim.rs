//! The real simulation behind the server: sim-core's [`World`] as a [`Simulation`].
//!
//! Frames are written straight into the loaned shared-memory slice: sim-core's
//! `GaussianState` has the exact layout of [`FrameGaussian`], so the slice is reinterpreted in
//! place with bytemuck and filled in parallel. Every field's offset, the size and the alignment
//! are asserted below at compile time, so swapping two same-size fields does not compile.
//! Background Gaussians (claimed by no object) carry `object_id = u32::MAX`.

use splatphys_core::kinematics::GaussianState;
use splatphys_core::scene::Scene;
use splatphys_core::world::{World, WorldError};

use splatphys_ipc::command::Command;
use splatphys_ipc::simulation::{Advance, Simulation, SimulationError};
use splatphys_ipc::wire::{FrameGaussian, ObjectState, SceneGaussian};

const _: () = {
    use std::mem::offset_of;
    assert!(size_of::<GaussianState>() == size_of::<FrameGaussian>());
    assert!(align_of::<GaussianState>() == align_of::<FrameGaussian>());
    assert!(offset_of!(GaussianState, position_m) == offset_of!(FrameGaussian, position_m));
    assert!(offset_of!(GaussianState, covariance_m2) == offset_of!(FrameGaussian, covariance_m2));
    assert!(offset_of!(GaussianState, rotation_wxyz) == offset_of!(FrameGaussian, rotation_wxyz));
};

pub use splatphys_ipc::wire::BACKGROUND_OBJECT_ID as BACKGROUND_OBJECT;

/// A [`World`] served over iceoryx2.
#[derive(Debug)]
pub struct WorldSim {
    /// The simulated world.
    pub world: World,
    name: String,
    sh_degree: u32,
    substeps: u64,
    /// The world and the substep count at the last published frame (restored after a failed
    /// step). Cloned into with `clone_from`, so its buffers are reused frame after frame; the
    /// scene's static data is shared, not copied.
    saved: Option<(World, u64)>,
}

impl WorldSim {
    /// Builds the world of `scene` under `name`.
    ///
    /// # Errors
    /// [`WorldError`] as [`World::from_scene`].
    pub fn new(name: &str, scene: &Scene) -> Result<Self, WorldError> {
        let world = World::from_scene(scene)?;
        let sh_degree = world
            .bodies()
            .iter()
            .map(|b| b.gaussians().sh_degree)
            .chain(std::iter::once(world.background().sh_degree))
            .max()
            .unwrap_or(0) as u32;
        Ok(Self {
            world,
            name: name.to_string(),
            sh_degree,
            substeps: 0,
            saved: None,
        })
    }
}

impl Simulation for WorldSim {
    fn scene_name(&self) -> &str {
        &self.name
    }
    fn scene_generation(&self) -> u32 {
        self.world.generation()
    }
    fn gaussian_count(&self) -> usize {
        self.world.published_count()
    }
    fn object_count(&self) -> usize {
        self.world.bodies().len()
    }
    fn object_name(&self, id: u32) -> Option<&str> {
        self.world.bodies().get(id as usize).map(|b| b.name())
    }
    fn sh_degree(&self) -> u32 {
        self.sh_degree
    }
    fn frame_dt_s(&self) -> f64 {
        self.world.frame_dt_s()
    }
    fn step(&self) -> u64 {
        self.world.frame()
    }
    fn time_s(&self) -> f64 {
        self.world.time_s()
    }
    fn substeps(&self) -> u64 {
        self.substeps
    }

    fn write_scene(&self, out: &mut [SceneGaussian]) {
        let mut k = 0;
        self.world.for_each_published(|object, cloud, i| {
            let Some(g) = out.get_mut(k) else { return };
            k += 1;
            let mut sh = [0.0f32; 48];
            for (c, rgb) in cloud.sh_coefficients(i).iter().take(16).enumerate() {
                sh[3 * c..3 * c + 3].copy_from_slice(rgb);
            }
            let q = cloud.rotation(i);
            *g = SceneGaussian {
                sh,
                opacity: cloud.opacity(i),
                scale_m: cloud.scale(i).to_array(),
                rotation_wxyz: [q.w, q.x, q.y, q.z],
                object_id: object.unwrap_or(BACKGROUND_OBJECT),
            };
        });
    }

    fn advance(
        &mut self,
        keep_going: &mut dyn FnMut() -> bool,
    ) -> Result<Advance, SimulationError> {
        let step = self.world.frame() + 1;
        let n = self
            .world
            .advance_frame_with(keep_going)
            .map_err(|e| match e {
                WorldError::Interrupted { .. } => SimulationError::Interrupted { step },
                e => SimulationError::Failed {
                    step,
                    reason: e.to_string(),
                },
            })?;
        self.substeps += n;
        Ok(Advance {
            steps: 1,
            substeps: n,
            time_s: self.world.time_s(),
        })
    }

    fn checkpoint(&mut self) {
        match &mut self.saved {
            Some((world, substeps)) => {
                world.clone_from(&self.world);
                *substeps = self.substeps;
            }
            None => self.saved = Some((self.world.clone(), self.substeps)),
        }
    }

    fn restore_checkpoint(&mut self) -> bool {
        let Some((world, substeps)) = &self.saved else {
            return false;
        };
        self.world.clone_from(world);
        self.substeps = *substeps;
        true
    }

    fn write_frame(&self, out: &mut [FrameGaussian]) {
        let states: &mut [GaussianState] = bytemuck::cast_slice_mut(out);
        self.world.write_gaussians(states);
    }

    fn write_objects(&self, out: &mut [ObjectState]) {
        for (o, s) in out.iter_mut().zip(self.world.objects()) {
            *o = ObjectState {
                id: s.id,
                contact_count: s.contacts,
                position_m: s.com_m.map(|v| v as f32),
                velocity_m_s: s.velocity_m_s.map(|v| v as f32),
                orientation_wxyz: s.orientation_wxyz,
                angular_velocity_rad_s: s.angular_velocity_rad_s.map(|v| v as f32),
                mass_kg: s.mass_kg as f32,
                contact_force_n: s.contact_force_n.map(|v| v as f32),
                contact_torque_n_m: s.contact_torque_n_m.map(|v| v as f32),
            };
        }
    }

    fn apply(&mut self, command: &Command) -> Result<u64, String> {
        let at = self.world.frame() + 1;
        self.world.apply(command).map_err(|e| e.to_string())?;
        if *command == Command::Reset {
            self.substeps = 0;
            return Ok(self.world.frame());
        }
        Ok(at)
    }

    fn is_finished(&self) -> bool {
        self.world.is_finished()
    }
}

/// Builds the world of `scene` as a boxed [`Simulation`] (what `bench ipc` serves).
///
/// # Errors
/// [`WorldError`] as [`World::from_scene`].
pub fn boxed(name: &str, scene: &Scene) -> anyhow::Result<Box<dyn Simulation + Send>> {
    Ok(Box::new(WorldSim::new(name, scene)?))
}
