//! Replay: publish a recording back onto the services, so any client (a renderer) can play it.
//!
//! The replayer owns the services under the prefix like a server does (scene, frame, objects,
//! status heartbeat, command); commands are not answered. Frames and objects go out through the
//! server's own publishers ([`frame_publisher`], [`objects_publisher`]): a lossless subscriber
//! (a recorder) is waited for, up to [`ReplayOptions::lossless_limit`] per message, and gets
//! every message. Timing: the
//! original wall-clock spacing of the messages, or as fast as possible. With
//! [`ReplayOptions::wait_for_subscribers`] nothing is published before that many clients
//! subscribed to `frame` and `objects` (frames keep no history, so a late client misses the
//! start).

use std::path::Path;
use std::time::{Duration, Instant};

use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::AllocationStrategy;
use iceoryx2::service::port_factory::PortFactory;
use splatphys_ipc::IpcError;
use splatphys_ipc::backpressure::LagBook;
use splatphys_ipc::heartbeat::Heartbeat;
use splatphys_ipc::server::{frame_publisher, objects_publisher};
use splatphys_ipc::services::{
    FrameService, ObjectsService, Role, ServiceNames, command_log_service, command_service,
    create_node, frame_service, frame_subscribers, object_names_service, objects_service,
    objects_subscribers, scene_service,
};
use splatphys_ipc::wire::{
    FrameGaussian, FrameHeader, ObjectName, ObjectState, STATUS_SHUTTING_DOWN, SceneGaussian,
    SceneHeader, Status,
};

use crate::channels::{FRAME, OBJECT_NAMES, OBJECTS, SCENE};
use crate::error::RecordError;
use crate::read::{Recording, split, verify};

/// How to replay.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayOptions {
    /// Keep the recorded spacing of the messages; `false` publishes as fast as the subscribers
    /// allow. Default true.
    pub realtime: bool,
    /// Publish nothing before this many subscribers are connected to `frame` and to `objects`
    /// (0 = start at once, the default).
    pub wait_for_subscribers: usize,
    /// Longest wait for them; the replay then starts anyway. Default 10 s.
    pub wait_timeout: Duration,
    /// Longest wait on a full lossless subscriber per message, as the server's
    /// `ServerConfig::lossless_limit`. Default 2 s.
    pub lossless_limit: Duration,
    /// Replay a truncated or corrupt file up to the damage; without it such a file is refused
    /// before anything is published. Default false.
    pub recover: bool,
}

impl Default for ReplayOptions {
    fn default() -> Self {
        Self {
            realtime: true,
            wait_for_subscribers: 0,
            wait_timeout: Duration::from_secs(10),
            lossless_limit: Duration::from_secs(2),
            recover: false,
        }
    }
}

/// Which subscribers the backpressure books know, refreshed when the counts change.
struct Books {
    frame: LagBook,
    objects: LagBook,
    counts: (usize, usize),
}

impl Books {
    fn refresh(&mut self, frame_s: &FrameService, objects_s: &ObjectsService) {
        let counts = (
            frame_s.dynamic_config().number_of_subscribers(),
            objects_s.dynamic_config().number_of_subscribers(),
        );
        if counts != self.counts {
            self.counts = counts;
            self.frame.set_subscribers(&frame_subscribers(frame_s));
            self.objects
                .set_subscribers(&objects_subscribers(objects_s));
        }
    }
}

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

/// What a replay did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ReplayReport {
    /// Messages published.
    pub counts: ReplayCounts,
    /// With [`ReplayOptions::recover`]: why the file ended early (`None`: it was whole).
    pub damage: Option<String>,
}

fn iox(op: &'static str, e: impl std::fmt::Debug) -> RecordError {
    RecordError::Ipc(IpcError::Iceoryx {
        op,
        service: "replay".into(),
        detail: format!("{e:?}"),
    })
}

/// Publishes `path` under `prefix` (see [`ReplayOptions`]), streaming it from disk: memory is
/// bounded by the largest chunk, whatever the length of the recording.
///
/// # Errors
/// File, MCAP and iceoryx2 errors; [`RecordError::Corrupt`] for a damaged file without
/// [`ReplayOptions::recover`] (nothing is published then); [`IpcError::Interrupted`] on a
/// signal while waiting for subscribers.
pub fn replay(
    path: &Path,
    prefix: &str,
    opts: &ReplayOptions,
) -> Result<ReplayReport, RecordError> {
    if !opts.recover {
        verify(path)?;
    }
    let mut msgs = Recording::open(path, opts.recover)?;
    let names = ServiceNames::new(prefix);
    let node = create_node("splatphys-replay")?;
    let _ = node.try_cleanup_dead_nodes();
    let scene_s = scene_service(&node, &names, Role::Owner)?;
    let names_s = object_names_service(&node, &names, Role::Owner)?;
    let frame_s = frame_service(&node, &names, Role::Owner)?;
    let objects_s = objects_service(&node, &names, Role::Owner)?;
    let _command_s = command_service(&node, &names, Role::Owner)?;
    let _command_log_s = command_log_service(&node, &names, Role::Owner)?;
    let heartbeat = Heartbeat::start(&names)?;
    let limit = opts.lossless_limit;
    let mut books = Books {
        frame: LagBook::new(limit),
        objects: LagBook::new(limit),
        counts: (usize::MAX, usize::MAX),
    };
    let scene_pub = scene_s
        .publisher_builder()
        .allocation_strategy(AllocationStrategy::PowerOfTwo)
        .create()
        .map_err(|e| iox("create publisher", e))?;
    let names_pub = names_s
        .publisher_builder()
        .allocation_strategy(AllocationStrategy::PowerOfTwo)
        .create()
        .map_err(|e| iox("create publisher", e))?;
    // Room for one Gaussian and one object to start with: the slices grow by powers of two.
    let frame_pub = frame_publisher(&frame_s, &names, 1, &books.frame)?;
    let objects_pub = objects_publisher(&objects_s, &names, 1, &books.objects)?;

    let waited = Instant::now();
    while opts.wait_for_subscribers > 0 && waited.elapsed() < opts.wait_timeout {
        let have = frame_s
            .dynamic_config()
            .number_of_subscribers()
            .min(objects_s.dynamic_config().number_of_subscribers());
        if have >= opts.wait_for_subscribers {
            break;
        }
        node.wait(Duration::from_millis(2))
            .map_err(|_| RecordError::Ipc(IpcError::Interrupted))?;
    }

    let mut counts = ReplayCounts::default();
    let t0 = Instant::now();
    let mut first_log = None;
    let mut status = Status::default();
    for m in msgs.by_ref() {
        let m = &m?;
        let first_log = *first_log.get_or_insert(m.log_time_ns);
        if node.wait(Duration::ZERO).is_err() {
            break;
        }
        if opts.realtime {
            let due = Duration::from_nanos(m.log_time_ns.saturating_sub(first_log));
            let el = t0.elapsed();
            if due > el && node.wait(due - el).is_err() {
                break;
            }
        }
        scene_pub
            .update_connections()
            .map_err(|e| iox("update", e))?;
        names_pub
            .update_connections()
            .map_err(|e| iox("update", e))?;
        match m.topic.as_str() {
            OBJECT_NAMES => {
                let (h, p): (FrameHeader, Vec<ObjectName>) = split(m, path, "object names")?;
                let s = names_pub
                    .loan_slice_uninit(p.len())
                    .map_err(|e| iox("loan", e))?;
                let mut s = s.write_from_slice(&p);
                *s.user_header_mut() = h;
                s.send().map_err(|e| iox("send", e))?;
            }
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
                books.refresh(&frame_s, &objects_s);
                let s = frame_pub
                    .loan_slice_uninit(p.len())
                    .map_err(|e| iox("loan", e))?;
                let mut s = s.write_from_slice(&p);
                *s.user_header_mut() = h;
                books.frame.begin_frame(counts.frames);
                s.send().map_err(|e| iox("send", e))?;
                books.frame.end_frame(counts.frames);
                counts.frames += 1;
                status.step = h.step;
                status.time_s = h.time_s;
                status.frames_published = counts.frames;
                heartbeat.update(&status);
            }
            OBJECTS => {
                let (h, p): (FrameHeader, Vec<ObjectState>) = split(m, path, "objects")?;
                books.refresh(&frame_s, &objects_s);
                let s = objects_pub
                    .loan_slice_uninit(p.len())
                    .map_err(|e| iox("loan", e))?;
                let mut s = s.write_from_slice(&p);
                *s.user_header_mut() = h;
                books.objects.begin_frame(counts.objects);
                s.send().map_err(|e| iox("send", e))?;
                books.objects.end_frame(counts.objects);
                counts.objects += 1;
            }
            _ => {}
        }
    }
    heartbeat.finish(STATUS_SHUTTING_DOWN)?;
    Ok(ReplayReport {
        counts,
        damage: msgs.damage().map(str::to_owned),
    })
}
