//! Errors of the IPC layer (server and client helpers).

use crate::simulation::SimulationError;

/// Everything that can go wrong talking to or serving over iceoryx2.
#[derive(Debug, thiserror::Error)]
pub enum IpcError {
    /// An iceoryx2 call failed.
    #[error("iceoryx2: {op} failed for `{service}`: {detail}")]
    Iceoryx {
        /// What was attempted (e.g. "create service", "loan frame").
        op: &'static str,
        /// Service name or port concerned.
        service: String,
        /// iceoryx2's error.
        detail: String,
    },
    /// A service or node name was rejected by iceoryx2.
    #[error("invalid name `{name}`: {detail}")]
    BadName {
        /// The name.
        name: String,
        /// Why.
        detail: String,
    },
    /// Another live server already owns this prefix.
    #[error("prefix `{prefix}` is already served by another live process")]
    PrefixInUse {
        /// The prefix.
        prefix: String,
    },
    /// No server appeared under the prefix within the connect timeout.
    #[error(
        "no splatphys server under prefix `{prefix}` after {waited_ms} ms (is `splatphys serve` running?)"
    )]
    ServerNotFound {
        /// The prefix.
        prefix: String,
        /// How long the client waited, ms.
        waited_ms: u64,
    },
    /// The server's heartbeat stopped: it was killed or hangs.
    #[error("splatphys server under `{prefix}` is gone: no heartbeat for {silent_ms} ms")]
    ServerGone {
        /// The prefix.
        prefix: String,
        /// Time since the last heartbeat, ms.
        silent_ms: u64,
    },
    /// The server beats but its main loop has made no progress for
    /// [`crate::services::STALL_THRESHOLD`] or longer (a step that does not end).
    #[error(
        "splatphys server under `{prefix}` is stalled: its loop made no progress for {stalled_ms} ms (at step {step}); it is alive but not stepping or answering"
    )]
    ServerStalled {
        /// The prefix.
        prefix: String,
        /// Time since its loop last made progress, ms.
        stalled_ms: u64,
        /// Its step.
        step: u64,
    },
    /// The server announced a clean shutdown and everything it sent has been received.
    #[error("splatphys server under `{prefix}` shut down")]
    ServerShutDown {
        /// The prefix.
        prefix: String,
    },
    /// The lossless subscribers the server was told to wait for (recorders) did not all say
    /// they were ready in time (the readiness handshake of `docs/reference/protocol.md`).
    #[error(
        "waited {waited_ms} ms for {expected} lossless subscriber(s) (recorders) to connect every port and take the scene; {ready} did (is the recorder running, under the same service prefix and iceoryx2 file prefix?)"
    )]
    LosslessNotReady {
        /// Lossless subscribers expected.
        expected: usize,
        /// Those that said they were ready.
        ready: usize,
        /// How long the server waited, ms.
        waited_ms: u64,
    },
    /// The server speaks another layout version.
    #[error("layout version mismatch: server {server}, this client {client}")]
    LayoutMismatch {
        /// Server's [`crate::wire::LAYOUT_VERSION`].
        server: u32,
        /// Ours.
        client: u32,
    },
    /// A command got no reply in time.
    #[error("no reply to command #{sequence} within {waited_ms} ms")]
    NoReply {
        /// The command's sequence number.
        sequence: u64,
        /// How long we waited, ms.
        waited_ms: u64,
    },
    /// SIGINT or SIGTERM arrived while waiting.
    #[error("interrupted by a termination signal")]
    Interrupted,
    /// Shared memory cannot hold what the server would publish (checked at start, instead of a
    /// SIGBUS mid-run when a tmpfs page cannot be backed).
    #[error(
        "{path} has {free_mb:.0} MB free, but serving {gaussians} Gaussians needs about {needed_mb:.0} MB of shared memory ({detail}); enlarge it (docker: --shm-size; or remount /dev/shm with a larger size=), or serve a smaller scene"
    )]
    SharedMemoryTooSmall {
        /// The shared-memory file system.
        path: String,
        /// Free bytes there, MB.
        free_mb: f64,
        /// Bytes needed, MB.
        needed_mb: f64,
        /// Published Gaussians.
        gaussians: usize,
        /// How the need is made up.
        detail: String,
    },
    /// The simulation failed.
    #[error(transparent)]
    Simulation(#[from] SimulationError),
}

impl IpcError {
    /// Wraps an iceoryx2 error.
    pub(crate) fn iox(op: &'static str, service: &str, e: impl core::fmt::Debug) -> Self {
        IpcError::Iceoryx {
            op,
            service: service.to_owned(),
            detail: format!("{e:?}"),
        }
    }
}
