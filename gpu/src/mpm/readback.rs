//! Reading results back from the GPU: the status (failures, largest speed) and the particles;
//! each read is one wait for the GPU.

use std::sync::mpsc::TryRecvError;
use std::time::{Duration, Instant};

use glam::{Mat3A, Vec3A};
use rayon::prelude::*;
use splatphys_core::mpm::Particles;

use crate::{GpuError, GpuMpm};

/// The largest read (bytes) that takes the small staging buffer.
const SMALL_READ_BYTES: u64 = 64 * 1024;

impl GpuMpm {
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
        self.read_with(ranges, |slices| slices.iter().map(|s| s.to_vec()).collect())
    }

    /// Copies each (buffer, byte offset, size) into the staging buffer after the work queued
    /// so far, waits for the GPU once, and hands `f` the bytes of each range, in order, where
    /// they are mapped (no copy).
    pub(crate) fn read_with<R>(
        &self,
        ranges: &[(&wgpu::Buffer, u64, u64)],
        f: impl FnOnce(&[&[u8]]) -> R,
    ) -> Result<R, GpuError> {
        let encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("readback"),
            });
        self.read_after(encoder, ranges, f)
    }

    /// [`GpuMpm::read_with`] after the work in `encoder`, submitted together: one submission
    /// and one wait.
    pub(crate) fn read_after<R>(
        &self,
        mut encoder: wgpu::CommandEncoder,
        ranges: &[(&wgpu::Buffer, u64, u64)],
        f: impl FnOnce(&[&[u8]]) -> R,
    ) -> Result<R, GpuError> {
        let total: u64 = ranges.iter().map(|r| r.2).sum::<u64>().max(4);
        // Staging buffers kept and grown as needed: creating host-visible memory for a frame's
        // particles costs more than their copy on a GPU. Small reads (a substep's report) have
        // their own: mapping part of a large buffer every substep cost more than a new small
        // buffer did.
        let mut kept = self
            .staging
            .lock()
            .map_err(|_| GpuError::Readback("staging buffer lock poisoned".into()))?;
        let cached = &mut kept[usize::from(total > SMALL_READ_BYTES)];
        if cached.as_ref().is_none_or(|b| b.size() < total) {
            *cached = Some(self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("readback"),
                size: total.next_power_of_two().max(256),
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        let Some(staging) = cached.as_ref() else {
            return Err(GpuError::Readback("no staging buffer".into()));
        };
        let mut at = 0;
        for &(buffer, offset, size) in ranges {
            encoder.copy_buffer_to_buffer(buffer, offset, staging, at, size);
            at += size;
        }
        self.ctx.queue.submit([encoder.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, ..total, move |r| {
            let _ = tx.send(r);
        });
        self.wait_for(&rx, self.spin)?
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        let out = {
            let bytes = staging
                .get_mapped_range(..total)
                .map_err(|e| GpuError::Readback(e.to_string()))?;
            let mut slices = Vec::with_capacity(ranges.len());
            let mut at = 0;
            for &(_, _, size) in ranges {
                slices.push(&bytes[at..at + size as usize]);
                at += size as usize;
            }
            f(&slices)
        };
        staging.unmap();
        Ok(out)
    }

    /// Waits until the GPU has run the work submitted so far and `rx` has the map's result:
    /// polling the device without blocking for up to `spin` (a blocking wait wakes the thread
    /// some tens of µs after the GPU signals, which a substep of a small object pays every
    /// time), then blocking.
    fn wait_for(
        &self,
        rx: &std::sync::mpsc::Receiver<Result<(), wgpu::BufferAsyncError>>,
        spin: Duration,
    ) -> Result<Result<(), wgpu::BufferAsyncError>, GpuError> {
        let failed = |e: &dyn std::fmt::Display| GpuError::Readback(e.to_string());
        let started = Instant::now();
        while started.elapsed() < spin {
            match rx.try_recv() {
                Ok(r) => return Ok(r),
                Err(TryRecvError::Empty) => {}
                Err(e) => return Err(failed(&e)),
            }
            self.ctx
                .device
                .poll(wgpu::PollType::Poll)
                .map_err(|e| failed(&e))?;
            std::hint::spin_loop();
        }
        self.ctx
            .device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| failed(&e))?;
        rx.recv().map_err(|e| failed(&e))
    }

    /// Waits for the queued substeps; returns the largest particle speed since the last check
    /// (m/s), and resets it.
    ///
    /// # Errors
    /// [`GpuError::Failed`] when a particle left the grid or a value went non-finite (the
    /// failed particles were left as they were), [`GpuError::Readback`].
    pub fn check(&mut self) -> Result<f32, GpuError> {
        let bytes = self.read_range(&self.buffers.status, 0, 16)?;
        self.take_status(bytemuck::cast_slice(&bytes))
    }

    /// The status words read back (`words`, the shader's `status`) as [`GpuMpm::check`] reports
    /// them; resets them on the GPU.
    pub(crate) fn take_status(&mut self, words: &[u32]) -> Result<f32, GpuError> {
        self.ctx
            .queue
            .write_buffer(&self.buffers.status, 0, bytemuck::cast_slice(&[0u32; 8]));
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
        let ranges = [
            (&self.buffers.xv, 0, self.buffers.xv.size()),
            (&self.buffers.cf, 0, self.buffers.cf.size()),
            (&self.buffers.plastic, 0, self.buffers.plastic.size()),
        ];
        self.read_with(&ranges, |bytes| -> Result<(), GpuError> {
            unpack(into, cast4(bytes[0])?, cast4(bytes[1])?, cast4(bytes[2])?);
            Ok(())
        })??;
        Ok(())
    }
}

/// `bytes` as vec4s of f32.
fn cast4(bytes: &[u8]) -> Result<&[[f32; 4]], GpuError> {
    bytemuck::try_cast_slice(bytes)
        .map_err(|e| GpuError::Readback(format!("particle read-back: {e}")))
}

/// The GPU's particle layout (`upload::pack`: x and v in `xv`, C and F by columns in `cf`, F_p
/// by columns with the plastic scalar in its first column's w in `plastic`) into `into`, in
/// parallel (a copy: the result does not depend on the thread count).
fn unpack(into: &mut Particles, xv: &[[f32; 4]], cf: &[[f32; 4]], plastic: &[[f32; 4]]) {
    let v3 = |a: [f32; 4]| Vec3A::new(a[0], a[1], a[2]);
    let m3 = |cols: &[[f32; 4]]| Mat3A::from_cols(v3(cols[0]), v3(cols[1]), v3(cols[2]));
    into.x
        .par_iter_mut()
        .enumerate()
        .for_each(|(i, x)| *x = v3(xv[2 * i]));
    into.v
        .par_iter_mut()
        .enumerate()
        .for_each(|(i, v)| *v = v3(xv[2 * i + 1]));
    into.c
        .par_iter_mut()
        .enumerate()
        .for_each(|(i, c)| *c = m3(&cf[6 * i..6 * i + 3]));
    into.f
        .par_iter_mut()
        .enumerate()
        .for_each(|(i, f)| *f = m3(&cf[6 * i + 3..6 * i + 6]));
    into.f_plastic
        .par_iter_mut()
        .enumerate()
        .for_each(|(i, f)| *f = m3(&plastic[3 * i..3 * i + 3]));
    into.plastic
        .par_iter_mut()
        .enumerate()
        .for_each(|(i, p)| *p = plastic[3 * i][3]);
}
