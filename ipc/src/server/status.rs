//! The `status` message of a running server: its counters, the lossless book's totals and
//! per-subscriber figures, and the flags the loop decided.

use super::ServerReport;
use super::ports::Ports;
use crate::simulation::Simulation;
use crate::wire::{STATUS_LOSSLESS_LAGGING, Status};

/// The status of `sim` served through `ports`, with `rates` (steps and substeps per wall
/// second) and `flags`.
pub(super) fn status<S: Simulation>(
    sim: &S,
    ports: &Ports,
    report: &ServerReport,
    rates: (f64, f64),
    flags: u32,
) -> Status {
    let totals = ports.frame_book.totals();
    let lags = ports.frame_book.report();
    let mut s = Status {
        step: sim.step(),
        time_s: sim.time_s(),
        frames_published: report.frames_published,
        steps_per_s: rates.0,
        substeps_per_s: rates.1,
        frames_dropped: totals.best_effort_dropped,
        recorder_frames_lost: totals.lossless_lost.max(report.recorder_frames_lost),
        commands_received: report.commands_received,
        commands_rejected: report.commands_rejected,
        flags: flags
            | if totals.lagging > 0 {
                STATUS_LOSSLESS_LAGGING
            } else {
                0
            },
        scene_generation: sim.scene_generation(),
        subscriber_count: ports.frame_subscriber_count() as u32,
        reported_subscribers: lags.len() as u32,
        ..Default::default()
    };
    s.subscribers[..lags.len()].copy_from_slice(&lags);
    s
}
