//! The co-simulation server loop, generic over [`Simulation`].
//!
//! One iteration: check for SIGINT/SIGTERM, drain and answer every pending command, advance
//! the simulation by one published frame (unless paused), and publish the frame and the
//! objects straight from the simulation into loaned shared memory. The scene is republished
//! whenever the scene generation changes. A separate thread beats the status heartbeat
//! ([`crate::heartbeat`]). Dead nodes (killed clients) are cleaned up every
//! [`ServerConfig::cleanup_period`]. On a signal, a `Shutdown` command or the end of the
//! simulation, the server finishes the step, publishes a last status with
//! [`STATUS_SHUTTING_DOWN`] and drops its services (iceoryx2 removes them with their last user).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use iceoryx2::node::Node;
use iceoryx2::port::backpressure_strategy::BackpressureStrategy;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::AllocationStrategy;

use crate::backpressure::LagBook;
use crate::command::{Command, RejectCode, Reply};
use crate::error::IpcError;
use crate::heartbeat::Heartbeat;
use crate::services::{
    FrameService, Iox, ObjectsService, Role, ServiceNames, command_log_service, command_service,
    create_node, frame_service, frame_subscribers, objects_service, objects_subscribers,
    scene_service,
};
use crate::simulation::Simulation;
use crate::validate::{Limits, validate};
use crate::wire::{
    CommandLogEntry, FrameGaussian, FrameHeader, LAYOUT_VERSION, MAX_NAMED_OBJECTS, ObjectState,
    STATUS_FINISHED, STATUS_LOSSLESS_LAGGING, STATUS_PAUSED, STATUS_SHUTTING_DOWN, SceneGaussian,
    SceneHeader, Status, write_fixed_str,
};

/// How the server runs.
#[derive(Debug, Clone)]
pub struct ServerConfig {
    /// Service prefix; `None` = `splatphys/<scene name>`.
    pub prefix: Option<String>,
    /// Pace frames to simulated time instead of running as fast as possible.
    pub realtime: bool,
    /// Longest wait on a full lossless subscriber per frame. Default 100 ms.
    pub lossless_limit: Duration,
    /// Command value limits.
    pub limits: Limits,
    /// Period of dead-node cleanup. Default 1 s.
    pub cleanup_period: Duration,
    /// Stop after publishing this many frames after the initial one.
    pub max_frames: Option<u64>,
    /// Stop when the simulation reports it is finished (otherwise: idle like paused).
    pub exit_when_finished: bool,
    /// Start paused.
    pub start_paused: bool,
    /// Set to stop the server from another thread.
    pub stop: Arc<AtomicBool>,
    /// Hold stepping until this many frame subscribers are connected (0 = do not wait), then
    /// publish the initial frame again so they all get it. The main job uses it so the recorder
    /// and the renderer see every step.
    pub wait_for_subscribers: usize,
    /// Longest wait for those subscribers; the run then starts anyway. Default 10 s.
    pub wait_timeout: Duration,
}

impl Default for ServerConfig {
    fn default() -> Self {
        Self {
            prefix: None,
            realtime: false,
            lossless_limit: Duration::from_millis(100),
            limits: Limits::default(),
            cleanup_period: Duration::from_secs(1),
            max_frames: None,
            exit_when_finished: true,
            start_paused: false,
            stop: Arc::default(),
            wait_for_subscribers: 0,
            wait_timeout: Duration::from_secs(10),
        }
    }
}

/// Why the server stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopReason {
    /// SIGINT or SIGTERM.
    Signal,
    /// A `Shutdown` command.
    ShutdownCommand,
    /// The simulation finished.
    Finished,
    /// [`ServerConfig::max_frames`] reached.
    MaxFrames,
    /// [`ServerConfig::stop`] was set.
    StopFlag,
}

/// What a server run did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServerReport {
    /// Why it stopped.
    pub reason: StopReason,
    /// Frames published, including the initial one.
    pub frames_published: u64,
    /// Last step index.
    pub step: u64,
    /// Commands received / rejected.
    pub commands_received: u64,
    /// Commands rejected.
    pub commands_rejected: u64,
    /// Frames skipped by best-effort subscribers.
    pub frames_dropped: u64,
    /// Frames lossless subscribers lost past the limit.
    pub recorder_frames_lost: u64,
    /// Wall time spent stepping vs. publishing, seconds.
    pub step_wall_s: f64,
    /// Wall time spent loaning, writing and sending frames and objects, seconds.
    pub publish_wall_s: f64,
}

struct Ports {
    names: ServiceNames,
    frame_service: FrameService,
    objects_service: ObjectsService,
    frame_pub: Publisher<Iox, [FrameGaussian], FrameHeader>,
    objects_pub: Publisher<Iox, [ObjectState], FrameHeader>,
    frame_book: LagBook,
    objects_book: LagBook,
    subscriber_counts: (usize, usize),
}

impl Ports {
    /// Re-reads which subscribers exist and which ask for lossless delivery.
    fn refresh_subscribers(&mut self, force: bool) {
        use iceoryx2::service::port_factory::PortFactory;
        let counts = (
            self.frame_service.dynamic_config().number_of_subscribers(),
            self.objects_service
                .dynamic_config()
                .number_of_subscribers(),
        );
        if !force && counts == self.subscriber_counts {
            return;
        }
        self.subscriber_counts = counts;
        self.frame_book
            .set_subscribers(&frame_subscribers(&self.frame_service));
        let o = objects_subscribers(&self.objects_service);
        self.objects_book.set_subscribers(&o);
    }
}

fn publish_scene<S: Simulation>(
    sim: &S,
    publisher: &Publisher<Iox, [SceneGaussian], SceneHeader>,
) -> Result<(), IpcError> {
    let n = sim.gaussian_count();
    let sample = publisher
        .loan_slice_uninit(n)
        .map_err(|e| IpcError::iox("loan scene", "scene", e))?;
    // SAFETY: the loaned chunk lives in an mmap'd shared-memory segment, which the OS zero-fills
    // on creation and which otherwise holds earlier samples: every byte is initialised, and
    // every bit pattern is a valid `SceneGaussian` (Pod). `write_scene` overwrites it all.
    let mut sample = unsafe { sample.assume_init() };
    let h = sample.user_header_mut();
    *h = SceneHeader {
        scene_generation: sim.scene_generation(),
        layout_version: LAYOUT_VERSION,
        gaussian_count: n as u32,
        object_count: sim.object_count() as u32,
        sh_degree: sim.sh_degree(),
        frame_dt_s: sim.frame_dt_s(),
        ..Default::default()
    };
    write_fixed_str(&mut h.scene_name, sim.scene_name());
    for id in 0..sim.object_count().min(MAX_NAMED_OBJECTS) {
        if let Some(name) = sim.object_name(id as u32) {
            write_fixed_str(&mut h.object_names[id], name);
        }
    }
    sim.write_scene(sample.payload_mut());
    sample
        .send()
        .map_err(|e| IpcError::iox("send scene", "scene", e))?;
    Ok(())
}

fn publish_frame<S: Simulation>(sim: &S, ports: &Ports, frame_index: u64) -> Result<(), IpcError> {
    let header = |count: usize| FrameHeader {
        step: sim.step(),
        time_s: sim.time_s(),
        substeps: sim.substeps(),
        frame_index,
        count: count as u32,
        scene_generation: sim.scene_generation(),
        layout_version: LAYOUT_VERSION,
        reserved: 0,
    };
    let n = sim.gaussian_count();
    let sample = ports
        .frame_pub
        .loan_slice_uninit(n)
        .map_err(|e| IpcError::iox("loan frame", &ports.names.name("frame"), e))?;
    // SAFETY: as in `publish_scene`: shared memory is always initialised and `FrameGaussian`
    // is Pod; `write_frame` overwrites every element.
    let mut sample = unsafe { sample.assume_init() };
    *sample.user_header_mut() = header(n);
    sim.write_frame(sample.payload_mut());
    ports.frame_book.begin_frame(frame_index);
    sample
        .send()
        .map_err(|e| IpcError::iox("send frame", &ports.names.name("frame"), e))?;
    ports.frame_book.end_frame(frame_index);

    let m = sim.object_count();
    let sample = ports
        .objects_pub
        .loan_slice_uninit(m)
        .map_err(|e| IpcError::iox("loan objects", &ports.names.name("objects"), e))?;
    // SAFETY: as above; `ObjectState` is Pod and `write_objects` overwrites every element.
    let mut sample = unsafe { sample.assume_init() };
    *sample.user_header_mut() = header(m);
    sim.write_objects(sample.payload_mut());
    ports.objects_book.begin_frame(frame_index);
    sample
        .send()
        .map_err(|e| IpcError::iox("send objects", &ports.names.name("objects"), e))?;
    ports.objects_book.end_frame(frame_index);
    Ok(())
}

/// The `frame` publisher as the server creates it: room for `gaussians` per sample (grows by
/// powers of two), and a full subscriber buffer handled by `book` (lossless subscribers are
/// waited for up to its limit, best-effort ones skip the frame). `splatphys bench ipc` measures
/// this very publisher.
///
/// # Errors
/// iceoryx2 failures.
pub fn frame_publisher(
    service: &FrameService,
    names: &ServiceNames,
    gaussians: usize,
    book: &LagBook,
) -> Result<Publisher<Iox, [FrameGaussian], FrameHeader>, IpcError> {
    service
        .publisher_builder()
        .initial_max_slice_len(gaussians.max(1))
        .allocation_strategy(AllocationStrategy::PowerOfTwo)
        .backpressure_strategy(BackpressureStrategy::RetryUntilDelivered)
        .set_backpressure_handler(book.handler())
        .create()
        .map_err(|e| IpcError::iox("create publisher", &names.name("frame"), e))
}

/// The `objects` publisher as the server creates it; see [`frame_publisher`].
///
/// # Errors
/// iceoryx2 failures.
pub fn objects_publisher(
    service: &ObjectsService,
    names: &ServiceNames,
    objects: usize,
    book: &LagBook,
) -> Result<Publisher<Iox, [ObjectState], FrameHeader>, IpcError> {
    service
        .publisher_builder()
        .initial_max_slice_len(objects.max(1))
        .allocation_strategy(AllocationStrategy::PowerOfTwo)
        .backpressure_strategy(BackpressureStrategy::RetryUntilDelivered)
        .set_backpressure_handler(book.handler())
        .create()
        .map_err(|e| IpcError::iox("create publisher", &names.name("objects"), e))
}

fn clean_dead_nodes(node: &Node<Iox>) {
    // Removes the shared-memory resources of killed clients; a cleanup that is busy elsewhere
    // is simply retried next period.
    let _ = node.try_cleanup_dead_nodes();
}

/// Serves `sim` until a signal, a `Shutdown` command, the end of the simulation or
/// [`ServerConfig::stop`].
///
/// # Errors
/// When services cannot be created (e.g. [`IpcError::PrefixInUse`]), iceoryx2 fails, or the
/// simulation fails.
pub fn serve<S: Simulation>(sim: &mut S, cfg: &ServerConfig) -> Result<ServerReport, IpcError> {
    let prefix = cfg
        .prefix
        .clone()
        .unwrap_or_else(|| ServiceNames::default_prefix(sim.scene_name()));
    let names = ServiceNames::new(&prefix);
    let node = create_node("splatphys-server")?;
    clean_dead_nodes(&node);

    fn owned<T>(r: Result<T, IpcError>, prefix: &str) -> Result<T, IpcError> {
        r.map_err(|e| match e {
            IpcError::Iceoryx { detail, .. } if detail.contains("AlreadyExists") => {
                IpcError::PrefixInUse {
                    prefix: prefix.to_owned(),
                }
            }
            e => e,
        })
    }
    let scene_service = owned(scene_service(&node, &names, Role::Owner), &prefix)?;
    let frame_service = owned(frame_service(&node, &names, Role::Owner), &prefix)?;
    let objects_service = owned(objects_service(&node, &names, Role::Owner), &prefix)?;
    let command_service = owned(command_service(&node, &names, Role::Owner), &prefix)?;
    let command_log_service = owned(command_log_service(&node, &names, Role::Owner), &prefix)?;

    let scene_pub = scene_service
        .publisher_builder()
        .initial_max_slice_len(sim.gaussian_count().max(1))
        .allocation_strategy(AllocationStrategy::PowerOfTwo)
        .create()
        .map_err(|e| IpcError::iox("create publisher", &names.name("scene"), e))?;
    let frame_book = LagBook::new(cfg.lossless_limit);
    let objects_book = LagBook::new(cfg.lossless_limit);
    let frame_pub = frame_publisher(&frame_service, &names, sim.gaussian_count(), &frame_book)?;
    let objects_pub =
        objects_publisher(&objects_service, &names, sim.object_count(), &objects_book)?;
    let command_log_pub = command_log_service
        .publisher_builder()
        .create()
        .map_err(|e| IpcError::iox("create publisher", &names.name("command_log"), e))?;
    let command_server = command_service
        .server_builder()
        .backpressure_strategy(BackpressureStrategy::DiscardData)
        .create()
        .map_err(|e| IpcError::iox("create server", &names.name("command"), e))?;
    // `status` last: a client connects once it opens, and sends commands at once. iceoryx2
    // delivers a request only to the servers connected when it is sent, so the command server
    // port must exist by then (regression: a `resume` sent right after connecting was lost).
    let heartbeat = owned(Heartbeat::start(&names), &prefix)?;

    let mut ports = Ports {
        names: names.clone(),
        frame_service,
        objects_service,
        frame_pub,
        objects_pub,
        frame_book,
        objects_book,
        subscriber_counts: (usize::MAX, usize::MAX),
    };

    let mut report = ServerReport {
        reason: StopReason::StopFlag,
        frames_published: 0,
        step: sim.step(),
        commands_received: 0,
        commands_rejected: 0,
        frames_dropped: 0,
        recorder_frames_lost: 0,
        step_wall_s: 0.0,
        publish_wall_s: 0.0,
    };
    let mut generation = sim.scene_generation();
    publish_scene(sim, &scene_pub)?;
    ports.refresh_subscribers(true);
    publish_frame(sim, &ports, 0)?;
    report.frames_published = 1;

    let mut paused = cfg.start_paused;
    let mut waiting = cfg.wait_for_subscribers > 0;
    let wait_started = Instant::now();
    let mut pending_steps = 0u64;
    let mut pace_origin = (Instant::now(), sim.time_s());
    let mut last_status = Instant::now();
    let mut last_cleanup = Instant::now();
    let mut period = (Instant::now(), report.step, sim.substeps());
    let mut rates = (0.0f64, 0.0f64);

    let reason = loop {
        if node.wait(Duration::ZERO).is_err() {
            break StopReason::Signal;
        }
        if cfg.stop.load(Ordering::Acquire) {
            break StopReason::StopFlag;
        }

        // Late subscribers get the scene from history when the publisher updates connections.
        scene_pub
            .update_connections()
            .map_err(|e| IpcError::iox("update connections", &names.name("scene"), e))?;

        // Commands.
        let mut shutdown = false;
        loop {
            let request = match command_server.receive() {
                Ok(Some(r)) => r,
                Ok(None) => break,
                Err(e) => return Err(IpcError::iox("receive command", &names.name("command"), e)),
            };
            report.commands_received += 1;
            let msg = *request.payload();
            let reply = match crate::command::decode(&msg) {
                Err(e) => Reply::Rejected {
                    code: RejectCode::Malformed,
                    reason: e.to_string(),
                },
                Ok(cmd) => match validate(&cmd, sim.object_count() as u32, &cfg.limits) {
                    Err(rejection) => rejection,
                    Ok(()) => match cmd {
                        Command::Pause => {
                            paused = true;
                            Reply::Accepted {
                                effective_step: sim.step(),
                            }
                        }
                        Command::Resume => {
                            paused = false;
                            pending_steps = 0;
                            pace_origin = (Instant::now(), sim.time_s());
                            Reply::Accepted {
                                effective_step: sim.step() + 1,
                            }
                        }
                        Command::Step { count } => {
                            pending_steps = pending_steps.saturating_add(count);
                            Reply::Accepted {
                                effective_step: sim.step() + 1,
                            }
                        }
                        Command::Shutdown => {
                            shutdown = true;
                            Reply::Accepted {
                                effective_step: sim.step(),
                            }
                        }
                        other => match sim.apply(&other) {
                            Ok(step) => Reply::Accepted {
                                effective_step: step,
                            },
                            Err(reason) => Reply::Rejected {
                                code: RejectCode::Refused,
                                reason,
                            },
                        },
                    },
                },
            };
            if matches!(reply, Reply::Rejected { .. }) {
                report.commands_rejected += 1;
            }
            // A client that died before its reply costs nothing: the send is discarded.
            let reply_msg = reply.to_msg(msg.sequence);
            let _ = request.send_copy(reply_msg);
            command_log_pub
                .send_copy(CommandLogEntry {
                    received_step: sim.step(),
                    command: msg,
                    reply: reply_msg,
                })
                .map_err(|e| IpcError::iox("send", &names.name("command_log"), e))?;
        }
        if shutdown {
            break StopReason::ShutdownCommand;
        }
        if sim.scene_generation() != generation {
            generation = sim.scene_generation();
            publish_scene(sim, &scene_pub)?;
            publish_frame(sim, &ports, report.frames_published)?;
            report.frames_published += 1;
            pace_origin = (Instant::now(), sim.time_s());
        }

        let finished = sim.is_finished();
        if finished && cfg.exit_when_finished {
            break StopReason::Finished;
        }
        if cfg.max_frames.is_some_and(|m| report.frames_published > m) {
            break StopReason::MaxFrames;
        }
        if waiting {
            ports.refresh_subscribers(false);
            let have = ports.subscriber_counts.0;
            if have >= cfg.wait_for_subscribers || wait_started.elapsed() >= cfg.wait_timeout {
                waiting = false;
                publish_frame(sim, &ports, report.frames_published)?;
                report.frames_published += 1;
                pace_origin = (Instant::now(), sim.time_s());
            } else {
                std::thread::sleep(Duration::from_millis(2));
                continue;
            }
        }
        let stepping = !finished && (!paused || pending_steps > 0);
        if stepping {
            let t0 = Instant::now();
            sim.advance()?;
            let t1 = Instant::now();
            ports.refresh_subscribers(false);
            publish_frame(sim, &ports, report.frames_published)?;
            report.frames_published += 1;
            report.step_wall_s += (t1 - t0).as_secs_f64();
            report.publish_wall_s += t1.elapsed().as_secs_f64();
            pending_steps = pending_steps.saturating_sub(1);
            if cfg.realtime {
                let due = pace_origin.0
                    + Duration::from_secs_f64((sim.time_s() - pace_origin.1).max(0.0));
                let now = Instant::now();
                if due > now && node.wait(due - now).is_err() {
                    break StopReason::Signal;
                }
            }
        } else if node.wait(Duration::from_millis(1)).is_err() {
            break StopReason::Signal;
        }

        if last_status.elapsed() >= crate::services::STATUS_PERIOD {
            let dt = period.0.elapsed().as_secs_f64().max(1e-9);
            rates = (
                (sim.step().saturating_sub(period.1)) as f64 / dt, // a reset moves the step back
                (sim.substeps().saturating_sub(period.2)) as f64 / dt,
            );
            period = (Instant::now(), sim.step(), sim.substeps());
            ports.refresh_subscribers(true);
            let flags =
                if paused { STATUS_PAUSED } else { 0 } | if finished { STATUS_FINISHED } else { 0 };
            heartbeat.update(&status(sim, &ports, &report, rates, flags));
            last_status = Instant::now();
        }
        if last_cleanup.elapsed() >= cfg.cleanup_period {
            clean_dead_nodes(&node);
            last_cleanup = Instant::now();
        }
    };

    report.reason = reason;
    report.step = sim.step();
    let totals = ports.frame_book.totals();
    report.frames_dropped = totals.best_effort_dropped;
    report.recorder_frames_lost = totals.lossless_lost;
    let finished = if sim.is_finished() {
        STATUS_FINISHED
    } else {
        0
    };
    heartbeat.update(&status(sim, &ports, &report, rates, finished));
    heartbeat.finish(STATUS_SHUTTING_DOWN)?;
    Ok(report)
}

fn status<S: Simulation>(
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
        recorder_frames_lost: totals.lossless_lost,
        commands_received: report.commands_received,
        commands_rejected: report.commands_rejected,
        flags: flags
            | if totals.lagging > 0 {
                STATUS_LOSSLESS_LAGGING
            } else {
                0
            },
        scene_generation: sim.scene_generation(),
        subscriber_count: ports.subscriber_counts.0 as u32,
        reported_subscribers: lags.len() as u32,
        ..Default::default()
    };
    s.subscribers[..lags.len()].copy_from_slice(&lags);
    s
}
