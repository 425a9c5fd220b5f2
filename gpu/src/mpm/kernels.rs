//! The compiled kernels of `mpm.wgsl`, `plastic.wgsl`, `sums.wgsl` and `run.wgsl` and their
//! bind group layout, one set per device (`GpuContext::kernels`), shared by every
//! [`super::GpuMpm`] on it. The parameters are bound as a read-only storage buffer (`mpm.wgsl`
//! says why): bound as a uniform buffer, lavapipe compiled P2G again at every dispatch and the
//! test binary peaked at 3.6 GB, against 0.17 GB now.

/// The layout of the shader's bindings and a pipeline per entry point.
#[derive(Debug)]
pub struct Kernels {
    pub(crate) layout: wgpu::BindGroupLayout,
    pub(crate) p2g: wgpu::ComputePipeline,
    pub(crate) grid_update: wgpu::ComputePipeline,
    pub(crate) g2p: wgpu::ComputePipeline,
    pub(crate) tick: wgpu::ComputePipeline,
    pub(crate) moments_per_group: wgpu::ComputePipeline,
    pub(crate) moments_total: wgpu::ComputePipeline,
    pub(crate) rigid_field: wgpu::ComputePipeline,
    pub(crate) run_check: wgpu::ComputePipeline,
}

/// Storage buffers the kernels bind (bindings 0 to 10 of [`Kernels::layout`]): a device must
/// allow this many per shader stage.
pub(crate) const STORAGE_BUFFERS: u32 = 11;

fn storage(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

impl Kernels {
    /// Compiles the shaders on `device`.
    pub(crate) fn new(device: &wgpu::Device) -> Self {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("mpm"),
            entries: &[
                storage(0, true),
                storage(1, false),
                storage(2, false),
                storage(3, true),
                storage(4, true),
                storage(5, true),
                storage(6, false),
                storage(7, false),
                storage(8, false),
                storage(9, false),
                storage(10, false),
            ],
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("mpm.wgsl"),
            source: wgpu::ShaderSource::Wgsl(
                concat!(
                    include_str!("../mpm.wgsl"),
                    include_str!("../plastic.wgsl"),
                    include_str!("../sums.wgsl"),
                    include_str!("../run.wgsl")
                )
                .into(),
            ),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("mpm"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = |entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        Self {
            p2g: pipeline("p2g"),
            grid_update: pipeline("grid_update"),
            g2p: pipeline("g2p"),
            tick: pipeline("tick"),
            moments_per_group: pipeline("moments_per_group"),
            moments_total: pipeline("moments_total"),
            rigid_field: pipeline("rigid_field"),
            run_check: pipeline("run_check"),
            layout,
        }
    }
}
