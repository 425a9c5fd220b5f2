//! Errors of the recorder library.

/// What can go wrong recording, reading or replaying.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// File I/O.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The MCAP library failed.
    #[error("{path}: mcap: {source}")]
    Mcap {
        /// The file.
        path: String,
        /// The mcap error.
        source: mcap::McapError,
    },
    /// The file is truncated or corrupt (a bad chunk CRC, a cut record); `--recover` reads what
    /// comes before the damage.
    #[error(
        "{path}: truncated or corrupt recording ({source}); replay and read it with --recover to use the messages before the damage"
    )]
    Corrupt {
        /// The file.
        path: String,
        /// What the MCAP reader found.
        source: mcap::McapError,
    },
    /// A message on a raw channel is shorter than its header or not a whole number of elements.
    #[error("{path}: message {sequence} on {topic} has {len} bytes, not a valid {what}")]
    BadMessage {
        /// The file.
        path: String,
        /// Topic.
        topic: String,
        /// Message sequence number.
        sequence: u32,
        /// Bytes found.
        len: usize,
        /// Expected layout.
        what: &'static str,
    },
    /// Writing an exported frame failed (the file and what went wrong).
    #[error(transparent)]
    Format(#[from] splatphys_formats::FormatError),
    /// The IPC layer failed.
    #[error(transparent)]
    Ipc(#[from] splatphys_ipc::IpcError),
}
