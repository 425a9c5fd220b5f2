//! The co-simulation server loop, generic over [`Simulation`].
//!
//! [`serve`] runs a [`Server`] whose loop reads as its steps: look for a stop (SIGINT/SIGTERM,
//! the stop flag), handle commands (drain and answer every pending one), republish the scene on
//! a new generation, step and publish (advance by one published frame unless paused, and write
//! the frame and the objects straight from the simulation into loaned shared memory), pace to
//! simulated time when asked, and beat (status). A separate thread publishes the status
//! heartbeat ([`crate::heartbeat`]). Dead nodes (killed clients) are cleaned up every
//! [`ServerConfig::cleanup_period`]. On a `Shutdown` command or the end of the simulation the
//! server finishes the step; a signal or the stop flag is seen between substeps, so a step in
//! progress is abandoned; it then waits for lossless subscribers to take the last frame
//! (`server/lossless.rs`), publishes a last status with [`STATUS_SHUTTING_DOWN`] and drops its
//! services (iceoryx2 removes them with their last user). Without
//! [`ServerConfig::exit_when_finished`] the end of the simulation does not stop the server: it
//! holds the last frame, paused, with [`STATUS_FINISHED`], and keeps answering.
//!
//! The lossless contract: with [`ServerConfig::wait_for_lossless`] the server publishes nothing
//! but the scene until that many lossless subscribers have said they are ready, then publishes
//! the initial frame once; at the end it waits until each of them has taken the last frame.
//!
//! Nothing a client sends ends the server, and a failing step does not either: the simulation
//! keeps a checkpoint of the last published frame; when a step fails (non-finite or unstable),
//! the server restores it, pauses, sets [`STATUS_FAILED`] with the reason in `status`, logs a
//! [`LOG_EVENT_STEP_FAILED`] entry on `command_log`, and keeps answering (reset, edits and
//! resume work). The command drain is bounded per iteration ([`MAX_COMMANDS_PER_ITERATION`],
//! [`COMMAND_DRAIN_BUDGET`]) so a flood cannot starve stepping, and liveness is the loop's
//! progress ([`Heartbeat::tick`]), not the beat.

use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use iceoryx2::node::Node;
use iceoryx2::port::backpressure_strategy::BackpressureStrategy;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::server::Server as CommandServer;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::AllocationStrategy;

use crate::backpressure::LagBook;
use crate::command::{Command, RejectCode, Reply};
use crate::error::IpcError;
use crate::heartbeat::Heartbeat;
use crate::services::{
    CommandLogService, CommandService, Iox, ObjectNamesService, Role, SceneService, ServiceNames,
    command_log_service, command_service, create_node, frame_service, frame_subscribers,
    object_names_service, objects_service, scene_service,
};
use crate::simulation::Simulation;
use crate::simulation::SimulationError;
use crate::validate::validate;
use crate::wire::{
    CommandLogEntry, CommandMsg, FrameHeader, LOG_EVENT_COMMAND, LOG_EVENT_STEP_FAILED, ObjectName,
    ReplyMsg, STATUS_FAILED, STATUS_FINISHED, STATUS_PAUSED, STATUS_SHUTTING_DOWN, SceneGaussian,
    SceneHeader, write_fixed_str,
};

/// Most commands answered per loop iteration; the rest wait for the next one.
pub const MAX_COMMANDS_PER_ITERATION: usize = 64;
/// Longest time spent answering commands per loop iteration.
pub const COMMAND_DRAIN_BUDGET: Duration = Duration::from_millis(5);

mod config;
mod lossless;
mod ports;
pub mod shm;
mod status;

pub use config::{ServerConfig, ServerReport, StopReason};
use lossless::LosslessAcks;
use status::status;

use ports::{Ports, clean_dead_nodes, publish_frame, publish_object_names, publish_scene};
pub use ports::{frame_publisher, objects_publisher};

/// Serves `sim` until a signal, a `Shutdown` command, the end of the simulation or
/// [`ServerConfig::stop`].
///
/// # Errors
/// When services cannot be created (e.g. [`IpcError::PrefixInUse`]), iceoryx2 fails, or the
/// simulation fails.
pub fn serve<S: Simulation>(sim: &mut S, cfg: &ServerConfig) -> Result<ServerReport, IpcError> {
    let mut server = Server::start(sim, cfg)?;
    let reason = loop {
        server.heartbeat.tick();
        if let Some(reason) = server.stop_requested() {
            break reason;
        }
        server.update_connections()?;
        if let Some(reason) = server.handle_commands()? {
            break reason;
        }
        server.republish_on_new_generation()?;
        if let Some(reason) = server.end_reached() {
            break reason;
        }
        if server.wait_for_subscribers()? {
            continue;
        }
        if let Some(reason) = server.step_and_publish()? {
            break reason;
        }
        server.beat();
        server.clean_up();
    };
    server.finish(reason)
}

/// Loop state that changes from iteration to iteration.
struct LoopState {
    /// The scene generation last published.
    generation: u32,
    /// Stepping paused by a command or [`ServerConfig::start_paused`].
    paused: bool,
    /// Still holding for [`ServerConfig::wait_for_lossless`] or
    /// [`ServerConfig::wait_for_subscribers`]; the initial frame is not published yet.
    waiting: bool,
    /// Holding at the end of the simulation (paused there once).
    held_at_end: bool,
    /// Steps past the simulation's end allowed by a `resume` there.
    run_until_step: u64,
    /// The step the simulation first ended at (the length of one more run).
    end_step: Option<u64>,
    /// Frames still to step while paused (`step N`).
    pending_steps: u64,
    /// Wall instant and simulated time that pacing counts from.
    pace_origin: (Instant, f64),
    /// When the wait for subscribers, the last status and the last cleanup happened.
    wait_started: Instant,
    last_status: Instant,
    last_cleanup: Instant,
    /// Start of the current rate period: instant, step, substeps.
    period: (Instant, u64, u64),
    /// Steps and substeps per wall second over the last period.
    rates: (f64, f64),
    /// The last failed step, restored and paused: (restored step, reason). Cleared by
    /// `resume`, `step` and `reset`.
    failure: Option<(u64, String)>,
    /// Entries sent on `command_log` so far.
    log_index: u64,
}

/// A running server: its ports, its report so far and its loop state. The services are kept
/// here so they live as long as their ports.
pub struct Server<'a, S: Simulation> {
    sim: &'a mut S,
    cfg: &'a ServerConfig,
    node: Node<Iox>,
    names: ServiceNames,
    _scene_service: SceneService,
    _object_names_service: ObjectNamesService,
    _command_service: CommandService,
    _command_log_service: CommandLogService,
    scene_pub: Publisher<Iox, [SceneGaussian], SceneHeader>,
    object_names_pub: Publisher<Iox, [ObjectName], FrameHeader>,
    command_log_pub: Publisher<Iox, CommandLogEntry, ()>,
    command_server: CommandServer<Iox, CommandMsg, (), ReplyMsg, ()>,
    acks: LosslessAcks,
    heartbeat: Heartbeat,
    ports: Ports,
    report: ServerReport,
    state: LoopState,
}

/// Maps "the service already exists" to [`IpcError::PrefixInUse`].
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

impl<'a, S: Simulation> Server<'a, S> {
    /// Creates every service and port and publishes the scene and the initial frame.
    ///
    /// # Errors
    /// As [`serve`].
    pub fn start(sim: &'a mut S, cfg: &'a ServerConfig) -> Result<Self, IpcError> {
        let prefix = cfg
            .prefix
            .clone()
            .unwrap_or_else(|| ServiceNames::default_prefix(sim.scene_name()));
        let names = ServiceNames::new(&prefix);
        shm::check_space(
            std::path::Path::new(shm::SHM_PATH),
            sim.gaussian_count(),
            sim.object_count(),
        )?;
        let node = create_node("splatphys-server")?;
        clean_dead_nodes(&node);

        let scene_service = owned(scene_service(&node, &names, Role::Owner), &prefix)?;
        let object_names_service =
            owned(object_names_service(&node, &names, Role::Owner), &prefix)?;
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
        let object_names_pub = object_names_service
            .publisher_builder()
            .initial_max_slice_len(sim.object_count().max(1))
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .create()
            .map_err(|e| IpcError::iox("create publisher", &names.name("object_names"), e))?;
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
        let acks = owned(LosslessAcks::create(&node, &names), &prefix)?;
        // `status` last: a client connects once it opens, and sends commands at once. iceoryx2
        // delivers a request only to the servers connected when it is sent, so the command
        // server port must exist by then (regression: a `resume` sent right after connecting
        // was lost).
        let heartbeat = owned(Heartbeat::start(&names), &prefix)?;

        let mut ports = Ports {
            names: names.clone(),
            frame_service,
            objects_service,
            frame_pub,
            objects_pub,
            frame_book,
            objects_book,
            subscribers: (Vec::new(), Vec::new()),
        };
        let waiting = cfg.wait_for_lossless > 0 || cfg.wait_for_subscribers > 0;
        let report = ServerReport {
            reason: StopReason::StopFlag,
            frames_published: 0,
            step: sim.step(),
            commands_received: 0,
            commands_rejected: 0,
            frames_dropped: 0,
            recorder_frames_lost: 0,
            step_failures: 0,
            step_wall_s: 0.0,
            publish_wall_s: 0.0,
            checkpoint_wall_s: 0.0,
        };
        publish_scene(sim, &scene_pub)?;
        publish_object_names(sim, &object_names_pub)?;
        ports.refresh_subscribers(true);
        sim.checkpoint();
        let now = Instant::now();
        let state = LoopState {
            generation: sim.scene_generation(),
            paused: cfg.start_paused,
            waiting,
            held_at_end: false,
            run_until_step: 0,
            end_step: None,
            pending_steps: 0,
            pace_origin: (now, sim.time_s()),
            wait_started: now,
            last_status: now,
            last_cleanup: now,
            period: (now, report.step, sim.substeps()),
            rates: (0.0, 0.0),
            failure: None,
            log_index: 0,
        };
        let mut server = Self {
            sim,
            cfg,
            node,
            names,
            _scene_service: scene_service,
            _object_names_service: object_names_service,
            _command_service: command_service,
            _command_log_service: command_log_service,
            scene_pub,
            object_names_pub,
            command_log_pub,
            command_server,
            acks,
            heartbeat,
            ports,
            report,
            state,
        };
        if !waiting {
            // Nobody to wait for: the initial frame now (a client that connects later starts
            // with the next one).
            server.publish()?;
        }
        Ok(server)
    }

    /// A signal or the stop flag.
    fn stop_requested(&self) -> Option<StopReason> {
        if self.node.wait(Duration::ZERO).is_err() {
            return Some(StopReason::Signal);
        }
        self.cfg
            .stop
            .load(Ordering::Acquire)
            .then_some(StopReason::StopFlag)
    }

    /// Late subscribers get the scene and the object names from history when the publishers
    /// update connections.
    fn update_connections(&self) -> Result<(), IpcError> {
        self.scene_pub
            .update_connections()
            .map_err(|e| IpcError::iox("update connections", &self.names.name("scene"), e))?;
        self.object_names_pub
            .update_connections()
            .map_err(|e| IpcError::iox("update connections", &self.names.name("object_names"), e))
    }

    /// Answers pending commands, at most [`MAX_COMMANDS_PER_ITERATION`] or
    /// [`COMMAND_DRAIN_BUDGET`] per call (the rest wait for the next iteration, so a flood
    /// cannot stop stepping); logs each with its reply. Returns
    /// [`StopReason::ShutdownCommand`] after an accepted `Shutdown`.
    fn handle_commands(&mut self) -> Result<Option<StopReason>, IpcError> {
        let mut shutdown = None;
        let started = Instant::now();
        for _ in 0..MAX_COMMANDS_PER_ITERATION {
            if started.elapsed() >= COMMAND_DRAIN_BUDGET {
                break;
            }
            let request = match self.command_server.receive() {
                Ok(Some(r)) => r,
                Ok(None) => break,
                Err(e) => {
                    return Err(IpcError::iox(
                        "receive command",
                        &self.names.name("command"),
                        e,
                    ));
                }
            };
            self.report.commands_received += 1;
            let msg = *request.payload();
            let (received_step, received_time_s) = (self.sim.step(), self.sim.time_s());
            let reply = match crate::command::decode(&msg) {
                Err(e) => Reply::Rejected {
                    code: RejectCode::Malformed,
                    reason: e.to_string(),
                },
                Ok(cmd) => match validate(&cmd, self.sim.object_count() as u32, &self.cfg.limits) {
                    Err(rejection) => rejection,
                    Ok(()) => {
                        if cmd == Command::Shutdown {
                            shutdown = Some(StopReason::ShutdownCommand);
                        }
                        self.execute(cmd)
                    }
                },
            };
            if matches!(reply, Reply::Rejected { .. }) {
                self.report.commands_rejected += 1;
            }
            // A client that died before its reply costs nothing: the send is discarded.
            let reply_msg = reply.to_msg(msg.sequence, self.sim.scene_generation());
            let _ = request.send_copy(reply_msg);
            let effective_time_s = match reply {
                Reply::Accepted { effective_step, .. } => {
                    let frames = effective_step as f64 - self.sim.step() as f64;
                    (self.sim.time_s() + (frames - 1.0).max(0.0) * self.sim.frame_dt_s()).max(0.0)
                }
                Reply::Rejected { .. } => received_time_s,
            };
            self.log(CommandLogEntry {
                received_step,
                received_time_s,
                effective_time_s,
                event: LOG_EVENT_COMMAND,
                command: msg,
                reply: reply_msg,
                ..Default::default()
            })?;
        }
        Ok(shutdown)
    }

    /// Sends one `command_log` entry, numbered.
    fn log(&mut self, entry: CommandLogEntry) -> Result<(), IpcError> {
        let entry = CommandLogEntry {
            log_index: self.state.log_index,
            ..entry
        };
        self.state.log_index += 1;
        self.command_log_pub
            .send_copy(entry)
            .map(|_| ())
            .map_err(|e| IpcError::iox("send", &self.names.name("command_log"), e))
    }

    /// Carries out one validated command: stepping commands here, the rest in the simulation.
    fn execute(&mut self, cmd: Command) -> Reply {
        let step = self.sim.step();
        let generation = self.sim.scene_generation();
        let accepted = |effective_step| Reply::Accepted {
            effective_step,
            generation,
        };
        match cmd {
            Command::Pause => {
                // A pause also cancels what is left of a `step N`.
                self.state.paused = true;
                self.state.pending_steps = 0;
                accepted(step)
            }
            Command::Resume => {
                if self.at_end() {
                    // One more run of the scene's length past its end.
                    let more = self.state.end_step.unwrap_or(0).max(1);
                    self.state.run_until_step = step.saturating_add(more);
                    self.state.held_at_end = false;
                }
                self.state.paused = false;
                self.state.pending_steps = 0;
                self.state.failure = None;
                self.state.pace_origin = (Instant::now(), self.sim.time_s());
                accepted(step + 1)
            }
            Command::Step { count } => {
                self.state.pending_steps = self.state.pending_steps.saturating_add(count);
                self.state.failure = None;
                accepted(step + 1)
            }
            Command::Shutdown => accepted(step),
            other => match self.sim.apply(&other) {
                Ok(step) => {
                    if other == Command::Reset {
                        self.state.failure = None;
                        self.state.held_at_end = false;
                        self.state.run_until_step = 0;
                    }
                    Reply::Accepted {
                        effective_step: step,
                        generation: self.sim.scene_generation(),
                    }
                }
                Err(reason) => Reply::Rejected {
                    code: RejectCode::Refused,
                    reason,
                },
            },
        }
    }

    /// Publishes the scene and a frame again when the scene generation changed (a reset, or an
    /// edit that changed the counts).
    fn republish_on_new_generation(&mut self) -> Result<(), IpcError> {
        if self.sim.scene_generation() == self.state.generation {
            return Ok(());
        }
        self.state.generation = self.sim.scene_generation();
        publish_scene(self.sim, &self.scene_pub)?;
        publish_object_names(self.sim, &self.object_names_pub)?;
        self.publish()?;
        self.sim.checkpoint();
        self.state.pace_origin = (Instant::now(), self.sim.time_s());
        Ok(())
    }

    /// At the simulation's end, and not running past it after a `resume` there.
    fn at_end(&self) -> bool {
        self.sim.is_finished() && self.sim.step() >= self.state.run_until_step
    }

    /// The end of the simulation (a stop with [`ServerConfig::exit_when_finished`], otherwise
    /// the first time a hold: paused, [`STATUS_FINISHED`]) or [`ServerConfig::max_frames`].
    fn end_reached(&mut self) -> Option<StopReason> {
        if self.at_end() && !self.state.held_at_end && !self.state.waiting {
            if self.cfg.exit_when_finished {
                return Some(StopReason::Finished);
            }
            self.state.held_at_end = true;
            self.state.paused = true;
            self.state.pending_steps = 0;
            self.state.end_step.get_or_insert(self.sim.step());
            eprintln!(
                "splatphys server: finished at step {} (t = {:.3} s); holding the last frame \
                 (resume, step N or reset go on; Ctrl-C or shutdown ends)",
                self.sim.step(),
                self.sim.time_s()
            );
            // Tell clients at once, not at the next period.
            self.state.last_status = Instant::now() - crate::services::STATUS_PERIOD;
            self.beat();
        }
        self.cfg
            .max_frames
            .is_some_and(|m| self.report.frames_published > m)
            .then_some(StopReason::MaxFrames)
    }

    /// While holding for [`ServerConfig::wait_for_lossless`] and
    /// [`ServerConfig::wait_for_subscribers`]: `true` to go round again. Once they are there the
    /// initial frame is published, once, so every one of them gets it.
    ///
    /// # Errors
    /// [`IpcError::LosslessNotReady`] when the lossless subscribers are not all ready within
    /// [`ServerConfig::wait_timeout`].
    fn wait_for_subscribers(&mut self) -> Result<bool, IpcError> {
        if !self.state.waiting {
            return Ok(false);
        }
        self.ports.refresh_subscribers(false);
        self.acks.poll()?;
        let connected = frame_subscribers(&self.ports.frame_service);
        let ready = self.acks.ready(&connected);
        let lossless_ready = ready >= self.cfg.wait_for_lossless;
        let subscribers_there = connected.len() >= self.cfg.wait_for_subscribers;
        let waited = self.state.wait_started.elapsed();
        if !(lossless_ready && subscribers_there) && waited < self.cfg.wait_timeout {
            std::thread::sleep(Duration::from_millis(2));
            return Ok(true);
        }
        if !lossless_ready {
            return Err(IpcError::LosslessNotReady {
                expected: self.cfg.wait_for_lossless,
                ready,
                waited_ms: waited.as_millis() as u64,
            });
        }
        if !subscribers_there {
            eprintln!(
                "splatphys server: {} of {} frame subscribers after {:.1} s; starting anyway",
                connected.len(),
                self.cfg.wait_for_subscribers,
                waited.as_secs_f64()
            );
        }
        self.state.waiting = false;
        // The subscribers that came since the last refresh must be in the lossless book
        // before the frame goes out.
        self.ports.refresh_subscribers(true);
        self.publish()?;
        self.state.pace_origin = (Instant::now(), self.sim.time_s());
        Ok(false)
    }

    /// Publishes the current frame and objects with the next frame index.
    fn publish(&mut self) -> Result<(), IpcError> {
        publish_frame(self.sim, &self.ports, self.report.frames_published)?;
        self.report.frames_published += 1;
        Ok(())
    }

    /// Advances one frame and publishes it when stepping (not paused, or `step N` pending),
    /// then paces; otherwise idles a millisecond. A signal during either wait stops.
    fn step_and_publish(&mut self) -> Result<Option<StopReason>, IpcError> {
        let stepping = self.state.pending_steps > 0 || (!self.state.paused && !self.at_end());
        if !stepping {
            let signalled = self.node.wait(Duration::from_millis(1)).is_err();
            return Ok(signalled.then_some(StopReason::Signal));
        }
        let t0 = Instant::now();
        let mut stop = None;
        let advanced = {
            let (node, flag, heartbeat) = (&self.node, &self.cfg.stop, &self.heartbeat);
            self.sim.advance(&mut || {
                heartbeat.tick();
                if node.wait(Duration::ZERO).is_err() {
                    stop = Some(StopReason::Signal);
                } else if flag.load(Ordering::Acquire) {
                    stop = Some(StopReason::StopFlag);
                }
                stop.is_none()
            })
        };
        match advanced {
            Ok(_) => {}
            Err(SimulationError::Interrupted { .. }) => {
                // The frame was abandoned mid-way: end on the last published state.
                self.sim.restore_checkpoint();
                return Ok(Some(stop.unwrap_or(StopReason::StopFlag)));
            }
            Err(SimulationError::Failed { step, reason }) => {
                return self.recover(step, reason).map(|()| None);
            }
        }
        let t1 = Instant::now();
        self.ports.refresh_subscribers(false);
        self.publish()?;
        let t2 = Instant::now();
        self.sim.checkpoint();
        self.report.step_wall_s += (t1 - t0).as_secs_f64();
        self.report.publish_wall_s += (t2 - t1).as_secs_f64();
        self.report.checkpoint_wall_s += t2.elapsed().as_secs_f64();
        self.state.pending_steps = self.state.pending_steps.saturating_sub(1);
        if self.cfg.realtime {
            let (origin, origin_time_s) = self.state.pace_origin;
            let due =
                origin + Duration::from_secs_f64((self.sim.time_s() - origin_time_s).max(0.0));
            let now = Instant::now();
            if due > now && self.node.wait(due - now).is_err() {
                return Ok(Some(StopReason::Signal));
            }
        }
        Ok(None)
    }

    /// After a failed step: restores the last published frame, pauses, and reports the failure
    /// in the status and the command log.
    ///
    /// # Errors
    /// [`IpcError::Simulation`] when the simulation keeps no checkpoint to restore.
    fn recover(&mut self, failed_step: u64, reason: String) -> Result<(), IpcError> {
        if !self.sim.restore_checkpoint() {
            return Err(SimulationError::Failed {
                step: failed_step,
                reason,
            }
            .into());
        }
        self.report.step_failures += 1;
        self.state.paused = true;
        self.state.pending_steps = 0;
        let restored = self.sim.step();
        eprintln!(
            "splatphys server: step {failed_step} failed ({reason}); restored step {restored} and paused"
        );
        let mut reply = Reply::Rejected {
            code: RejectCode::Refused,
            reason: reason.clone(),
        }
        .to_msg(0, self.sim.scene_generation());
        write_fixed_str(&mut reply.message, &reason);
        self.log(CommandLogEntry {
            received_step: restored,
            received_time_s: self.sim.time_s(),
            effective_time_s: self.sim.time_s(),
            event: LOG_EVENT_STEP_FAILED,
            reply,
            ..Default::default()
        })?;
        self.state.failure = Some((restored, reason));
        // Tell clients at once, not at the next period.
        self.state.last_status = Instant::now() - crate::services::STATUS_PERIOD;
        self.beat();
        Ok(())
    }

    /// Updates the heartbeat's status every [`crate::services::STATUS_PERIOD`].
    fn beat(&mut self) {
        if self.state.last_status.elapsed() < crate::services::STATUS_PERIOD {
            return;
        }
        let (start, step0, substeps0) = self.state.period;
        let dt = start.elapsed().as_secs_f64().max(1e-9);
        self.state.rates = (
            // a reset moves the step back
            (self.sim.step().saturating_sub(step0)) as f64 / dt,
            (self.sim.substeps().saturating_sub(substeps0)) as f64 / dt,
        );
        self.state.period = (Instant::now(), self.sim.step(), self.sim.substeps());
        self.ports.refresh_subscribers(true);
        self.update_status(if self.state.paused { STATUS_PAUSED } else { 0 });
        self.state.last_status = Instant::now();
    }

    /// Hands the heartbeat thread the current status, with `flags` and [`STATUS_FINISHED`]
    /// when the simulation is at its end.
    fn update_status(&self, flags: u32) {
        let finished = if self.at_end() { STATUS_FINISHED } else { 0 };
        let mut s = status(
            self.sim,
            &self.ports,
            &self.report,
            self.state.rates,
            flags | finished,
        );
        if let Some((step, reason)) = &self.state.failure {
            s.flags |= STATUS_FAILED;
            s.failure_step = *step;
            write_fixed_str(&mut s.failure_reason, reason);
        }
        self.heartbeat.update(&s);
    }

    /// Removes killed clients' resources every [`ServerConfig::cleanup_period`].
    fn clean_up(&mut self) {
        if self.state.last_cleanup.elapsed() >= self.cfg.cleanup_period {
            clean_dead_nodes(&self.node);
            self.state.last_cleanup = Instant::now();
        }
    }

    /// Waits for lossless subscribers to take the last published frame (see
    /// [`LosslessAcks::wait_for_last_frame`]); returns the frames not taken.
    fn wait_for_lossless_to_take_the_last_frame(&mut self, reason: StopReason) -> u64 {
        let Some(last) = self.report.frames_published.checked_sub(1) else {
            return 0;
        };
        let signalled = matches!(reason, StopReason::Signal | StopReason::StopFlag);
        self.acks.wait_for_last_frame(
            last,
            &self.ports.frame_service,
            self.cfg.lossless_limit,
            (!signalled).then_some(&self.node),
            &self.heartbeat,
        )
    }

    /// Waits for lossless subscribers to take the last frame, publishes the last status with
    /// [`STATUS_SHUTTING_DOWN`] and returns the report.
    fn finish(mut self, reason: StopReason) -> Result<ServerReport, IpcError> {
        let t0 = Instant::now();
        let not_taken = self.wait_for_lossless_to_take_the_last_frame(reason);
        if t0.elapsed() >= Duration::from_millis(100) {
            eprintln!(
                "splatphys server: waited {:.2} s for lossless subscribers to take the last frame",
                t0.elapsed().as_secs_f64()
            );
        }
        if not_taken > 0 {
            eprintln!(
                "splatphys server: lossless subscribers had not taken the last {not_taken} frame(s) when the server stopped"
            );
        }
        self.report.reason = reason;
        self.report.step = self.sim.step();
        let totals = self.ports.frame_book.totals();
        self.report.frames_dropped = totals.best_effort_dropped;
        self.report.recorder_frames_lost = totals.lossless_lost + not_taken;
        self.update_status(0);
        self.heartbeat.finish(STATUS_SHUTTING_DOWN)?;
        Ok(self.report)
    }
}
