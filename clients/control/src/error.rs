//! Errors of the controller library.

use splatphys_ipc::IpcError;

/// Everything that can go wrong controlling a server.
#[derive(Debug, thiserror::Error)]
pub enum ControlError {
    /// Talking to the server failed (not found, gone, no reply, iceoryx2 failure).
    #[error(transparent)]
    Ipc(#[from] IpcError),
    /// A vector argument could not be parsed.
    #[error("`{input}` is not a vector x,y,z: {reason}")]
    BadVector {
        /// The text given.
        input: String,
        /// Why it was refused.
        reason: String,
    },
    /// A named object does not exist in the scene.
    #[error("no object named `{name}` in the scene (objects: {known})")]
    UnknownObject {
        /// The name given.
        name: String,
        /// The scene's object names, comma separated.
        known: String,
    },
    /// The server's scene header did not arrive in time (needed to resolve object names).
    #[error("no scene header from the server within {waited_ms} ms")]
    NoScene {
        /// How long we waited, ms.
        waited_ms: u64,
    },
    /// A value that is not one of the accepted names.
    #[error("unknown {what} `{input}` (expected one of: {expected})")]
    UnknownName {
        /// What kind of name (e.g. "material model").
        what: &'static str,
        /// The text given.
        input: String,
        /// The accepted names.
        expected: String,
    },
    /// A timeline file could not be read or parsed.
    #[error("timeline {path}: {detail}")]
    Timeline {
        /// The file.
        path: String,
        /// What is wrong, with the line where known.
        detail: String,
    },
    /// One event of a timeline is incomplete or inconsistent.
    #[error("timeline {path}: event {index} (at_s = {at_s}): {detail}")]
    TimelineEvent {
        /// The file.
        path: String,
        /// 0-based index of the `[[event]]` table.
        index: usize,
        /// Its time, seconds.
        at_s: f64,
        /// What is wrong.
        detail: String,
    },
}

impl ControlError {
    /// Whether the error is about reaching the server (not found, gone, shut down, no reply)
    /// rather than about the input.
    pub fn is_connection(&self) -> bool {
        matches!(
            self,
            ControlError::Ipc(
                IpcError::ServerNotFound { .. }
                    | IpcError::ServerGone { .. }
                    | IpcError::ServerShutDown { .. }
                    | IpcError::NoReply { .. }
                    | IpcError::Iceoryx { .. }
            ) | ControlError::NoScene { .. }
        )
    }
}
