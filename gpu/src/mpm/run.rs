//! A run of substeps in one submission (`splatphys_core::world::RunPlan`): the substeps, each
//! followed by `run.wgsl`'s check, which logs it and halts the run where the host has to see
//! its end; then the object's moments, and one read-back of the log and the moments.

use glam::Vec3A;
use splatphys_core::world::{DeviceReport, DeviceRun, RunPlan, RunStep};

use crate::mpm::{COLLIDER_WORDS, MOMENTS};
use crate::{GpuError, GpuMpm};

/// Status words before a run's log (the shader's `RUN_HEADER`).
const RUN_HEADER: usize = 8;
/// Substeps a run logs at most; a longer plan runs this many.
const RUN_CAPACITY: usize = 64;
/// Colliders a run tells apart (bits of the shader's `open_mask`); with more, no runs.
const RUN_COLLIDERS: usize = 32;
/// The shader's `RUN_HALT_ON_TOUCH`.
const RUN_HALT_ON_TOUCH: u32 = 1;

/// Status words for `n_colliders` colliders: the header and a run's log.
pub(crate) fn status_words(n_colliders: usize) -> usize {
    RUN_HEADER + RUN_CAPACITY * log_words(n_colliders)
}

/// Status words a substep's log entry takes: its speed, then each collider's sums.
fn log_words(n_colliders: usize) -> usize {
    1 + COLLIDER_WORDS as usize * n_colliders
}

impl GpuMpm {
    /// Runs `plan` (its substeps, each checked; the moments about its reference) with one
    /// wait; `None` for more colliders than a run tells apart (32).
    ///
    /// # Errors
    /// [`GpuError::Failed`] when a particle left the grid or a value went non-finite,
    /// [`GpuError::Readback`].
    pub fn run(&mut self, plan: &RunPlan) -> Result<Option<DeviceRun>, GpuError> {
        let n_colliders = self.params.n_colliders as usize;
        if n_colliders > RUN_COLLIDERS || plan.open.len() != n_colliders || plan.substeps == 0 {
            return Ok(None);
        }
        let count = plan.substeps.min(RUN_CAPACITY as u32);
        self.params.reference = plan.reference_m.to_array();
        self.params.speed_limit = plan.speed_limit_m_s;
        self.params.plastic_floor = plan.plastic_floor;
        // Halting early is safe, late is not: half the impulse that opens an impact halts.
        self.params.opens_at = (0.5 * plan.opens_at_n_s * f64::from(self.params.scale_p)) as f32;
        self.params.open_mask = (plan.open.iter().enumerate())
            .fold(0, |mask, (c, &open)| mask | (u32::from(open) << c));
        self.params.run_flags = if plan.halt_on_touch {
            RUN_HALT_ON_TOUCH
        } else {
            0
        };
        self.time_s = plan.time_s;
        self.begin_batch(plan.dt_s);
        self.ctx.queue.write_buffer(
            &self.buffers.status,
            0,
            bytemuck::cast_slice(&[0u32; RUN_HEADER]),
        );
        let mut encoder = self.encoder("run");
        for _ in 0..count {
            self.encode_substep(&mut encoder);
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("run check"),
                timestamp_writes: None,
            });
            pass.set_bind_group(0, &self.bind_group, &[]);
            pass.set_pipeline(&self.kernels.run_check);
            pass.dispatch_workgroups(1, 1, 1);
        }
        self.encode_moments(&mut encoder);
        let words = 4 * (RUN_HEADER + count as usize * log_words(n_colliders)) as u64;
        let ranges = [
            (&self.buffers.status, 0, words),
            (&self.buffers.moments, 0, 4 * u64::from(MOMENTS)),
        ];
        let reference = plan.reference_m;
        let (status, run) = self.read_after(encoder, &ranges, |bytes| {
            let status: &[u32] = bytemuck::cast_slice(bytes[0]);
            let moments: &[f32] = bytemuck::cast_slice(bytes[1]);
            (
                status[..RUN_HEADER].to_vec(),
                self.run_of(status, moments, reference),
            )
        })?;
        self.take_status(&status)?;
        if let Some(run) = &run {
            self.end_batch(run.steps.len() as u32, plan.dt_s);
        }
        Ok(run)
    }

    /// The run read back: the status words with its log (`status`) and the moments after it
    /// about `reference` (m); `None` if no substep ran.
    fn run_of(&self, status: &[u32], moments: &[f32], reference: Vec3A) -> Option<DeviceRun> {
        let entry = log_words(self.params.n_colliders as usize);
        let ran = (status[3] as usize).min((status.len() - RUN_HEADER) / entry);
        let mut steps: Vec<RunStep> = (0..ran)
            .map(|i| {
                let at = RUN_HEADER + i * entry;
                let sums = self.contacts_of(&status[at + 1..at + entry]);
                RunStep {
                    max_speed_m_s: f32::from_bits(status[at]),
                    impulses_n_s: sums.impulses_n_s,
                    friction_n_s: sums.friction_n_s,
                    nodes: sums.nodes,
                }
            })
            .collect();
        let last = steps.pop()?;
        let report = DeviceReport {
            state: self.state_of(moments, reference),
            max_speed_m_s: moments[26],
            min_plastic: -moments[27],
            impulses_n_s: last.impulses_n_s.clone(),
            friction_n_s: last.friction_n_s.clone(),
            nodes: last.nodes.clone(),
        };
        steps.push(last);
        Some(DeviceRun { steps, report })
    }
}
