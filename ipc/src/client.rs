//! Client helpers: connect to a server under a prefix, receive scene, frames, objects and
//! status, notice a dead server through the heartbeat, and send commands with replies.
//!
//! ```no_run
//! use splatphys_ipc::client::{ClientOptions, Connection};
//! # fn main() -> Result<(), splatphys_ipc::IpcError> {
//! let mut conn = Connection::connect(&ClientOptions::new("splatphys/demo"))?;
//! loop {
//!     // Errors with ServerGone within 1 s of a kill -9 of the server,
//!     // and with ServerShutDown after a clean shutdown once every frame was received.
//!     if let Some(frame) = conn.wait_frame(std::time::Duration::from_millis(100))? {
//!         let h = frame.user_header();
//!         println!("step {} t = {} s, {} Gaussians", h.step, h.time_s, frame.payload().len());
//!     }
//! }
//! # }
//! ```

use std::time::{Duration, Instant};

use iceoryx2::node::Node;
use iceoryx2::pending_response::PendingResponse;
use iceoryx2::port::backpressure_strategy::BackpressureStrategy;
use iceoryx2::port::client::Client;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::PortName;
use iceoryx2::sample::Sample;

use crate::command::{Command, Reply};
use crate::error::IpcError;
use crate::services::{
    CommandLogService, CommandService, FrameService, HEARTBEAT_TIMEOUT, Iox, LOSSLESS_PORT_NAME,
    LosslessAckService, MAX_FRAME_BUFFER, ObjectNamesService, ObjectsService, Role, SceneService,
    ServiceNames, StatusService, command_log_service, command_service, create_node, frame_service,
    lossless_ack_service, object_names_service, objects_service, scene_service, status_service,
};
use crate::wire::{
    ACK_READY, ACK_TOOK_FRAME, CommandLogEntry, CommandMsg, FrameGaussian, FrameHeader,
    LAYOUT_VERSION, LosslessAck, ObjectName, ObjectState, ReplyMsg, STATUS_SHUTTING_DOWN,
    STATUS_STALLED, SceneGaussian, SceneHeader, Status,
};

/// A received frame: `payload()` is `[N] FrameGaussian` viewing shared memory.
pub type FrameSample = Sample<Iox, [FrameGaussian], FrameHeader>;
/// A received objects sample: `payload()` is `[M] ObjectState`.
pub type ObjectsSample = Sample<Iox, [ObjectState], FrameHeader>;
/// A received scene: `payload()` is `[N] SceneGaussian`.
pub type SceneSample = Sample<Iox, [SceneGaussian], SceneHeader>;
/// A received list of object names: `payload()` is `[M] ObjectName`, indexed by object id.
pub type ObjectNamesSample = Sample<Iox, [ObjectName], FrameHeader>;
/// The `object_names` subscriber.
type ObjectNamesSubscriber = Subscriber<Iox, [ObjectName], FrameHeader>;
/// A command in flight.
pub type PendingCommand = PendingResponse<Iox, CommandMsg, (), ReplyMsg, ()>;

/// What to subscribe to and how.
#[derive(Debug, Clone)]
pub struct ClientOptions {
    /// Service prefix of the server.
    pub prefix: String,
    /// Node name (shows up in iceoryx2 tooling).
    pub node_name: String,
    /// How long [`Connection::connect`] waits for the server to appear. Default 5 s.
    pub connect_timeout: Duration,
    /// Silence after which the server is declared gone. Default 1 s.
    pub heartbeat_timeout: Duration,
    /// Subscribe to `frame`.
    pub frames: bool,
    /// Subscribe to `objects`.
    pub objects: bool,
    /// Ask for lossless delivery of frames and objects (the server waits for us, up to its
    /// limit). Default false: best effort, take the newest. A lossless client also opens
    /// `lossless_ack` and must say when it is ready ([`Connection::announce_ready`]) and which
    /// frames it took ([`Connection::acknowledge`]): the lossless contract of
    /// `docs/reference/protocol.md`.
    pub lossless: bool,
    /// Frames buffered by our subscriber, 1..=4. Default 2 (4 when lossless).
    pub frame_buffer: usize,
    /// Open the `command` service.
    pub commands: bool,
    /// Subscribe to `command_log` (every client's commands and their replies).
    pub command_log: bool,
}

impl ClientOptions {
    /// Frames, objects and commands under `prefix`, best effort.
    pub fn new(prefix: &str) -> Self {
        Self {
            prefix: prefix.to_owned(),
            node_name: "splatphys-client".into(),
            connect_timeout: Duration::from_secs(5),
            heartbeat_timeout: HEARTBEAT_TIMEOUT,
            frames: true,
            objects: true,
            lossless: false,
            frame_buffer: 2,
            commands: true,
            command_log: false,
        }
    }

    /// Lossless delivery (recorders).
    pub fn lossless(mut self) -> Self {
        self.lossless = true;
        self.frame_buffer = MAX_FRAME_BUFFER;
        self
    }
}

/// A live connection to one server.
pub struct Connection {
    node: Node<Iox>,
    names: ServiceNames,
    opts: ClientOptions,
    status_sub: Subscriber<Iox, Status, ()>,
    scene_sub: Subscriber<Iox, [SceneGaussian], SceneHeader>,
    /// `None` when the server publishes no `object_names` (a replay of an older recording).
    object_names_sub: Option<(ObjectNamesService, ObjectNamesSubscriber)>,
    frame_sub: Option<Subscriber<Iox, [FrameGaussian], FrameHeader>>,
    objects_sub: Option<Subscriber<Iox, [ObjectState], FrameHeader>>,
    command_client: Option<Client<Iox, CommandMsg, (), ReplyMsg, ()>>,
    command_log_sub: Option<Subscriber<Iox, CommandLogEntry, ()>>,
    _command_log: Option<CommandLogService>,
    /// Lossless clients only, and `None` when the server has no `lossless_ack` (a replay).
    ack: Option<(LosslessAckService, Publisher<Iox, LosslessAck, ()>)>,
    _services: (
        StatusService,
        SceneService,
        Option<FrameService>,
        Option<ObjectsService>,
        Option<CommandService>,
    ),
    last_beat: Instant,
    last_status: Option<Status>,
    shutting_down: bool,
    next_sequence: u64,
}

impl std::fmt::Debug for Connection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Connection")
            .field("prefix", &self.names.prefix())
            .field("last_status", &self.last_status)
            .finish_non_exhaustive()
    }
}

impl Connection {
    /// Waits (up to `connect_timeout`) for a server under the prefix and subscribes.
    ///
    /// # Errors
    /// [`IpcError::ServerNotFound`] after the timeout, [`IpcError::Interrupted`] on a signal,
    /// iceoryx2 failures otherwise.
    pub fn connect(opts: &ClientOptions) -> Result<Self, IpcError> {
        let node = create_node(&opts.node_name)?;
        let names = ServiceNames::new(&opts.prefix);
        let start = Instant::now();
        // The server creates `status` last, so once it opens every other service and the
        // server's ports exist (a command sent now reaches the command server).
        let status = loop {
            match status_service(&node, &names, Role::User) {
                Ok(s) => break s,
                Err(_) if start.elapsed() < opts.connect_timeout => {
                    // A killed server leaves stale services that cannot be opened: remove them.
                    let _ = node.try_cleanup_dead_nodes();
                    node.wait(Duration::from_millis(20))
                        .map_err(|_| IpcError::Interrupted)?;
                }
                Err(_) => {
                    return Err(IpcError::ServerNotFound {
                        prefix: opts.prefix.clone(),
                        waited_ms: start.elapsed().as_millis() as u64,
                    });
                }
            }
        };
        let scene = scene_service(&node, &names, Role::User)?;
        let object_names_sub = object_names_service(&node, &names, Role::User)
            .ok()
            .and_then(|service| {
                let sub = service
                    .subscriber_builder()
                    .history_request(1)
                    .create()
                    .ok()?;
                Some((service, sub))
            });
        let frame = opts
            .frames
            .then(|| frame_service(&node, &names, Role::User))
            .transpose()?;
        let objects = opts
            .objects
            .then(|| objects_service(&node, &names, Role::User))
            .transpose()?;
        let command = opts
            .commands
            .then(|| command_service(&node, &names, Role::User))
            .transpose()?;

        let command_log = opts
            .command_log
            .then(|| command_log_service(&node, &names, Role::User))
            .transpose()?;
        let command_log_sub = command_log
            .as_ref()
            .map(|s| {
                s.subscriber_builder()
                    .buffer_size(256)
                    .create()
                    .map_err(|e| IpcError::iox("create subscriber", &names.name("command_log"), e))
            })
            .transpose()?;
        let port_name = |lossless: bool| {
            PortName::new(if lossless {
                LOSSLESS_PORT_NAME
            } else {
                "best-effort"
            })
            .map_err(|e| IpcError::iox("port name", "subscriber", e))
        };
        let status_sub = status
            .subscriber_builder()
            .history_request(1)
            .create()
            .map_err(|e| IpcError::iox("create subscriber", &names.name("status"), e))?;
        let scene_sub = scene
            .subscriber_builder()
            .history_request(1)
            .create()
            .map_err(|e| IpcError::iox("create subscriber", &names.name("scene"), e))?;
        let buffer = opts.frame_buffer.clamp(1, MAX_FRAME_BUFFER);
        let frame_sub = frame
            .as_ref()
            .map(|s| {
                s.subscriber_builder()
                    .buffer_size(buffer)
                    .name(&port_name(opts.lossless)?)
                    .create()
                    .map_err(|e| IpcError::iox("create subscriber", &names.name("frame"), e))
            })
            .transpose()?;
        let objects_sub = objects
            .as_ref()
            .map(|s| {
                s.subscriber_builder()
                    .buffer_size(if opts.lossless { 16 } else { 4 })
                    .name(&port_name(opts.lossless)?)
                    .create()
                    .map_err(|e| IpcError::iox("create subscriber", &names.name("objects"), e))
            })
            .transpose()?;
        let ack = opts
            .lossless
            .then(|| lossless_ack_service(&node, &names, Role::User).ok())
            .flatten()
            .map(|service| {
                let publisher = service.publisher_builder().create().map_err(|e| {
                    IpcError::iox("create publisher", &names.name("lossless_ack"), e)
                })?;
                Ok::<_, IpcError>((service, publisher))
            })
            .transpose()?;
        let command_client = command
            .as_ref()
            .map(|s| {
                s.client_builder()
                    .backpressure_strategy(BackpressureStrategy::DiscardData)
                    .create()
                    .map_err(|e| IpcError::iox("create client", &names.name("command"), e))
            })
            .transpose()?;
        Ok(Self {
            node,
            names,
            opts: opts.clone(),
            status_sub,
            scene_sub,
            object_names_sub,
            frame_sub,
            objects_sub,
            command_client,
            command_log_sub,
            _command_log: command_log,
            ack,
            _services: (status, scene, frame, objects, command),
            last_beat: Instant::now(),
            last_status: None,
            shutting_down: false,
            next_sequence: 1,
        })
    }

    /// The service prefix.
    pub fn prefix(&self) -> &str {
        self.names.prefix()
    }

    /// The iceoryx2 node (to wait on, or to open extra ports).
    pub fn node(&self) -> &Node<Iox> {
        &self.node
    }

    /// Whether the server announced its shutdown.
    pub fn server_shutting_down(&self) -> bool {
        self.shutting_down
    }

    /// Lossless clients: tells the server that every port is connected and the current scene
    /// taken, so it may publish the first frame. Call it once, after taking the scene. Does
    /// nothing for a best-effort client or a server without `lossless_ack`.
    ///
    /// # Errors
    /// iceoryx2 failures.
    pub fn announce_ready(&mut self) -> Result<(), IpcError> {
        self.send_ack(ACK_READY, 0)
    }

    /// Lossless clients: tells the server that the frame and objects of `frame_index` (and
    /// every earlier one received) have been taken, so it need not wait for them at its end.
    ///
    /// # Errors
    /// iceoryx2 failures.
    pub fn acknowledge(&mut self, frame_index: u64) -> Result<(), IpcError> {
        self.send_ack(ACK_READY | ACK_TOOK_FRAME, frame_index)
    }

    fn send_ack(&mut self, flags: u32, frame_index: u64) -> Result<(), IpcError> {
        let (Some((_, publisher)), Some(frame_sub)) = (&self.ack, &self.frame_sub) else {
            return Ok(());
        };
        let id = frame_sub.id().value();
        let ack = LosslessAck {
            subscriber_id_lo: id as u64,
            subscriber_id_hi: (id >> 64) as u64,
            frame_index,
            flags,
            layout_version: LAYOUT_VERSION,
        };
        let name = self.names.name("lossless_ack");
        publisher
            .update_connections()
            .map_err(|e| IpcError::iox("update connections", &name, e))?;
        publisher
            .send_copy(ack)
            .map(|_| ())
            .map_err(|e| IpcError::iox("send", &name, e))
    }

    /// Drains the status service and checks the heartbeat.
    ///
    /// # Errors
    /// [`IpcError::ServerGone`] when no status arrived for the heartbeat timeout.
    pub fn poll_status(&mut self) -> Result<Option<Status>, IpcError> {
        loop {
            match self.status_sub.receive() {
                Ok(Some(s)) => {
                    let s = *s.payload();
                    if s.layout_version != LAYOUT_VERSION {
                        return Err(IpcError::LayoutMismatch {
                            server: s.layout_version,
                            client: LAYOUT_VERSION,
                        });
                    }
                    self.last_beat = Instant::now();
                    self.shutting_down |= s.flags & STATUS_SHUTTING_DOWN != 0;
                    self.last_status = Some(s);
                }
                Ok(None) => break,
                Err(e) => return Err(IpcError::iox("receive", &self.names.name("status"), e)),
            }
        }
        let silent = self.last_beat.elapsed();
        if !self.shutting_down && silent > self.opts.heartbeat_timeout {
            // Remove what the dead server left in shared memory.
            let _ = self
                .node
                .blocking_cleanup_dead_nodes(Duration::from_millis(100));
            return Err(IpcError::ServerGone {
                prefix: self.names.prefix().to_owned(),
                silent_ms: silent.as_millis() as u64,
            });
        }
        Ok(self.last_status)
    }

    /// [`IpcError::ServerStalled`] when the last status said the server's loop is stalled
    /// ([`STATUS_STALLED`]): it beats, but makes no progress.
    pub fn stalled(&self) -> Option<IpcError> {
        let s = self.last_status?;
        (s.flags & STATUS_STALLED != 0).then(|| IpcError::ServerStalled {
            prefix: self.names.prefix().to_owned(),
            stalled_ms: u64::from(s.progress_age_ms),
            step: s.step,
        })
    }

    fn shut_down(&self) -> IpcError {
        IpcError::ServerShutDown {
            prefix: self.names.prefix().to_owned(),
        }
    }

    /// The next scene sample (once per generation; the first one comes from history).
    ///
    /// # Errors
    /// iceoryx2 failures, [`IpcError::LayoutMismatch`].
    pub fn recv_scene(&mut self) -> Result<Option<SceneSample>, IpcError> {
        let s = self
            .scene_sub
            .receive()
            .map_err(|e| IpcError::iox("receive", &self.names.name("scene"), e))?;
        if let Some(s) = &s
            && s.user_header().layout_version != LAYOUT_VERSION
        {
            return Err(IpcError::LayoutMismatch {
                server: s.user_header().layout_version,
                client: LAYOUT_VERSION,
            });
        }
        Ok(s)
    }

    /// The next list of every object's name (once per generation; the first one comes from
    /// history). `None` also when the server publishes no names.
    ///
    /// # Errors
    /// iceoryx2 failures.
    pub fn recv_object_names(&mut self) -> Result<Option<ObjectNamesSample>, IpcError> {
        let Some((_, sub)) = &self.object_names_sub else {
            return Ok(None);
        };
        sub.receive()
            .map_err(|e| IpcError::iox("receive", &self.names.name("object_names"), e))
    }

    /// The next buffered frame, if any, oldest first.
    ///
    /// # Errors
    /// [`IpcError::ServerGone`], [`IpcError::ServerShutDown`] (after the last frame),
    /// [`IpcError::LayoutMismatch`], iceoryx2 failures.
    pub fn recv_frame(&mut self) -> Result<Option<FrameSample>, IpcError> {
        self.poll_status()?;
        let Some(sub) = &self.frame_sub else {
            return Ok(None);
        };
        let s = sub
            .receive()
            .map_err(|e| IpcError::iox("receive", &self.names.name("frame"), e))?;
        match s {
            Some(s) if s.user_header().layout_version != LAYOUT_VERSION => {
                Err(IpcError::LayoutMismatch {
                    server: s.user_header().layout_version,
                    client: LAYOUT_VERSION,
                })
            }
            Some(s) => Ok(Some(s)),
            None if self.shutting_down => Err(self.shut_down()),
            None => Ok(None),
        }
    }

    /// The newest buffered frame, releasing older ones (renderers).
    ///
    /// Holds at most one sample at a time (the `frame` service lets a subscriber borrow one):
    /// each older sample is released before the next one is taken, however many are pending.
    ///
    /// # Errors
    /// As [`Connection::recv_frame`].
    pub fn latest_frame(&mut self) -> Result<Option<FrameSample>, IpcError> {
        let mut newest = self.recv_frame()?;
        while newest.is_some() && self.frame_pending()? {
            // Release before borrowing the next: a second borrow fails with ExceedsMaxBorrows.
            drop(newest.take());
            newest = self.recv_frame()?;
        }
        Ok(newest)
    }

    /// Whether our `frame` subscriber holds more frames (`false` without a `frame` subscriber).
    ///
    /// # Errors
    /// [`IpcError::Iceoryx`] when the subscriber cannot be queried.
    pub fn frame_pending(&self) -> Result<bool, IpcError> {
        let Some(sub) = &self.frame_sub else {
            return Ok(false);
        };
        sub.has_samples()
            .map_err(|e| IpcError::iox("receive", &self.names.name("frame"), e))
    }

    /// Waits up to `timeout` for the next frame.
    ///
    /// # Errors
    /// As [`Connection::recv_frame`], plus [`IpcError::Interrupted`] on SIGINT/SIGTERM.
    pub fn wait_frame(&mut self, timeout: Duration) -> Result<Option<FrameSample>, IpcError> {
        let start = Instant::now();
        loop {
            if let Some(s) = self.recv_frame()? {
                return Ok(Some(s));
            }
            if start.elapsed() >= timeout {
                return Ok(None);
            }
            self.node
                .wait(Duration::from_micros(100))
                .map_err(|_| IpcError::Interrupted)?;
        }
    }

    /// The next buffered objects sample, if any, oldest first.
    ///
    /// # Errors
    /// As [`Connection::recv_frame`].
    pub fn recv_objects(&mut self) -> Result<Option<ObjectsSample>, IpcError> {
        self.poll_status()?;
        let Some(sub) = &self.objects_sub else {
            return Ok(None);
        };
        match sub
            .receive()
            .map_err(|e| IpcError::iox("receive", &self.names.name("objects"), e))?
        {
            Some(s) => Ok(Some(s)),
            None if self.shutting_down => Err(self.shut_down()),
            None => Ok(None),
        }
    }

    /// The next entry of the command log (every client's commands), if subscribed.
    ///
    /// # Errors
    /// iceoryx2 failures.
    pub fn recv_command_log(&mut self) -> Result<Option<CommandLogEntry>, IpcError> {
        let Some(sub) = &self.command_log_sub else {
            return Ok(None);
        };
        sub.receive()
            .map(|s| s.map(|s| *s.payload()))
            .map_err(|e| IpcError::iox("receive", &self.names.name("command_log"), e))
    }

    /// Sends a command without waiting; poll the returned handle with
    /// [`Connection::poll_reply`].
    ///
    /// # Errors
    /// iceoryx2 failures (e.g. too many commands in flight), or no command service opened.
    pub fn send_command(&mut self, cmd: &Command) -> Result<(u64, PendingCommand), IpcError> {
        let Some(client) = &self.command_client else {
            return Err(IpcError::iox(
                "send command",
                &self.names.name("command"),
                "not opened",
            ));
        };
        let sequence = self.next_sequence;
        self.next_sequence += 1;
        let pending = client
            .send_copy(crate::command::encode(cmd, sequence))
            .map_err(|e| IpcError::iox("send command", &self.names.name("command"), e))?;
        Ok((sequence, pending))
    }

    /// The reply to a pending command, if it arrived.
    ///
    /// # Errors
    /// iceoryx2 failures.
    pub fn poll_reply(&self, pending: &PendingCommand) -> Result<Option<Reply>, IpcError> {
        pending
            .receive()
            .map(|r| r.map(|r| Reply::from_msg(r.payload())))
            .map_err(|e| IpcError::iox("receive reply", &self.names.name("command"), e))
    }

    /// Sends a command and waits up to `timeout` for its reply.
    ///
    /// # Errors
    /// [`IpcError::NoReply`] after the timeout ([`IpcError::ServerStalled`] instead when the
    /// server says its loop is stalled), [`IpcError::ServerGone`], iceoryx2 failures.
    pub fn command(&mut self, cmd: &Command, timeout: Duration) -> Result<Reply, IpcError> {
        let (sequence, pending) = self.send_command(cmd)?;
        let start = Instant::now();
        loop {
            if let Some(r) = self.poll_reply(&pending)? {
                return Ok(r);
            }
            self.poll_status()?;
            if start.elapsed() >= timeout {
                if let Some(stalled) = self.stalled() {
                    return Err(stalled);
                }
                return Err(IpcError::NoReply {
                    sequence,
                    waited_ms: start.elapsed().as_millis() as u64,
                });
            }
            self.node
                .wait(Duration::from_micros(50))
                .map_err(|_| IpcError::Interrupted)?;
        }
    }
}
