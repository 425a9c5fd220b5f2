//! Finding a GPU and opening a device on it.

use std::sync::{Arc, OnceLock};

use crate::GpuError;
use crate::mpm::kernels::Kernels;

/// An open wgpu device and its queue; a clone shares them, and the kernels compiled on it.
#[derive(Debug, Clone)]
pub struct GpuContext {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// What the adapter says it is.
    pub info: wgpu::AdapterInfo,
    /// The MPM kernels, compiled once (when a `GpuBackend` opens, or at the first upload) and
    /// shared by every upload: every object on the device, and an object uploaded again
    /// (compiling them took 0.2 s of a 0.45 s upload on lavapipe, 0.74 s on an H200 whose
    /// driver had not cached them).
    kernels: Arc<OnceLock<Arc<Kernels>>>,
}

impl GpuContext {
    /// Opens the highest-performance adapter wgpu finds (Vulkan on Linux, Metal on macOS,
    /// DirectX 12 on Windows; `WGPU_BACKEND` and `WGPU_ADAPTER_NAME` choose another), with the
    /// adapter's own limits.
    ///
    /// # Errors
    /// [`GpuError::NoAdapter`] when there is none (tests skip then), [`GpuError::Device`] when
    /// it refuses a device.
    pub fn new() -> Result<Self, GpuError> {
        Self::with_limits(|limits| limits)
    }

    /// [`GpuContext::new`] with the limits `adjust` makes of the adapter's own (lower ones, to
    /// see how the GPU path meets a smaller device).
    ///
    /// # Errors
    /// As [`GpuContext::new`].
    pub fn with_limits(
        adjust: impl FnOnce(wgpu::Limits) -> wgpu::Limits,
    ) -> Result<Self, GpuError> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            ..Default::default()
        }))
        .map_err(|_| GpuError::NoAdapter)?;
        let info = adapter.get_info();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("splatphys-gpu"),
            // Timestamps, where there are, for `GpuMpm::profile`.
            required_features: adapter.features() & wgpu::Features::TIMESTAMP_QUERY,
            required_limits: adjust(adapter.limits()),
            memory_hints: wgpu::MemoryHints::Performance,
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device {
            adapter: info.name.clone(),
            message: e.to_string(),
        })?;
        Ok(Self {
            device,
            queue,
            info,
            kernels: Arc::default(),
        })
    }

    /// The MPM kernels on this device, compiled on the first call.
    pub(crate) fn kernels(&self) -> Arc<Kernels> {
        Arc::clone(
            self.kernels
                .get_or_init(|| Arc::new(Kernels::new(&self.device))),
        )
    }

    /// The adapter's name and backend, e.g. `"NVIDIA H100 (Vulkan)"`.
    pub fn name(&self) -> String {
        format!("{} ({:?})", self.info.name, self.info.backend)
    }
}
