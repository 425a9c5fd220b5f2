//! The recording loop: subscribe losslessly to a server and write everything to MCAP.

use std::path::Path;
use std::time::{Duration, Instant};

use splatphys_ipc::IpcError;
use splatphys_ipc::client::{ClientOptions, Connection};

use crate::error::RecordError;
use crate::writer::{RunWriter, WriteCounts, WriterOptions};

/// How to record.
#[derive(Debug, Clone)]
pub struct RecordOptions {
    /// Service prefix of the server.
    pub prefix: String,
    /// Output file options.
    pub writer: WriterOptions,
    /// How long to wait for the server to appear.
    pub connect_timeout: Duration,
    /// Stop after this many frames.
    pub max_frames: Option<u64>,
    /// Close the open chunk this often so a killed recorder loses little. Default 1 s.
    pub flush_period: Duration,
}

impl RecordOptions {
    /// Defaults for `prefix`.
    pub fn new(prefix: &str) -> Self {
        Self {
            prefix: prefix.to_owned(),
            writer: WriterOptions::default(),
            connect_timeout: Duration::from_secs(5),
            max_frames: None,
            flush_period: Duration::from_secs(1),
        }
    }
}

/// Why recording stopped.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum RecordEnd {
    /// The server shut down cleanly; everything it sent is in the file.
    ServerShutDown,
    /// `max_frames` reached.
    MaxFrames,
    /// SIGINT/SIGTERM.
    Interrupted,
    /// The server died (no heartbeat); the file is closed properly anyway.
    ServerGone(String),
}

/// Records until the server shuts down (or dies, or a signal, or `max_frames`); the file is
/// always finished with a summary.
///
/// # Errors
/// Connecting, iceoryx2 and file errors.
pub fn record(out: &Path, opts: &RecordOptions) -> Result<(RecordEnd, WriteCounts), RecordError> {
    let mut copts = ClientOptions::new(&opts.prefix).lossless();
    copts.node_name = "splatphys-record".into();
    copts.connect_timeout = opts.connect_timeout;
    copts.commands = false;
    copts.command_log = true;
    let mut conn = Connection::connect(&copts)?;
    let mut w = RunWriter::create(out, opts.writer)?;
    let mut last_flush = Instant::now();
    let mut last_heartbeat = 0;
    let end = loop {
        let mut busy = false;
        while let Some(s) = conn.recv_scene()? {
            w.scene(s.user_header(), s.payload())?;
            busy = true;
        }
        while let Some(n) = conn.recv_object_names()? {
            w.object_names(n.user_header(), n.payload())?;
            busy = true;
        }
        while let Some(c) = conn.recv_command_log()? {
            w.command(&c)?;
            busy = true;
        }
        let frame = conn.recv_frame();
        // Objects are published right after their frame; drain them in either case.
        loop {
            match conn.recv_objects() {
                Ok(Some(o)) => w.objects(o.user_header(), o.payload())?,
                Ok(None) | Err(IpcError::ServerShutDown { .. }) => break,
                Err(IpcError::ServerGone { .. }) => break,
                Err(e) => return Err(e.into()),
            }
        }
        if let Some(s) = conn.poll_status().ok().flatten()
            && s.heartbeat != last_heartbeat
        {
            last_heartbeat = s.heartbeat;
            w.status(&s)?;
        }
        match frame {
            Ok(Some(f)) => {
                w.frame(f.user_header(), f.payload())?;
                busy = true;
                if opts.max_frames.is_some_and(|n| w.counts.frames >= n) {
                    break RecordEnd::MaxFrames;
                }
            }
            Ok(None) => {}
            Err(IpcError::ServerShutDown { .. }) => break RecordEnd::ServerShutDown,
            Err(e @ IpcError::ServerGone { .. }) => break RecordEnd::ServerGone(e.to_string()),
            Err(IpcError::Interrupted) => break RecordEnd::Interrupted,
            Err(e) => return Err(e.into()),
        }
        if last_flush.elapsed() >= opts.flush_period {
            w.flush()?;
            last_flush = Instant::now();
        }
        // Signals are looked at every iteration: a recorder that is the bottleneck is never
        // idle, and must still stop (and finish its file) on SIGINT/SIGTERM.
        let idle = if busy {
            Duration::ZERO
        } else {
            Duration::from_micros(100)
        };
        if conn.node().wait(idle).is_err() {
            break RecordEnd::Interrupted;
        }
    };
    let counts = w.finish()?;
    Ok((end, counts))
}
