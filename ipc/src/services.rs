//! Every service of the contract, its name and its settings, defined once.
//!
//! Servers and clients both go through the `*_service` functions here, so no two processes can
//! open a service with different settings (iceoryx2 refuses that). Names live under a prefix,
//! `splatphys/<scene name>` by default: two servers with different prefixes never cross-talk.
//!
//! | service   | pattern              | payload / header                    | delivery |
//! |-----------|----------------------|-------------------------------------|----------|
//! | `scene`   | publish-subscribe    | `[SceneGaussian]` / `SceneHeader`   | history 1, overflow |
//! | `object_names` | publish-subscribe | `[ObjectName]` / `FrameHeader`   | history 1, overflow |
//! | `frame`   | publish-subscribe    | `[FrameGaussian]` / `FrameHeader`   | no overflow, backpressure |
//! | `objects` | publish-subscribe    | `[ObjectState]` / `FrameHeader`     | no overflow, backpressure |
//! | `status`  | publish-subscribe    | `Status`                            | history 1, overflow |
//! | `command` | request-response     | `CommandMsg` -> `ReplyMsg`          | replies never block the server |
//! | `command_log` | publish-subscribe | `CommandLogEntry`                  | buffer 256, overflow |
//! | `lossless_ack` | publish-subscribe | `LosslessAck` (clients to server) | buffer 64, overflow |
//!
//! The iceoryx2 file prefix (default `iox2_`) can be changed with the environment variable
//! [`IOX2_PREFIX_ENV`], which isolates test runs from each other.

use core::time::Duration;

use iceoryx2::config::Config;
use iceoryx2::node::Node;
use iceoryx2::prelude::{
    CallbackProgression, FileName, LogLevel, NodeBuilder, NodeName, SemanticString, ServiceName,
    set_log_level_from_env_or,
};
use iceoryx2::service::port_factory::{publish_subscribe, request_response};

use crate::error::IpcError;
use crate::wire::{
    CommandLogEntry, CommandMsg, FrameGaussian, FrameHeader, LosslessAck, ObjectName, ObjectState,
    ReplyMsg, SceneGaussian, SceneHeader, Status,
};

/// The iceoryx2 service flavour used everywhere (inter-process, single-threaded ports).
pub type Iox = iceoryx2::service::ipc::Service;
/// `scene` port factory.
pub type SceneService = publish_subscribe::PortFactory<Iox, [SceneGaussian], SceneHeader>;
/// `object_names` port factory.
pub type ObjectNamesService = publish_subscribe::PortFactory<Iox, [ObjectName], FrameHeader>;
/// `frame` port factory.
pub type FrameService = publish_subscribe::PortFactory<Iox, [FrameGaussian], FrameHeader>;
/// `objects` port factory.
pub type ObjectsService = publish_subscribe::PortFactory<Iox, [ObjectState], FrameHeader>;
/// `status` port factory.
pub type StatusService = publish_subscribe::PortFactory<Iox, Status, ()>;
/// `command_log` port factory.
pub type CommandLogService = publish_subscribe::PortFactory<Iox, CommandLogEntry, ()>;
/// `lossless_ack` port factory.
pub type LosslessAckService = publish_subscribe::PortFactory<Iox, LosslessAck, ()>;
/// `command` port factory.
pub type CommandService = request_response::PortFactory<Iox, CommandMsg, (), ReplyMsg, ()>;

/// Environment variable overriding the iceoryx2 file prefix (default `iox2_`).
pub const IOX2_PREFIX_ENV: &str = "SPLATPHYS_IOX2_PREFIX";
/// Period of the status heartbeat (10 Hz).
pub const STATUS_PERIOD: Duration = Duration::from_millis(100);
/// The server calls itself stalled ([`crate::wire::STATUS_STALLED`]) when its main loop made no
/// progress for this long. Progress is counted per substep, so a healthy 1M-particle scene
/// (0.2-0.4 s per substep on two cores) stays far below it.
pub const STALL_THRESHOLD: Duration = Duration::from_secs(5);
/// A client declares the server gone after this long without a heartbeat.
pub const HEARTBEAT_TIMEOUT: Duration = Duration::from_secs(1);
/// Port name a subscriber uses to ask for lossless delivery of `frame` and `objects`.
pub const LOSSLESS_PORT_NAME: &str = "lossless";
/// Maximum subscribers per data service.
pub const MAX_SUBSCRIBERS: usize = 8;
/// Maximum frames a `frame`/`objects` subscriber may buffer.
pub const MAX_FRAME_BUFFER: usize = 4;
/// Maximum nodes per service (server, clients, tools).
const MAX_NODES: usize = 32;

/// Whether the caller owns the service (the server) or uses it (a client).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// Creates the service; fails if a live process already owns it.
    Owner,
    /// Opens an existing service; fails if it does not exist.
    User,
}

/// The names of all services under one prefix.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ServiceNames {
    prefix: String,
}

impl ServiceNames {
    /// Services under `prefix` (no trailing slash needed).
    pub fn new(prefix: &str) -> Self {
        Self {
            prefix: prefix.trim_end_matches('/').to_owned(),
        }
    }

    /// The default prefix for a scene: `splatphys/<scene name>`.
    pub fn default_prefix(scene_name: &str) -> String {
        format!("splatphys/{scene_name}")
    }

    /// The prefix.
    pub fn prefix(&self) -> &str {
        &self.prefix
    }

    /// Full name of service `leaf` (`scene`, `frame`, `objects`, `status`, `command`).
    pub fn name(&self, leaf: &str) -> String {
        format!("{}/{leaf}", self.prefix)
    }

    fn service_name(&self, leaf: &str) -> Result<ServiceName, IpcError> {
        let name = self.name(leaf);
        ServiceName::new(&name).map_err(|e| IpcError::BadName {
            name,
            detail: format!("{e:?}"),
        })
    }
}

/// The iceoryx2 configuration every splatphys process uses (see [`IOX2_PREFIX_ENV`]).
pub fn iox_config() -> Result<Config, IpcError> {
    // iceoryx2 warns on stderr when no config file exists; keep it quiet unless asked for.
    set_log_level_from_env_or(LogLevel::Error);
    let mut config = Config::global_config().clone();
    if let Ok(prefix) = std::env::var(IOX2_PREFIX_ENV) {
        config.global.prefix = FileName::new(prefix.as_bytes()).map_err(|e| IpcError::BadName {
            name: prefix.clone(),
            detail: format!("{e:?}"),
        })?;
    }
    Ok(config)
}

/// Creates a node named `name` with the splatphys configuration. SIGINT/SIGTERM are caught
/// and reported by `Node::wait`.
pub fn create_node(name: &str) -> Result<Node<Iox>, IpcError> {
    let config = iox_config()?;
    let node_name = NodeName::new(name).map_err(|e| IpcError::BadName {
        name: name.to_owned(),
        detail: format!("{e:?}"),
    })?;
    NodeBuilder::new()
        .name(&node_name)
        .config(&config)
        .create::<Iox>()
        .map_err(|e| IpcError::iox("create node", name, e))
}

/// Removes the shared-memory resources of every dead splatphys/iceoryx2 node (e.g. a server
/// killed with SIGKILL). Call it after dropping a [`crate::client::Connection`] whose server
/// died: while a client still holds the dead server's services they cannot be removed.
/// Returns (nodes cleaned, nodes that could not be cleaned).
///
/// # Errors
/// When no node can be created.
pub fn cleanup_dead_nodes() -> Result<(u64, u64), IpcError> {
    let node = create_node("splatphys-cleanup")?;
    let state = node.blocking_cleanup_dead_nodes(Duration::from_millis(200));
    Ok((state.cleanups, state.failed_cleanups))
}

/// Every subscriber of a `frame` or `objects` dynamic config: (iceoryx2 subscriber id, whether
/// it asked for lossless delivery through [`LOSSLESS_PORT_NAME`]).
macro_rules! list_subscribers {
    ($service:expr) => {{
        use iceoryx2::service::port_factory::PortFactory;
        let mut out = Vec::new();
        $service.dynamic_config().list_subscribers(|d| {
            out.push((
                d.subscriber_id.value(),
                d.subscriber_name.as_str() == LOSSLESS_PORT_NAME,
            ));
            CallbackProgression::Continue
        });
        out
    }};
}

/// Every subscriber of the `frame` service: (iceoryx2 subscriber id, whether it asked for
/// lossless delivery through [`LOSSLESS_PORT_NAME`]). Feeds
/// [`crate::backpressure::LagBook::set_subscribers`].
pub fn frame_subscribers(service: &FrameService) -> Vec<(u128, bool)> {
    list_subscribers!(service)
}

/// Every subscriber of the `objects` service, as [`frame_subscribers`].
pub fn objects_subscribers(service: &ObjectsService) -> Vec<(u128, bool)> {
    list_subscribers!(service)
}

macro_rules! open_by_role {
    ($builder:expr, $role:expr, $name:expr) => {
        match $role {
            Role::Owner => $builder
                .create()
                .map_err(|e| IpcError::iox("create service", &$name, e)),
            Role::User => $builder
                .open()
                .map_err(|e| IpcError::iox("open service", &$name, e)),
        }
    };
}

/// The settings of the services published once per scene generation (`scene`,
/// `object_names`): the last sample kept (history 1, overflow) so a late client gets it on
/// connect.
/// `scene` and `object_names`: history 1 for late clients, and a buffer of
/// [`MAX_FRAME_BUFFER`] + 1 generations per subscriber. The server waits for a lossless
/// subscriber's frames, so it is never more than [`MAX_FRAME_BUFFER`] frames behind, and a new
/// generation needs at least one frame: such a subscriber never loses a generation, however
/// often the clients reset.
macro_rules! once_per_generation {
    ($builder:expr) => {
        $builder
            .enable_safe_overflow(true)
            .history_size(1)
            .subscriber_max_buffer_size(MAX_FRAME_BUFFER + 1)
            .subscriber_max_borrowed_samples(1)
            .max_subscribers(MAX_SUBSCRIBERS)
            .max_publishers(1)
            .max_nodes(MAX_NODES)
    };
}

/// The `scene` service: static Gaussian data, once per generation, history 1 so late clients
/// get it on connect.
pub fn scene_service(
    node: &Node<Iox>,
    names: &ServiceNames,
    role: Role,
) -> Result<SceneService, IpcError> {
    let b = node
        .service_builder(&names.service_name("scene")?)
        .publish_subscribe::<[SceneGaussian]>()
        .user_header::<SceneHeader>();
    let b = once_per_generation!(b);
    open_by_role!(b, role, names.name("scene"))
}

/// The `object_names` service: every object's name, once per generation with the scene,
/// history 1 so late clients get it on connect.
pub fn object_names_service(
    node: &Node<Iox>,
    names: &ServiceNames,
    role: Role,
) -> Result<ObjectNamesService, IpcError> {
    let b = node
        .service_builder(&names.service_name("object_names")?)
        .publish_subscribe::<[ObjectName]>()
        .user_header::<FrameHeader>();
    let b = once_per_generation!(b);
    open_by_role!(b, role, names.name("object_names"))
}

/// The `frame` service: per published step, the dynamic state of every visible Gaussian.
/// No overflow: a full subscriber buffer goes through the server's backpressure handler.
pub fn frame_service(
    node: &Node<Iox>,
    names: &ServiceNames,
    role: Role,
) -> Result<FrameService, IpcError> {
    let b = node
        .service_builder(&names.service_name("frame")?)
        .publish_subscribe::<[FrameGaussian]>()
        .user_header::<FrameHeader>()
        .enable_safe_overflow(false)
        .history_size(0)
        .subscriber_max_buffer_size(MAX_FRAME_BUFFER)
        .subscriber_max_borrowed_samples(1)
        .max_subscribers(MAX_SUBSCRIBERS)
        .max_publishers(1)
        .max_nodes(MAX_NODES);
    open_by_role!(b, role, names.name("frame"))
}

/// The `objects` service: per published step, the state of every object.
pub fn objects_service(
    node: &Node<Iox>,
    names: &ServiceNames,
    role: Role,
) -> Result<ObjectsService, IpcError> {
    let b = node
        .service_builder(&names.service_name("objects")?)
        .publish_subscribe::<[ObjectState]>()
        .user_header::<FrameHeader>()
        .enable_safe_overflow(false)
        .history_size(0)
        .subscriber_max_buffer_size(16)
        .subscriber_max_borrowed_samples(2)
        .max_subscribers(MAX_SUBSCRIBERS)
        .max_publishers(1)
        .max_nodes(MAX_NODES);
    open_by_role!(b, role, names.name("objects"))
}

/// The `status` service: heartbeat and statistics, history 1.
pub fn status_service(
    node: &Node<Iox>,
    names: &ServiceNames,
    role: Role,
) -> Result<StatusService, IpcError> {
    let b = node
        .service_builder(&names.service_name("status")?)
        .publish_subscribe::<Status>()
        .enable_safe_overflow(true)
        .history_size(1)
        .subscriber_max_buffer_size(4)
        .subscriber_max_borrowed_samples(1)
        .max_subscribers(2 * MAX_SUBSCRIBERS)
        .max_publishers(1)
        .max_nodes(MAX_NODES);
    open_by_role!(b, role, names.name("status"))
}

/// The `command` service: request-response; requests are never overwritten, and replies never
/// block the server (a dead client just loses its reply).
pub fn command_service(
    node: &Node<Iox>,
    names: &ServiceNames,
    role: Role,
) -> Result<CommandService, IpcError> {
    let b = node
        .service_builder(&names.service_name("command")?)
        .request_response::<CommandMsg, ReplyMsg>()
        .enable_safe_overflow_for_requests(false)
        .enable_safe_overflow_for_responses(true)
        .max_active_requests_per_client(64)
        .max_response_buffer_size(4)
        .max_servers(1)
        .max_clients(2 * MAX_SUBSCRIBERS)
        .max_nodes(MAX_NODES);
    open_by_role!(b, role, names.name("command"))
}

/// The `command_log` service: every command received and its reply, for recorders.
pub fn command_log_service(
    node: &Node<Iox>,
    names: &ServiceNames,
    role: Role,
) -> Result<CommandLogService, IpcError> {
    let b = node
        .service_builder(&names.service_name("command_log")?)
        .publish_subscribe::<CommandLogEntry>()
        .enable_safe_overflow(true)
        .history_size(0)
        .subscriber_max_buffer_size(256)
        .subscriber_max_borrowed_samples(1)
        .max_subscribers(MAX_SUBSCRIBERS)
        .max_publishers(1)
        .max_nodes(MAX_NODES);
    open_by_role!(b, role, names.name("command_log"))
}

/// The `lossless_ack` service: lossless subscribers (one publisher each) tell the server that
/// they are ready and which frame they took last ([`LosslessAck`]); the server is its one
/// subscriber. Acknowledgements are cumulative, so an overwritten one loses nothing.
pub fn lossless_ack_service(
    node: &Node<Iox>,
    names: &ServiceNames,
    role: Role,
) -> Result<LosslessAckService, IpcError> {
    let b = node
        .service_builder(&names.service_name("lossless_ack")?)
        .publish_subscribe::<LosslessAck>()
        .enable_safe_overflow(true)
        .history_size(0)
        .subscriber_max_buffer_size(64)
        .subscriber_max_borrowed_samples(1)
        .max_subscribers(1)
        .max_publishers(MAX_SUBSCRIBERS)
        .max_nodes(MAX_NODES);
    open_by_role!(b, role, names.name("lossless_ack"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_live_under_the_prefix() {
        let n = ServiceNames::new("splatphys/vase/");
        assert_eq!(n.name("frame"), "splatphys/vase/frame");
        assert_eq!(ServiceNames::default_prefix("vase"), "splatphys/vase");
    }
}
