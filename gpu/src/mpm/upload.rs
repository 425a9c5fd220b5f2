//! The particles' layout in the GPU's buffers, and writing a new state into them.

use glam::Vec3A;
use splatphys_core::mpm::Particles;

use super::{GpuMpm, grid_buffers};
use crate::GpuError;

/// Particles as the shader stores them: `xv` (position and mass, velocity and rest volume: two
/// vec4 per particle), `cf` (C's and F's columns: six vec4) and `plastic` (F_p's columns, the
/// plastic scalar in the first one's w: three vec4).
pub(crate) struct Packed {
    pub(crate) xv: Vec<[f32; 4]>,
    pub(crate) cf: Vec<[f32; 4]>,
    pub(crate) plastic: Vec<[f32; 4]>,
}

/// `p` in the shader's layout.
pub(crate) fn pack(p: &Particles) -> Packed {
    let xv = (0..p.len())
        .flat_map(|i| {
            [
                p.x[i].extend(p.mass_kg[i]).to_array(),
                p.v[i].extend(p.volume0_m3[i]).to_array(),
            ]
        })
        .collect();
    let cf = (0..p.len())
        .flat_map(|i| {
            let (c, f) = (p.c[i], p.f[i]);
            [c.x_axis, c.y_axis, c.z_axis, f.x_axis, f.y_axis, f.z_axis]
                .map(|col| col.extend(0.0).to_array())
        })
        .collect();
    let plastic = (0..p.len())
        .flat_map(|i| {
            let fp = p.f_plastic[i];
            [
                fp.x_axis.extend(p.plastic[i]).to_array(),
                fp.y_axis.extend(0.0).to_array(),
                fp.z_axis.extend(0.0).to_array(),
            ]
        })
        .collect();
    Packed { xv, cf, plastic }
}

impl GpuMpm {
    /// Replaces the particles' positions, velocities, C, F, F_p and plastic state (and masses
    /// and rest volumes) with `particles`' (the uploaded count and order; their materials, and
    /// the fixed-point scale chosen from the uploaded total mass, stay as uploaded, so a changed
    /// mass needs a new upload). Queued before the next substep; returns without waiting.
    ///
    /// # Errors
    /// [`GpuError::Readback`] for a count that does not match.
    pub fn write_particles(&mut self, particles: &Particles) -> Result<(), GpuError> {
        let n = self.params.n_particles as usize;
        if particles.len() != n {
            return Err(GpuError::Readback(format!(
                "{} particles given, {n} on the GPU",
                particles.len()
            )));
        }
        if n == 0 {
            return Ok(());
        }
        let Packed { xv, cf, plastic } = pack(particles);
        let queue = &self.ctx.queue;
        queue.write_buffer(&self.buffers.xv, 0, bytemuck::cast_slice(&xv));
        queue.write_buffer(&self.buffers.cf, 0, bytemuck::cast_slice(&cf));
        queue.write_buffer(&self.buffers.plastic, 0, bytemuck::cast_slice(&plastic));
        Ok(())
    }

    /// Moves the dense grid, keeping its size, so that it covers `extent` (min, max corners in m)
    /// with the three cells a particle's stencil needs beyond it; `false` (and nothing changed)
    /// when the extent does not fit in the grid, which then needs a new upload. The grid holds
    /// nothing between substeps, so nothing else moves. Returns without waiting.
    pub fn recentre(&mut self, extent: (Vec3A, Vec3A)) -> bool {
        let dx = self.params.dx;
        let first = (extent.0 / dx).floor() - Vec3A::splat(3.0);
        let last = (extent.1 / dx).ceil() + Vec3A::splat(3.0);
        let dims = Vec3A::from(self.params.grid_dims.map(|d| d as f32));
        let spare = dims - (last - first + Vec3A::ONE);
        if !(spare.cmpge(Vec3A::ZERO).all() && first.is_finite()) {
            return false;
        }
        // The spare cells split evenly on both sides; nodes stay at integer multiples of dx.
        let origin = first - (spare * 0.5).floor();
        self.params.grid_origin = (origin * dx).to_array();
        self.write_params();
        true
    }

    /// Lays the dense grid out anew over `extent` (min, max corners in m), larger or smaller,
    /// keeping the particles where they are on the GPU: what an object that outgrew its grid
    /// needs, without reading its particles back and uploading them again. `false` (and
    /// nothing changed) for a grid over the system's domain bound, or one of more than 2^32
    /// nodes. Returns without waiting.
    pub fn regrid(&mut self, extent: (Vec3A, Vec3A)) -> bool {
        let dx = self.params.dx;
        let first = (extent.0 / dx).floor() - Vec3A::splat(3.0);
        let last = (extent.1 / dx).ceil() + Vec3A::splat(3.0);
        let dims = (last - first + Vec3A::ONE).as_ivec3();
        let nodes = dims.as_u64vec3().element_product();
        let (Ok(n_nodes), true) = (u32::try_from(nodes), first.is_finite() && !self.over_domain)
        else {
            return false;
        };
        let device = &self.ctx.device;
        (self.buffers.grid_sum, self.buffers.grid_v) =
            grid_buffers(device, n_nodes, self.params.n_colliders);
        self.n_nodes = n_nodes;
        self.params.grid_dims = dims.to_array();
        self.params.grid_origin = (first * dx).to_array();
        self.write_params();
        self.bind_group = self.buffers.bind(device, &self.kernels);
        true
    }
}
