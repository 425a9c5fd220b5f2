//! Replay: publish a recording back onto the services, so any client (a renderer) can play it.
//!
//! The replayer owns the services under the prefix like a server does (scene, frame, objects,
//! status heartbeat, command); commands are not answered. Timing: the original wall-clock
//! spacing of the frames, or as fast as possible.

use std::path::Path;
use std::time::{Duration, Instant};

use iceoryx2::port::backpressure_strategy::BackpressureStrategy;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::AllocationStrategy;
use splatphys_ipc::IpcError;
use splatphys_ipc::backpressure::LagBook;
use splatphys_ipc::heartbeat::Heartbeat;
use splatphys_ipc::services::{
    Role, ServiceNames, command_log_service, command_service, create_node, frame_service,
    objects_service, scene_service,
};
use splatphys_ipc::wire::{
    FrameGaussian, FrameHeader, ObjectState, STATUS_SHUTTING_DOWN, SceneGaussian, SceneHeader,
    Status,
};

use crate::channels::{FRAME, OBJECTS, SCENE};
use crate::error::RecordError;
use crate::read::{messages, read_file, split};

/// What a replay published.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ReplayCounts {
    /// Scenes.
    pub scenes: u64,
    /// Frames.
    pub frames: u64,
    /// Objects samples.
    pub objects: u64,
}

fn iox(op: &'static str, e: impl std::fmt::Debug) -> RecordError {
    RecordError::Ipc(IpcError::Iceoryx {
        op,
        service: "replay".into(),
        detail: format!("{e:?}"),
    })
}

/// Publishes `path` under `prefix`; `realtime` keeps the recorded spacing.
///
/// # Errors
/// File, MCAP and iceoryx2 errors.
pub fn replay(path: &Path, prefix: &str, realtime: bool) -> Result<ReplayCounts, RecordError> {
    let bytes = read_file(path)?;
    let msgs = messages(&bytes, path, true)?;
    let names = ServiceNames::new(prefix);
    let node = create_node("splatphys-replay")?;
    let _ = node.try_cleanup_dead_nodes();
    let scene_s = scene_service(&node, &names, Role::Owner)?;
    let frame_s = frame_service(&node, &names, Role::Owner)?;
    let objects_s = objects_service(&node, &names, Role::Owner)?;
    let _command_s = command_service(&node, &names, Role::Owner)?;
    let _command_log_s = command_log_service(&node, &names, Role::Owner)?;
    let heartbeat = Heartbeat::start(&names)?;
    let book = LagBook::new(Duration::from_millis(100));
    let scene_pub = scene_s
        .publisher_builder()
        .allocation_strategy(AllocationStrategy::PowerOfTwo)
        .create()
        .map_err(|e| iox("create publisher", e))?;
    let frame_pub = frame_s
        .publisher_builder()
        .allocation_strategy(AllocationStrategy::PowerOfTwo)
        .backpressure_strategy(BackpressureStrategy::RetryUntilDelivered)
        .set_backpressure_handler(book.handler())
        .create()
        .map_err(|e| iox("create publisher", e))?;
    let objects_pub = objects_s
        .publisher_builder()
        .allocation_strategy(AllocationStrategy::PowerOfTwo)
        .backpressure_strategy(BackpressureStrategy::DiscardData)
        .create()
        .map_err(|e| iox("create publisher", e))?;

    let mut counts = ReplayCounts::default();
    let t0 = Instant::now();
    let first_log = msgs.first().map_or(0, |m| m.log_time_ns);
    let mut status = Status::default();
    for m in &msgs {
        if node.wait(Duration::ZERO).is_err() {
            break;
        }
        if realtime {
            let due = Duration::from_nanos(m.log_time_ns.saturating_sub(first_log));
            let el = t0.elapsed();
            if due > el && node.wait(due - el).is_err() {
                break;
            }
        }
        scene_pub
            .update_connections()
            .map_err(|e| iox("update", e))?;
        match m.topic.as_str() {
            SCENE => {
                let (h, p): (SceneHeader, Vec<SceneGaussian>) = split(m, path, "scene")?;
                let s = scene_pub
                    .loan_slice_uninit(p.len())
                    .map_err(|e| iox("loan", e))?;
                let mut s = s.write_from_slice(&p);
                *s.user_header_mut() = h;
                s.send().map_err(|e| iox("send", e))?;
                counts.scenes += 1;
            }
            FRAME => {
                let (h, p): (FrameHeader, Vec<FrameGaussian>) = split(m, path, "frame")?;
                let s = frame_pub
                    .loan_slice_uninit(p.len())
                    .map_err(|e| iox("loan", e))?;
                let mut s = s.write_from_slice(&p);
                *s.user_header_mut() = h;
                s.send().map_err(|e| iox("send", e))?;
                counts.frames += 1;
                status.step = h.step;
                status.time_s = h.time_s;
                status.frames_published = counts.frames;
                heartbeat.update(&status);
            }
            OBJECTS => {
                let (h, p): (FrameHeader, Vec<ObjectState>) = split(m, path, "objects")?;
                let s = objects_pub
                    .loan_slice_uninit(p.len())
                    .map_err(|e| iox("loan", e))?;
                let mut s = s.write_from_slice(&p);
                *s.user_header_mut() = h;
                s.send().map_err(|e| iox("send", e))?;
                counts.objects += 1;
            }
            _ => {}
        }
    }
    heartbeat.finish(STATUS_SHUTTING_DOWN)?;
    Ok(counts)
}
