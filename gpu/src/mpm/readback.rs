//! Reading results back from the GPU: the status (failures, largest speed) and the particles;
//! each read is one wait for the GPU.

use glam::{Mat3A, Vec3A};
use splatphys_core::mpm::Particles;

use crate::{GpuError, GpuMpm};

impl GpuMpm {
    /// Waits for the GPU and copies `buffer` back.
    pub(crate) fn read(&self, buffer: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
        self.read_range(buffer, 0, buffer.size())
    }

    /// Waits for the GPU and copies `size` bytes of `buffer` from byte `offset` back.
    pub(crate) fn read_range(
        &self,
        buffer: &wgpu::Buffer,
        offset: u64,
        size: u64,
    ) -> Result<Vec<u8>, GpuError> {
        Ok(self.read_ranges(&[(buffer, offset, size)])?.remove(0))
    }

    /// Waits for the GPU once and copies each (buffer, byte offset, size) back, in order
    /// (offsets and sizes multiples of 4).
    pub(crate) fn read_ranges(
        &self,
        ranges: &[(&wgpu::Buffer, u64, u64)],
    ) -> Result<Vec<Vec<u8>>, GpuError> {
        let total: u64 = ranges.iter().map(|r| r.2).sum();
        let staging = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: total.max(4),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("readback"),
            });
        let mut at = 0;
        for &(buffer, offset, size) in ranges {
            encoder.copy_buffer_to_buffer(buffer, offset, &staging, at, size);
            at += size;
        }
        self.ctx.queue.submit([encoder.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        self.ctx
            .device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        rx.recv()
            .map_err(|e| GpuError::Readback(e.to_string()))?
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        let bytes = staging
            .get_mapped_range(..)
            .map_err(|e| GpuError::Readback(e.to_string()))?
            .to_vec();
        staging.unmap();
        let mut out = Vec::with_capacity(ranges.len());
        let mut at = 0;
        for &(_, _, size) in ranges {
            out.push(bytes[at..at + size as usize].to_vec());
            at += size as usize;
        }
        Ok(out)
    }

    /// Waits for the queued substeps; returns the largest particle speed since the last check
    /// (m/s), and resets it.
    ///
    /// # Errors
    /// [`GpuError::Failed`] when a particle left the grid or a value went non-finite (the
    /// failed particles were left as they were), [`GpuError::Readback`].
    pub fn check(&mut self) -> Result<f32, GpuError> {
        let bytes = self.read(&self.status)?;
        self.take_status(bytemuck::cast_slice(&bytes))
    }

    /// The status words read back (`words`, the shader's `status`) as [`GpuMpm::check`] reports
    /// them; resets them on the GPU.
    pub(crate) fn take_status(&mut self, words: &[u32]) -> Result<f32, GpuError> {
        self.ctx
            .queue
            .write_buffer(&self.status, 0, bytemuck::cast_slice(&[0u32; 4]));
        if words[0] > 0 {
            return Err(GpuError::Failed {
                substep: self.substeps,
                count: words[0],
                first: words[2].checked_sub(1),
            });
        }
        Ok(f32::from_bits(words[1]))
    }

    /// Copies the particles' positions, velocities, C, F, F_p and plastic state back into `into`
    /// (which must be the set uploaded: same count and order).
    ///
    /// # Errors
    /// [`GpuError::Readback`], or a count that does not match.
    pub fn read_particles(&self, into: &mut Particles) -> Result<(), GpuError> {
        let n = self.params.n_particles as usize;
        if into.len() != n {
            return Err(GpuError::Readback(format!(
                "{} particles given, {n} on the GPU",
                into.len()
            )));
        }
        if n == 0 {
            return Ok(());
        }
        let xv = self.read(&self.xv)?;
        let cf = self.read(&self.cf)?;
        let plastic = self.read(&self.plastic)?;
        let xv: &[[f32; 4]] = bytemuck::cast_slice(&xv);
        let cf: &[[f32; 4]] = bytemuck::cast_slice(&cf);
        let plastic: &[[f32; 4]] = bytemuck::cast_slice(&plastic);
        let v3 = |a: [f32; 4]| Vec3A::new(a[0], a[1], a[2]);
        for i in 0..n {
            into.x[i] = v3(xv[2 * i]);
            into.v[i] = v3(xv[2 * i + 1]);
            let col = |k: usize| v3(cf[6 * i + k]);
            into.c[i] = Mat3A::from_cols(col(0), col(1), col(2));
            into.f[i] = Mat3A::from_cols(col(3), col(4), col(5));
            let fp = |k: usize| v3(plastic[3 * i + k]);
            into.f_plastic[i] = Mat3A::from_cols(fp(0), fp(1), fp(2));
            into.plastic[i] = plastic[3 * i][3];
        }
        Ok(())
    }
}
