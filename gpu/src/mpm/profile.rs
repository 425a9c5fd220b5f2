//! Where a substep's time goes on the GPU: each kernel in its own compute pass between two
//! timestamps (wgpu's `TIMESTAMP_QUERY`), for `splatphys bench mpm --device gpu --profile`; and
//! what a substep costs as a `World` runs it, on the host's clock (the substep, then its report
//! read back: [`GpuMpm::round_trip`]).

use std::time::Instant;

use glam::Vec3A;

use crate::{GpuError, GpuMpm};

/// Queries one query set holds (wgpu's limit).
const MAX_QUERIES: u32 = 4096;

/// The mean time of each phase of a substep on the GPU (µs), in order: `clear` (zeroing the
/// grid's sums), each kernel, `substep` (from the start of the clear to the end of the last
/// kernel, gaps between passes included), then the two kernels of the moments a `World` reads
/// back after every substep on the device (`moments`, `moments_total`: `sums.wgsl`).
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    /// (phase, mean µs per substep).
    pub phases_us: Vec<(String, f64)>,
    /// Substeps measured.
    pub substeps: u32,
}

impl GpuMpm {
    /// Runs `count` substeps of `dt_s` (at most 4096 / (2 × kernels + 1) of them; fewer are run
    /// if more are asked), each kernel in a pass of its own with timestamps at its start and
    /// end, and returns the mean time of each phase. The passes of their own make a substep a
    /// little slower than [`GpuMpm::substeps`] runs it.
    ///
    /// # Errors
    /// [`GpuError::Unsupported`] when the device has no timestamp queries,
    /// [`GpuError::Readback`].
    pub fn profile(&mut self, count: u32, dt_s: f32) -> Result<Profile, GpuError> {
        let device = self.ctx.device.clone();
        if !device.features().contains(wgpu::Features::TIMESTAMP_QUERY) {
            return Err(GpuError::Unsupported {
                what: format!("timestamp queries on {}", self.ctx.name()),
            });
        }
        self.begin_batch(dt_s);
        let mut kernels: Vec<_> = self.substep_kernels().collect();
        let in_substep = kernels.len();
        kernels.extend([
            (
                "moments",
                &self.kernels.moments_per_group,
                (self.params.n_groups, 1),
            ),
            ("moments_total", &self.kernels.moments_total, (1, 1)),
        ]);
        let per = 1 + 2 * kernels.len() as u32;
        let count = count.clamp(1, MAX_QUERIES / per);
        let queries = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("profile"),
            ty: wgpu::QueryType::Timestamp,
            count: count * per,
        });
        let size = 8 * u64::from(count * per);
        let resolved = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("profile"),
            size,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("profile"),
        });
        for s in 0..count {
            let base = s * per;
            // An empty pass marks the start, before the grid's sums are cleared (a transfer,
            // outside passes).
            encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("start"),
                timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
                    query_set: &queries,
                    beginning_of_pass_write_index: Some(base),
                    end_of_pass_write_index: None,
                }),
            });
            encoder.clear_buffer(&self.buffers.grid_sum, 0, None);
            for (i, (name, pipeline, groups)) in kernels.iter().enumerate() {
                let at = base + 1 + 2 * i as u32;
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(name),
                    timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
                        query_set: &queries,
                        beginning_of_pass_write_index: Some(at),
                        end_of_pass_write_index: Some(at + 1),
                    }),
                });
                pass.set_bind_group(0, &self.bind_group, &[]);
                pass.set_pipeline(pipeline);
                pass.dispatch_workgroups(groups.0, groups.1, 1);
            }
        }
        encoder.resolve_query_set(&queries, 0..count * per, &resolved, 0);
        let ticks: Vec<u64> = self.read_after(encoder, &[(&resolved, 0, size)], |bytes| {
            bytemuck::pod_collect_to_vec(bytes[0])
        })?;
        let names: Vec<&str> = kernels.iter().map(|k| k.0).collect();
        self.end_batch(count, dt_s);
        let ns_per_tick = f64::from(self.ctx.queue.get_timestamp_period());
        let us = |from: u64, to: u64| to.saturating_sub(from) as f64 * ns_per_tick * 1e-3;
        // clear, each kernel, substep.
        let mut sums = vec![0.0; names.len() + 2];
        for t in ticks.chunks_exact(per as usize) {
            sums[0] += us(t[0], t[1]);
            for i in 0..names.len() {
                sums[1 + i] += us(t[1 + 2 * i], t[2 + 2 * i]);
            }
            sums[names.len() + 1] += us(t[0], t[2 * in_substep]);
        }
        // The substep's phases, the substep, then the moments' kernels.
        let substep = sums.pop().unwrap_or_default();
        sums.insert(1 + in_substep, substep);
        let names = std::iter::once("clear")
            .chain(names[..in_substep].iter().copied())
            .chain(std::iter::once("substep"))
            .chain(names[in_substep..].iter().copied());
        Ok(Profile {
            phases_us: names
                .zip(sums)
                .map(|(name, sum)| (name.to_string(), sum / f64::from(count)))
                .collect(),
            substeps: count,
        })
    }
}

/// What a substep costs on the host's clock as a `World` takes it on the device
/// ([`GpuMpm::round_trip`]), mean µs per substep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoundTrip {
    /// The whole: the substep queued, then its report recorded, submitted and read back.
    pub total_us: f64,
    /// Of which queueing the substep (parameters written, kernels recorded, submitted).
    pub queue_us: f64,
    /// Of which the report: recorded, submitted, waited for, read.
    pub report_us: f64,
    /// With nothing queued, one 16-byte read-back alone (submit, wait, map), as the report
    /// waits (polling, then blocking): the floor a round trip costs on this device and driver,
    /// whatever the kernels.
    pub bare_read_us: f64,
    /// The same read-back with a blocking wait only.
    pub bare_read_blocking_us: f64,
}

impl GpuMpm {
    /// The mean wall time (µs, on the host's clock) of `count` substeps of `dt_s` taken one at a
    /// time as a `World` takes them on the device: each queued, then its report (moments about
    /// `reference` m, the colliders' impulses, the failure check) recorded, submitted and read
    /// back ([`GpuMpm::report`]) before the next; and a bare read-back's. Against the kernels'
    /// time this is what the round trip costs.
    ///
    /// # Errors
    /// As [`GpuMpm::report`].
    pub fn round_trip(
        &mut self,
        count: u32,
        dt_s: f32,
        reference: Vec3A,
    ) -> Result<RoundTrip, GpuError> {
        let count = count.max(1);
        let (mut queue, mut report) = (0.0, 0.0);
        for _ in 0..count {
            let started = Instant::now();
            self.substep(dt_s);
            let queued = Instant::now();
            self.report(reference)?;
            queue += (queued - started).as_secs_f64();
            report += queued.elapsed().as_secs_f64();
        }
        let spin = self.spin;
        let mut bare_read = |spin| -> Result<f64, GpuError> {
            let kept = std::mem::replace(&mut self.spin, spin);
            let started = Instant::now();
            for _ in 0..count {
                self.read_range(&self.buffers.status, 0, 16)?;
            }
            self.spin = kept;
            Ok(started.elapsed().as_secs_f64())
        };
        let bare = bare_read(spin)?;
        let blocking = bare_read(std::time::Duration::ZERO)?;
        let us = |s: f64| s * 1e6 / f64::from(count);
        Ok(RoundTrip {
            total_us: us(queue + report),
            queue_us: us(queue),
            report_us: us(report),
            bare_read_us: us(bare),
            bare_read_blocking_us: us(blocking),
        })
    }
}
