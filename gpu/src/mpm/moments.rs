//! What the COM layer needs of an object whose particles stay on the GPU, as small buffers
//! instead of the particles: its moments summed on the GPU (`sums.wgsl`), the normal and
//! friction impulses each collider gave it in the last substep (summed in the grid update), and
//! the rigid velocity field the COM layer's laws add to it.

use glam::{DVec3, Vec3A};
use splatphys_core::world::measure::inertia_from_second_moments;
use splatphys_core::world::{BodyState, DeviceReport};

use crate::mpm::{COLLIDER_WORDS, MOMENTS, NODE_WORDS, dispatch};
use crate::{GpuError, GpuMpm};

/// What each grid collider gave an object's grid in the last substep, one entry per collider in
/// the system's order ([`GpuMpm::collider_contacts`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ColliderSums {
    /// The normal impulse, n n·Δp summed over its nodes (N s).
    pub impulses_n_s: Vec<DVec3>,
    /// The friction impulse, Δp − n n·Δp summed over its nodes (N s).
    pub friction_n_s: Vec<DVec3>,
    /// Its grid nodes with mass inside it, whether or not they took its rule.
    pub nodes: Vec<u64>,
}

impl GpuMpm {
    /// The particles' state as `splatphys_core::world::measure` computes it from them on the
    /// CPU (mass, COM, velocity, angular momentum about the COM with the APIC spin term, inertia
    /// about the COM, bounds), and their largest speed (m/s). The radius is the farthest corner
    /// of the bounds from the COM plus dx/2, at least the CPU's. Summed on the GPU in f32 about
    /// `reference` (m): a point near the particles, such as their last COM, keeps the sums
    /// accurate. Waits for the GPU (for every substep queued before it, too).
    ///
    /// # Errors
    /// [`GpuError::Readback`].
    pub fn moments(&mut self, reference: Vec3A) -> Result<(BodyState, f32), GpuError> {
        self.queue_moments(reference);
        let bytes = self.read_range(&self.buffers.moments, 0, 4 * MOMENTS as u64)?;
        let s: &[f32] = bytemuck::cast_slice(&bytes);
        Ok((self.state_of(s, reference), s[26]))
    }

    /// The normal impulse each collider gave the particles in the last substep (N s, one per
    /// collider in the system's order, zero for one not touched): n n·Δp summed over its grid
    /// nodes, as `MpmSolver::collider_impulses_n_s` reports on the CPU (what the restitution law
    /// at collider contacts takes). Exact sums of 64-bit fixed-point terms. Waits for the GPU.
    ///
    /// # Errors
    /// [`GpuError::Readback`].
    pub fn collider_impulses_n_s(&self) -> Result<Vec<DVec3>, GpuError> {
        Ok(self.collider_contacts()?.impulses_n_s)
    }

    /// The friction impulse each collider gave the particles in the last substep (N s, one per
    /// collider): each node's impulse less its part along the collider's normal, summed as
    /// [`GpuMpm::collider_impulses_n_s`] is (`MpmSolver::collider_friction_n_s` on the CPU).
    /// Waits for the GPU.
    ///
    /// # Errors
    /// [`GpuError::Readback`].
    pub fn collider_friction_n_s(&self) -> Result<Vec<DVec3>, GpuError> {
        Ok(self.collider_contacts()?.friction_n_s)
    }

    /// [`GpuMpm::collider_impulses_n_s`], [`GpuMpm::collider_friction_n_s`] and each
    /// collider's grid nodes with mass inside it in the last substep, whether or not they took
    /// its rule (`MpmSolver::collider_nodes` on the CPU), from one read-back.
    ///
    /// # Errors
    /// [`GpuError::Readback`].
    pub fn collider_contacts(&self) -> Result<ColliderSums, GpuError> {
        let (offset, size) = self.collider_range();
        if size == 0 {
            return Ok(ColliderSums::default());
        }
        let bytes = self.read_range(&self.buffers.grid_sum, offset, size)?;
        Ok(self.contacts_of(bytemuck::cast_slice(&bytes)))
    }

    /// The byte offset and size of the colliders' sums in `grid_sum`.
    fn collider_range(&self) -> (u64, u64) {
        let offset = 4 * u64::from(self.n_nodes) * NODE_WORDS;
        (
            offset,
            4 * COLLIDER_WORDS * u64::from(self.params.n_colliders),
        )
    }

    /// The colliders' sums read back (`words`) as impulses (N s) and node counts.
    pub(super) fn contacts_of(&self, words: &[u32]) -> ColliderSums {
        let scale = 1.0 / f64::from(self.params.scale_p);
        let value = |k: usize| {
            let bits = u64::from(words[k]) | (u64::from(words[k + 1]) << 32);
            bits as i64 as f64 * scale
        };
        let vector = |k: usize| DVec3::new(value(k), value(k + 2), value(k + 4));
        let mut sums = ColliderSums::default();
        for c in 0..self.params.n_colliders as usize {
            let k = c * COLLIDER_WORDS as usize;
            sums.impulses_n_s.push(vector(k));
            sums.friction_n_s.push(vector(k + 6));
            sums.nodes.push(u64::from(words[k + 12]));
        }
        sums
    }

    /// What a `World`'s substep takes back after the substeps queued, in one wait: the failure
    /// check and largest speed ([`GpuMpm::check`]), the object's state about `reference`
    /// ([`GpuMpm::moments`]) and each collider's impulse and nodes
    /// ([`GpuMpm::collider_contacts`]).
    ///
    /// # Errors
    /// As [`GpuMpm::check`].
    pub fn report(&mut self, reference: Vec3A) -> Result<DeviceReport, GpuError> {
        // A `World` sets the reference with the substep's parameters (`backend.rs`): one
        // write a substep instead of two.
        if self.params.reference != reference.to_array() {
            self.params.reference = reference.to_array();
            self.write_params();
        }
        let mut encoder = self.encoder("report");
        self.encode_moments(&mut encoder);
        let (offset, size) = self.collider_range();
        let mut ranges = vec![
            (&self.buffers.status, 0, 16),
            (&self.buffers.moments, 0, 4 * u64::from(MOMENTS)),
        ];
        if size > 0 {
            ranges.push((&self.buffers.grid_sum, offset, size));
        }
        let (status, report) = self.read_after(encoder, &ranges, |bytes| {
            let s: &[f32] = bytemuck::cast_slice(bytes[1]);
            let sums = match bytes.get(2) {
                Some(b) => self.contacts_of(bytemuck::cast_slice(b)),
                None => ColliderSums::default(),
            };
            let report = DeviceReport {
                state: self.state_of(s, reference),
                max_speed_m_s: s[26],
                min_plastic: -s[27],
                impulses_n_s: sums.impulses_n_s,
                friction_n_s: sums.friction_n_s,
                nodes: sums.nodes,
            };
            (bytemuck::pod_read_unaligned::<[u32; 4]>(bytes[0]), report)
        })?;
        self.take_status(&status)?;
        Ok(report)
    }

    /// Queues the moments about `reference` (m) into the `moments` buffer (`sums.wgsl`).
    fn queue_moments(&mut self, reference: Vec3A) {
        self.params.reference = reference.to_array();
        self.write_params();
        let mut encoder = self.encoder("moments");
        self.encode_moments(&mut encoder);
        self.ctx.queue.submit([encoder.finish()]);
    }

    /// Records the moments about the parameters' reference (`sums.wgsl`) into `encoder`.
    pub(super) fn encode_moments(&self, encoder: &mut wgpu::CommandEncoder) {
        encode_pass(
            encoder,
            &self.bind_group,
            "moments",
            &[
                (&self.kernels.moments_per_group, (self.params.n_groups, 1)),
                (&self.kernels.moments_total, (1, 1)),
            ],
        );
    }

    /// A new command encoder.
    pub(super) fn encoder(&self, label: &str) -> wgpu::CommandEncoder {
        self.ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) })
    }

    /// [`GpuMpm::moments`]'s sums `s` about `reference` as a [`BodyState`].
    pub(super) fn state_of(&self, s: &[f32], reference: Vec3A) -> BodyState {
        let f = |k: usize| f64::from(s[k]);
        let v3 = |k: usize| DVec3::new(f(k), f(k + 1), f(k + 2));
        let m = f(0);
        if m.is_nan() || m <= 0.0 {
            return BodyState::default();
        }
        let mean = v3(1) / m;
        let velocity = v3(4) / m;
        // Σ m (y − ȳ) × (v − V) = Σ m y × v − M ȳ × V, and the second moments likewise.
        let orbital = v3(7) - mean.cross(velocity) * m;
        let diag = v3(13) - mean * mean * m;
        let off = v3(16) - DVec3::new(mean.x * mean.y, mean.x * mean.z, mean.y * mean.z) * m;
        let d = f64::from(self.params.dx).powi(2) / 4.0;
        let r0 = reference.as_dvec3();
        let (lo, hi) = (v3(20), v3(23));
        let far = (lo - mean).abs().max((hi - mean).abs());
        BodyState {
            mass_kg: m,
            com_m: r0 + mean,
            velocity_m_s: velocity,
            angular_momentum: orbital + v3(10) * d,
            inertia: inertia_from_second_moments(diag, off, 2.0 * d * m),
            radius_m: far.length() + f64::from(self.params.dx) / 2.0,
            aabb_m: (r0 + lo, r0 + hi),
        }
    }

    /// Queues the rigid field the COM layer's laws add to an object: v += `dv` + `dw` ×
    /// (x − `about`) and C += \[`dw`\]× on every particle (m/s, rad/s, m), as
    /// `splatphys_core::world::coherence` does on the CPU. Returns without waiting.
    pub fn rigid_field(&mut self, dv: Vec3A, dw: Vec3A, about: Vec3A) {
        self.params.reference = about.to_array();
        self.params.field_dv = dv.to_array();
        self.params.field_dw = dw.to_array();
        self.write_params();
        let groups = dispatch(self.params.n_particles);
        self.submit_pass("rigid field", &[(&self.kernels.rigid_field, groups)]);
    }

    /// Submits one compute pass that runs `kernels` (pipeline, (x, y) workgroups) in order.
    fn submit_pass(&self, label: &str, kernels: &[(&wgpu::ComputePipeline, (u32, u32))]) {
        let mut encoder = self.encoder(label);
        encode_pass(&mut encoder, &self.bind_group, label, kernels);
        self.ctx.queue.submit([encoder.finish()]);
    }
}

/// Records one compute pass of `kernels` (each with its workgroup counts) over `bind_group`.
fn encode_pass(
    encoder: &mut wgpu::CommandEncoder,
    bind_group: &wgpu::BindGroup,
    label: &str,
    kernels: &[(&wgpu::ComputePipeline, (u32, u32))],
) {
    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(label),
        timestamp_writes: None,
    });
    pass.set_bind_group(0, bind_group, &[]);
    for (pipeline, (x, y)) in kernels {
        pass.set_pipeline(pipeline);
        pass.dispatch_workgroups(*x, *y, 1);
    }
}
