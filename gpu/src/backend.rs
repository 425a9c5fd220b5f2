//! [`GpuBackend`]: the GPU as the device a `World` runs deformable objects' MPM on
//! (`splatphys_core::world::device`).

use glam::Vec3A;
use splatphys_core::mpm::{MpmSystem, Particles};
use splatphys_core::world::{
    BodyState, DeviceBackend, DeviceError, DeviceMpm, DeviceReport, DeviceRun, RunPlan,
};

use crate::{GpuContext, GpuError, GpuMpm};

/// A GPU for a `World` ([`splatphys_core::world::World::set_device`]); every object on it shares
/// its device and compiled kernels (each has its own buffers, `GpuMpm`).
#[derive(Debug, Clone)]
pub struct GpuBackend {
    ctx: GpuContext,
}

impl GpuBackend {
    /// The backend on `ctx`'s device, with the MPM kernels compiled on it now, so the first
    /// object uploaded does not wait for them mid-run (0.74 s on an NVIDIA H200 whose driver
    /// had not cached them, 0.2 s on lavapipe).
    pub fn new(ctx: GpuContext) -> Self {
        ctx.kernels();
        Self { ctx }
    }

    /// The backend on the first adapter wgpu finds ([`GpuContext::new`]).
    ///
    /// # Errors
    /// As [`GpuContext::new`].
    pub fn open() -> Result<Self, GpuError> {
        GpuContext::new().map(Self::new)
    }

    /// Whether the adapter is software on the CPU (Mesa's lavapipe): correct, and slower than
    /// the CPU path.
    pub fn is_software(&self) -> bool {
        self.ctx.info.device_type == wgpu::DeviceType::Cpu
    }
}

impl From<GpuError> for DeviceError {
    fn from(e: GpuError) -> Self {
        match e {
            GpuError::Unsupported { what } => DeviceError::Unsupported(what),
            other => DeviceError::Failed(other.to_string()),
        }
    }
}

impl DeviceBackend for GpuBackend {
    fn name(&self) -> String {
        self.ctx.name()
    }

    fn upload(
        &self,
        system: &MpmSystem,
        extent_m: (Vec3A, Vec3A),
    ) -> Result<Box<dyn DeviceMpm>, DeviceError> {
        let mpm = GpuMpm::new_over(self.ctx.clone(), system, Some(extent_m))?;
        Ok(Box::new(mpm))
    }
}

impl DeviceMpm for GpuMpm {
    fn write_particles(&mut self, particles: &Particles) -> Result<(), DeviceError> {
        Ok(GpuMpm::write_particles(self, particles)?)
    }

    fn substep(
        &mut self,
        dt_s: f32,
        time_s: f64,
        reference_m: Vec3A,
    ) -> Result<DeviceReport, DeviceError> {
        self.time_s = time_s;
        self.set_reference(reference_m);
        // Two submissions: the GPU runs the substep while the report is recorded (one
        // submission of both was 10-15 % slower on an H200 for the captured donut).
        GpuMpm::substep(self, dt_s);
        Ok(self.report(reference_m)?)
    }

    fn moments(&mut self, reference_m: Vec3A) -> Result<(BodyState, f32), DeviceError> {
        Ok(GpuMpm::moments(self, reference_m)?)
    }

    fn recentre(&mut self, extent_m: (Vec3A, Vec3A)) -> bool {
        GpuMpm::recentre(self, extent_m)
    }

    fn regrid(&mut self, extent_m: (Vec3A, Vec3A)) -> bool {
        GpuMpm::regrid(self, extent_m)
    }

    fn rigid_field(&mut self, dv: Vec3A, dw: Vec3A, about: Vec3A) {
        GpuMpm::rigid_field(self, dv, dw, about);
    }

    fn read_particles(&mut self, into: &mut Particles) -> Result<(), DeviceError> {
        Ok(GpuMpm::read_particles(self, into)?)
    }

    fn run(&mut self, plan: &RunPlan) -> Result<Option<DeviceRun>, DeviceError> {
        Ok(GpuMpm::run(self, plan)?)
    }
}
