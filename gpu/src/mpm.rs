//! [`GpuMpm`]: an [`MpmSystem`]'s particles on the GPU, advanced substep by substep by the
//! kernels of `mpm.wgsl` (P2G, grid update, G2P) on a dense grid over the system's domain bound.
//! The particles stay on the GPU between substeps; [`GpuMpm::read_particles`] brings them back
//! and [`GpuMpm::check`] reads the failure count and the largest speed (each is one wait for the
//! GPU: call them once per frame, not per substep).

use bytemuck::{Pod, Zeroable};
use glam::Vec3A;
use splatphys_core::collider::{Shape, Surface};
use splatphys_core::material::Material;
use splatphys_core::mpm::MpmSystem;
use wgpu::util::DeviceExt;

use crate::{GpuContext, GpuError};

pub(crate) mod kernels;
mod moments;
mod profile;
mod readback;
mod run;
mod upload;

use kernels::Kernels;
pub use moments::ColliderSums;
pub use profile::{Profile, RoundTrip};

/// f32 values per set of moments in the shader's `moments` buffer (`sums.wgsl`).
const MOMENTS: u32 = 28;
/// u32 words per collider after the nodes in the shader's `grid_sum` (its normal and friction
/// impulses: three 64-bit sums each; the nodes with mass inside it).
pub(crate) const COLLIDER_WORDS: u64 = 13;
/// u32 words per grid node in the shader's `grid_sum` (the mass and each momentum component's
/// positive and negative parts as sums of two words, and the node gap).
pub(crate) const NODE_WORDS: u64 = 15;
/// Work items per workgroup (`@workgroup_size(64)` in the shader).
const WORKGROUP: u32 = 64;
/// Workgroups per dispatch row (the per-dimension limit); the shader's `ROW`.
const ROW: u32 = 65_535;
/// At most this many workgroups sum an object's moments (`sums.wgsl`), each over every
/// (groups × 64)-th particle: the second pass, one workgroup, then reads at most this many.
const MOMENT_GROUPS: u32 = 1024;
/// Substeps per command buffer that [`GpuMpm::substeps`] submits.
const SUBMIT_BATCH: u32 = 64;
/// How long a read-back polls the device before it blocks (µs), unless
/// `SPLATPHYS_GPU_SPIN_US` says otherwise.
const SPIN_WAIT_US: u64 = 1000;

/// [`SPIN_WAIT_US`], or `SPLATPHYS_GPU_SPIN_US`.
fn spin_wait() -> std::time::Duration {
    let us = std::env::var("SPLATPHYS_GPU_SPIN_US")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(SPIN_WAIT_US);
    std::time::Duration::from_micros(us)
}

/// The speed (m/s) at which the heaviest particle's momentum is 2^16 units of P2G's fixed-point
/// sums for a million particles ([`fixed_point_scales`]).
const REFERENCE_SPEED_M_S: f32 = 1.0;

/// The shader's `Params` (a read-only storage buffer, `mpm.wgsl` says why).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct Params {
    grid_dims: [i32; 3],
    n_particles: u32,
    grid_origin: [f32; 3],
    dx: f32,
    gravity: [f32; 3],
    dt: f32,
    inv_dx: f32,
    n_colliders: u32,
    scale_m: f32,
    scale_p: f32,
    inv_scale_m: f32,
    inv_scale_p: f32,
    n_gated: u32,
    t0: f32,
    reference: [f32; 3],
    n_groups: u32,
    field_dv: [f32; 3],
    _pad0: f32,
    field_dw: [f32; 3],
    /// A run of substeps (`mpm/run.rs`, the shader's `run_check`): it halts after a substep
    /// whose largest particle speed passes `speed_limit` (m/s), in which snow's Jp fell below
    /// `plastic_floor`, or in which a collider's contact opened (its impulse past `opens_at`,
    /// in the momentum's fixed-point units) or closed (bit c of `open_mask`: collider c's is
    /// open), or, with bit 0 of `run_flags`, that touched any collider.
    speed_limit: f32,
    plastic_floor: f32,
    opens_at: f32,
    open_mask: u32,
    run_flags: u32,
}

/// The shader's `Material`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct GpuMaterial {
    mu: f32,
    lambda: f32,
    eta: f32,
    model: u32,
    /// The model's parameters (`plastic.wgsl`).
    p: [f32; 4],
}

/// A collider's `gated`: its nodes take the rule only where material reaches the surface
/// ([`splatphys_core::collider::Collider::is_gated`]).
const GAPS_GATED: u32 = 1;
/// A collider's `gated`: it holds every node inside it, but is a box thin enough that the grid
/// reads which side of it the material lies on
/// ([`splatphys_core::collider::Collider::takes_sides`]).
const GAPS_SIDES: u32 = 2;

/// The shader's `Collider`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct GpuCollider {
    kind: u32,
    surface: u32,
    friction: f32,
    /// 0, [`GAPS_GATED`] or [`GAPS_SIDES`]: what the node gaps are read for.
    gated: u32,
    a: [f32; 4],
    b: [f32; 4],
    /// Velocity (m/s) and, in w, 1 for a moving collider with an active window.
    velocity: [f32; 4],
    /// Active window start and end (s).
    window: [f32; 4],
}

fn unsupported(what: impl Into<String>) -> GpuError {
    GpuError::Unsupported { what: what.into() }
}

/// The shader's `MODEL_*`.
const MODEL_JELLY: u32 = 0;
const MODEL_NEO_HOOKEAN: u32 = 1;
const MODEL_SNOW: u32 = 2;
const MODEL_SAND: u32 = 3;
const MODEL_VON_MISES: u32 = 4;

/// P2G's fixed-point scales for mass and momentum (units per kg and per kg m/s), powers of two,
/// for `n` particles the heaviest of which weighs `largest_mass_kg`.
///
/// A node's sum is two 32-bit words: one sums every term's part below 2^16 (rounded up or down
/// with a dither, so without bias), the other the rest (`add_magnitude` in the shader). Neither
/// carries while a node takes fewer than 2^16 terms in a substep (65,536 particles within 1.5
/// cells of it: about 2,400 a cell, where MPM uses 8 to 27) and its sum stays below 2^48. For a
/// million particles or more the scales put the heaviest particle's mass, and its momentum at
/// [`REFERENCE_SPEED_M_S`], at 2^16 units: a mass term is then always one atomic add (a weight
/// is at most 0.42) and a momentum term one below about 2.4 times that speed. A dithered term is
/// off by a fraction of a unit, at random, so an object's momentum wanders by about
/// sqrt(terms) units a substep, relatively more for fewer particles: below a million the units
/// are finer by half a bit for every bit fewer of particles (at most 2^8 finer), which keeps
/// the wander relative to the object's momentum at the million-particle level, for more atomic
/// adds where there are few particles to add.
fn fixed_point_scales(n: u32, largest_mass_kg: f32) -> (f32, f32) {
    let finer = ((21 - n.max(1).next_power_of_two().ilog2() as i32).max(0) / 2).min(8);
    let exponent = f64::from(largest_mass_kg).max(1e-30).log2().ceil() as i32;
    let scale = 2f32.powi((16 + finer - exponent).clamp(-100, 100));
    (scale, scale / REFERENCE_SPEED_M_S)
}

/// The GPU form of `materials`: every model of splatphys-core runs there.
fn materials(materials: &[Material]) -> Vec<GpuMaterial> {
    materials
        .iter()
        .map(|m| {
            let (model, p) = match m {
                Material::Jelly(_) => (MODEL_JELLY, [0.0; 4]),
                Material::NeoHookean(_) => (MODEL_NEO_HOOKEAN, [0.0; 4]),
                Material::Snow(s) => (MODEL_SNOW, [s.hardening, s.theta_c, s.theta_s, 0.0]),
                Material::Sand(s) => (MODEL_SAND, [s.alpha(), 0.0, 0.0, 0.0]),
                Material::Metal(m) => (MODEL_VON_MISES, [m.yield_stress_pa, 0.0, 0.0, 0.0]),
                Material::Plasticine(p) => {
                    (MODEL_VON_MISES, [p.yield_stress_pa, p.softening, 0.0, 0.0])
                }
                Material::Foam(f) => (
                    MODEL_VON_MISES,
                    [f.yield_stress_pa, 0.0, f.viscosity_pa_s, 0.0],
                ),
            };
            let e = splatphys_core::material::ConstitutiveModel::elastic(m);
            GpuMaterial {
                mu: e.mu_pa,
                lambda: e.lambda_pa,
                eta: e.damping_viscosity_pa_s,
                model,
                p,
            }
        })
        .collect()
}

/// The GPU form of `sys`'s colliders and the grid's extent: the domain bound's box, else
/// `extent`.
fn colliders(
    sys: &MpmSystem,
    extent: Option<(Vec3A, Vec3A)>,
) -> Result<(Vec<GpuCollider>, (Vec3A, Vec3A)), GpuError> {
    let mut out = Vec::new();
    let mut domain = None;
    for c in &sys.colliders {
        let surface = match c.surface {
            Surface::Sticky => 0,
            Surface::Slip => 1,
            Surface::Separate => 2,
            Surface::Clamp => 3,
        };
        let (kind, a, b) = match c.shape {
            Shape::Plane(p) => (0, p.point_m, p.normal),
            Shape::Box(b) => (1, b.min_m, b.max_m),
            Shape::DomainBound(b) => {
                domain = Some((b.min_m, b.max_m));
                (2, b.min_m, b.max_m)
            }
        };
        out.push(GpuCollider {
            kind,
            surface,
            friction: c.surface.friction(c.friction),
            gated: if c.is_gated() {
                GAPS_GATED
            } else if c.takes_sides(sys.solver.dx_m) {
                GAPS_SIDES
            } else {
                0
            },
            a: a.extend(0.0).to_array(),
            b: b.extend(0.0).to_array(),
            velocity: c
                .velocity_m_s
                .extend(if c.active_s.is_some() { 1.0 } else { 0.0 })
                .to_array(),
            window: match c.active_s {
                Some((start, end)) => [start as f32, end.min(f64::from(f32::MAX)) as f32, 0.0, 0.0],
                None => [0.0; 4],
            },
        });
    }
    let domain = domain.or(extent).ok_or_else(|| {
        unsupported("a system without a domain bound (the GPU grid is dense over it)")
    })?;
    Ok((out, domain))
}

/// What [`GpuMpm::new`] uploads of a system the GPU path runs.
struct Supported {
    n: u32,
    materials: Vec<GpuMaterial>,
    colliders: Vec<GpuCollider>,
    domain: (Vec3A, Vec3A),
}

fn supported(sys: &MpmSystem, extent: Option<(Vec3A, Vec3A)>) -> Result<Supported, GpuError> {
    let p = &sys.particles;
    let n = u32::try_from(p.len()).map_err(|_| unsupported("more than 2^32 particles"))?;
    if let Some(&m) = p
        .material
        .iter()
        .find(|&&m| m as usize >= sys.materials.len())
    {
        return Err(unsupported(format!(
            "material index {m} without a material"
        )));
    }
    let materials = materials(&sys.materials);
    let (colliders, domain) = colliders(sys, extent)?;
    Ok(Supported {
        n,
        materials,
        colliders,
        domain,
    })
}

/// Whether the GPU path runs `sys` (no device needed).
///
/// # Errors
/// [`GpuError::Unsupported`] naming the first model, collider or layout it does not run.
pub fn check_supported(sys: &MpmSystem) -> Result<(), GpuError> {
    supported(sys, None).map(|_| ())
}

/// The dispatch size for `n` work items: (x, y) workgroups, rows of [`ROW`].
fn dispatch(n: u32) -> (u32, u32) {
    let groups = n.div_ceil(WORKGROUP).max(1);
    (groups.min(ROW), groups.div_ceil(ROW))
}

/// The grid's buffers for `n_nodes` nodes and `n_colliders` colliders: the P2G sums
/// (`grid_sum`, [`NODE_WORDS`] a node, then [`COLLIDER_WORDS`] a collider) and the velocities
/// (`grid_v`).
fn grid_buffers(
    device: &wgpu::Device,
    n_nodes: u32,
    n_colliders: u32,
) -> (wgpu::Buffer, wgpu::Buffer) {
    let usage =
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
    let buffer = |label, size| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage,
            mapped_at_creation: false,
        })
    };
    let words = u64::from(n_nodes) * NODE_WORDS + COLLIDER_WORDS * u64::from(n_colliders);
    (
        buffer("grid_sum", 4 * words),
        buffer("grid_v", u64::from(n_nodes) * 16),
    )
}

/// The buffers the kernels bind, one field per binding of `kernels.rs`'s layout.
#[derive(Debug)]
struct Buffers {
    params: wgpu::Buffer,
    xv: wgpu::Buffer,
    cf: wgpu::Buffer,
    /// The particles' material indices, the materials and the colliders (bound, never read
    /// back).
    fixed: [wgpu::Buffer; 3],
    grid_sum: wgpu::Buffer,
    grid_v: wgpu::Buffer,
    status: wgpu::Buffer,
    plastic: wgpu::Buffer,
    moments: wgpu::Buffer,
}

impl Buffers {
    /// The buffers in binding order.
    fn in_binding_order(&self) -> [&wgpu::Buffer; kernels::STORAGE_BUFFERS as usize] {
        let [pmat, mats, cols] = &self.fixed;
        [
            &self.params,
            &self.xv,
            &self.cf,
            pmat,
            mats,
            cols,
            &self.grid_sum,
            &self.grid_v,
            &self.status,
            &self.plastic,
            &self.moments,
        ]
    }

    /// The kernels' bind group over them.
    fn bind(&self, device: &wgpu::Device, kernels: &Kernels) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> = self
            .in_binding_order()
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("mpm"),
            layout: &kernels.layout,
            entries: &entries,
        })
    }
}

/// An [`MpmSystem`]'s particles, materials and colliders on the GPU.
#[derive(Debug)]
pub struct GpuMpm {
    ctx: GpuContext,
    params: Params,
    n_nodes: u32,
    buffers: Buffers,
    /// Whether the grid covers the system's domain bound (it then never moves or grows).
    over_domain: bool,
    bind_group: wgpu::BindGroup,
    kernels: std::sync::Arc<Kernels>,
    /// The read-back staging buffers, small and large, kept between reads (`mpm/readback.rs`).
    staging: std::sync::Mutex<[Option<wgpu::Buffer>; 2]>,
    /// How long a read-back polls the device before it blocks (`mpm/readback.rs`).
    spin: std::time::Duration,
    /// Substeps run.
    pub substeps: u64,
    /// Simulated time (s).
    pub time_s: f64,
}

impl GpuMpm {
    /// Uploads `sys` (its particles, materials, colliders and gravity; the time-step policy is
    /// the caller's: [`GpuMpm::substep`] takes dt).
    ///
    /// # Errors
    /// [`GpuError::Unsupported`] for a model, collider or layout the GPU path does not run, or
    /// a device that allows fewer storage buffers per shader stage than the kernels bind (11).
    pub fn new(ctx: GpuContext, sys: &MpmSystem) -> Result<Self, GpuError> {
        Self::new_over(ctx, sys, None)
    }

    /// [`GpuMpm::new`] on a grid over `extent` (min, max corners in m) where `sys` has no
    /// domain bound; a particle that leaves it fails its substep ([`GpuMpm::check`]).
    ///
    /// # Errors
    /// As [`GpuMpm::new`].
    pub fn new_over(
        ctx: GpuContext,
        sys: &MpmSystem,
        extent: Option<(Vec3A, Vec3A)>,
    ) -> Result<Self, GpuError> {
        let Supported {
            n,
            materials: mats,
            colliders: cols,
            domain: (lo, hi),
        } = supported(sys, extent)?;
        let p = &sys.particles;
        let dx = sys.solver.dx_m;
        // Nodes at integer multiples of dx, as on the CPU's sparse grid, three cells beyond the
        // bound on every side (a particle's stencil reaches 1.5 cells).
        let first = (lo / dx).floor() - Vec3A::splat(3.0);
        let last = (hi / dx).ceil() + Vec3A::splat(3.0);
        let dims = (last - first + Vec3A::ONE).as_ivec3();
        let n_nodes = dims.x as u64 * dims.y as u64 * dims.z as u64;
        let n_nodes =
            u32::try_from(n_nodes).map_err(|_| unsupported("a grid of more than 2^32 nodes"))?;
        let largest_mass = p.mass_kg.iter().fold(0f32, |a, &m| a.max(m));
        let (scale_m, scale_p) = fixed_point_scales(n, largest_mass);
        let params = Params {
            grid_dims: dims.to_array(),
            n_particles: n,
            grid_origin: (first * dx).to_array(),
            dx,
            gravity: sys.gravity_m_s2.to_array(),
            dt: 0.0,
            inv_dx: 1.0 / dx,
            n_colliders: cols.len() as u32,
            scale_m,
            scale_p,
            inv_scale_m: 1.0 / scale_m,
            inv_scale_p: 1.0 / scale_p,
            n_gated: sys
                .colliders
                .iter()
                .filter(|c| c.is_gated() || c.takes_sides(dx))
                .count() as u32,
            t0: 0.0,
            reference: [0.0; 3],
            n_groups: n.div_ceil(WORKGROUP).clamp(1, MOMENT_GROUPS),
            field_dv: [0.0; 3],
            _pad0: 0.0,
            field_dw: [0.0; 3],
            speed_limit: f32::MAX,
            plastic_floor: f32::MIN,
            opens_at: f32::MAX,
            open_mask: 0,
            run_flags: 0,
        };
        let allowed = ctx.device.limits().max_storage_buffers_per_shader_stage;
        if allowed < kernels::STORAGE_BUFFERS {
            return Err(unsupported(format!(
                "{} storage buffers per shader stage on {} (it allows {allowed})",
                kernels::STORAGE_BUFFERS,
                ctx.name()
            )));
        }
        let kernels = ctx.kernels();
        let device = &ctx.device;
        let init = |label: &str, contents: &[u8], usage: wgpu::BufferUsages| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
        };
        let rw = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST;
        let upload::Packed { xv, cf, plastic } = upload::pack(p);
        let pmat: Vec<u32> = p.material.iter().map(|&m| u32::from(m)).collect();
        // Storage buffers may not be empty: one unused element where there is nothing.
        let nonempty = |v: &[u8], size: usize| {
            if v.is_empty() {
                vec![0u8; size]
            } else {
                v.to_vec()
            }
        };
        let params_buf = init(
            "params",
            bytemuck::bytes_of(&params),
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        );
        let xv = init("xv", &nonempty(bytemuck::cast_slice(&xv), 32), rw);
        let cf = init("cf", &nonempty(bytemuck::cast_slice(&cf), 96), rw);
        let plastic = init("plastic", &nonempty(bytemuck::cast_slice(&plastic), 48), rw);
        let pmat = init(
            "particle_material",
            &nonempty(bytemuck::cast_slice(&pmat), 4),
            wgpu::BufferUsages::STORAGE,
        );
        let mats = init(
            "materials",
            &nonempty(bytemuck::cast_slice(&mats), size_of::<GpuMaterial>()),
            wgpu::BufferUsages::STORAGE,
        );
        let cols = init(
            "colliders",
            &nonempty(bytemuck::cast_slice(&cols), size_of::<GpuCollider>()),
            wgpu::BufferUsages::STORAGE,
        );
        let (grid_sum, grid_v) = grid_buffers(device, n_nodes, params.n_colliders);
        let status = init(
            "status",
            &vec![0u8; 4 * run::status_words(params.n_colliders as usize)],
            rw,
        );
        let moments = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("moments"),
            size: 4 * MOMENTS as u64 * (1 + u64::from(params.n_groups)),
            usage: rw,
            mapped_at_creation: false,
        });
        let buffers = Buffers {
            params: params_buf,
            xv,
            cf,
            fixed: [pmat, mats, cols],
            grid_sum,
            grid_v,
            status,
            plastic,
            moments,
        };
        let bind_group = buffers.bind(device, &kernels);
        Ok(Self {
            params,
            n_nodes,
            buffers,
            over_domain: sys
                .colliders
                .iter()
                .any(|c| matches!(c.shape, Shape::DomainBound(_))),
            bind_group,
            kernels,
            staging: std::sync::Mutex::new([None, None]),
            // A software adapter's kernels run on the cores a spinning thread would take.
            spin: if ctx.info.device_type == wgpu::DeviceType::Cpu {
                std::time::Duration::ZERO
            } else {
                spin_wait()
            },
            substeps: 0,
            time_s: sys.time_s,
            ctx,
        })
    }

    /// The device it runs on.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// Grid nodes (the dense grid over the domain bound).
    pub fn grid_nodes(&self) -> u32 {
        self.n_nodes
    }

    /// Queues `count` substeps of `dt_s` seconds each (P2G, grid update, G2P); returns without
    /// waiting for the GPU. Failures are counted on the GPU and reported by [`GpuMpm::check`].
    pub fn substeps(&mut self, count: u32, dt_s: f32) {
        if count == 0 {
            return;
        }
        self.begin_batch(dt_s);
        // Submitted in batches, at most two in flight: one command buffer of thousands of
        // substeps held gigabytes on lavapipe.
        let mut in_flight = None;
        let mut left = count;
        while left > 0 {
            let batch = left.min(SUBMIT_BATCH);
            left -= batch;
            let mut encoder = self
                .ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("mpm") });
            for _ in 0..batch {
                self.encode_substep(&mut encoder);
            }
            let submitted = self.ctx.queue.submit([encoder.finish()]);
            if let Some(previous) = in_flight.replace(submitted) {
                // A failure here shows at the next read-back.
                let _ = self.ctx.device.poll(wgpu::PollType::Wait {
                    submission_index: Some(previous),
                    timeout: None,
                });
            }
        }
        self.end_batch(count, dt_s);
    }

    /// Queues the parameters of a batch of substeps of `dt_s` starting now, and its substep
    /// counter (status word 3) at 0.
    fn begin_batch(&mut self, dt_s: f32) {
        self.params.dt = dt_s;
        self.params.t0 = self.time_s as f32;
        self.write_params();
        self.ctx
            .queue
            .write_buffer(&self.buffers.status, 12, bytemuck::bytes_of(&0u32));
    }

    /// Counts `count` substeps of `dt_s` queued.
    fn end_batch(&mut self, count: u32, dt_s: f32) {
        self.substeps += u64::from(count);
        self.time_s += f64::from(dt_s) * f64::from(count);
    }

    /// Queues one substep of `dt_s` seconds.
    pub fn substep(&mut self, dt_s: f32) {
        self.substeps(1, dt_s);
    }

    /// Records one substep (P2G, grid update, G2P and the substep counter) into `encoder`,
    /// with the parameters last written.
    fn encode_substep(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.clear_buffer(&self.buffers.grid_sum, 0, None);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("substep"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &self.bind_group, &[]);
        for (_, pipeline, groups) in self.substep_kernels() {
            pass.set_pipeline(pipeline);
            pass.dispatch_workgroups(groups.0, groups.1, 1);
        }
    }

    /// A substep's kernels in order, with their names and dispatch sizes: P2G, the grid update,
    /// G2P (which also ends the substep; `tick` does without particles). No allocation: this
    /// runs for every substep recorded.
    fn substep_kernels(
        &self,
    ) -> impl Iterator<Item = (&'static str, &wgpu::ComputePipeline, (u32, u32))> {
        let k = &self.kernels;
        let particles = dispatch(self.params.n_particles);
        let any = self.params.n_particles > 0;
        let last = if any {
            ("g2p", &k.g2p, particles)
        } else {
            ("tick", &k.tick, (1, 1))
        };
        [
            any.then_some(("p2g", &k.p2g, particles)),
            Some(("grid_update", &k.grid_update, dispatch(self.n_nodes))),
            Some(last),
        ]
        .into_iter()
        .flatten()
    }

    /// How long a read-back polls the device before it blocks (by default 1 ms on a hardware
    /// adapter, or `SPLATPHYS_GPU_SPIN_US` µs; none on a software one). Polling spends a core
    /// while it waits and wakes sooner: on an NVIDIA H200 a 16-byte read-back took 30 µs
    /// polling and 55 µs blocking, and a 10,648-particle substep with its report 177 against
    /// 219 µs. The results are the same bits either way.
    pub fn set_spin_wait(&mut self, spin: std::time::Duration) {
        self.spin = spin;
    }

    /// The point (m) the next report's moments are summed about, written with the next
    /// substep's parameters ([`GpuMpm::report`]).
    pub(crate) fn set_reference(&mut self, reference: Vec3A) {
        self.params.reference = reference.to_array();
    }

    /// Queues the upload of the parameters (before the next submission's work).
    fn write_params(&self) {
        self.ctx
            .queue
            .write_buffer(&self.buffers.params, 0, bytemuck::bytes_of(&self.params));
    }
}
