//! The recording loop: subscribe losslessly to a server and write everything to MCAP.

use std::collections::VecDeque;
use std::path::Path;
use std::time::{Duration, Instant};

use splatphys_ipc::IpcError;
use splatphys_ipc::client::{ClientOptions, Connection};
use splatphys_ipc::wire::{FrameHeader, ObjectName, ObjectState, SceneGaussian, SceneHeader};

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
/// The recorder keeps its side of the lossless contract (`docs/reference/protocol.md`): once every port
/// is connected it takes the scene (from history) and writes it, then tells the server it is
/// ready; after writing each frame with its objects it acknowledges it, so the server knows
/// what was taken before it shuts down.
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
    let mut held = Held::default();
    take_initial_scene(&mut conn, &mut held, &mut w, opts.connect_timeout)?;
    conn.announce_ready()?;
    let mut acknowledged = None;
    let end = loop {
        let mut busy = false;
        // A new generation's scene and names are held until its first frame: a lagging
        // recorder still has frames of the previous generation to write first.
        while let Some(s) = conn.recv_scene()? {
            held.scenes
                .push_back((*s.user_header(), s.payload().to_vec()));
            busy = true;
        }
        while let Some(n) = conn.recv_object_names()? {
            held.names
                .push_back((*n.user_header(), n.payload().to_vec()));
            busy = true;
        }
        while let Some(c) = conn.recv_command_log()? {
            w.command(&c)?;
            busy = true;
        }
        let frame = conn.recv_frame();
        // Objects are published right after their frame, but a lagging recorder can find the
        // objects of later frames already waiting: they are held back so that the file is in
        // frame order, each frame followed by its objects.
        loop {
            match conn.recv_objects() {
                Ok(Some(o)) => held
                    .objects
                    .push_back((*o.user_header(), o.payload().to_vec())),
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
        let end = match frame {
            Ok(Some(f)) => {
                let h = f.user_header();
                // The server publishes a generation's scene before its frames, but the two
                // services deliver independently: a frame can be seen first. Take its scene
                // before writing it (waiting at most ~100 ms).
                for _ in 0..50 {
                    if held.has_scene(h.scene_generation) {
                        break;
                    }
                    match conn.recv_scene()? {
                        Some(s) => held
                            .scenes
                            .push_back((*s.user_header(), s.payload().to_vec())),
                        None => std::thread::sleep(Duration::from_millis(2)),
                    }
                }
                held.write_before(&mut w, h.scene_generation, h.frame_index)?;
                w.frame(h, f.payload())?;
                held.last_frame = Some((h.scene_generation, h.frame_index));
                busy = true;
                opts.max_frames
                    .is_some_and(|n| w.counts.frames >= n)
                    .then_some(RecordEnd::MaxFrames)
            }
            Ok(None) => None,
            Err(IpcError::ServerShutDown { .. }) => Some(RecordEnd::ServerShutDown),
            Err(e @ IpcError::ServerGone { .. }) => Some(RecordEnd::ServerGone(e.to_string())),
            Err(IpcError::Interrupted) => Some(RecordEnd::Interrupted),
            Err(e) => return Err(e.into()),
        };
        // A frame's objects may come after it: write them as soon as they are there, and
        // acknowledge what has been written whole.
        if let Some((generation, frame_index)) = held.last_frame {
            held.write_before(&mut w, generation, frame_index + 1)?;
        }
        if w.taken() > acknowledged {
            acknowledged = w.taken();
            if let Some(frame_index) = acknowledged {
                conn.acknowledge(frame_index)?;
            }
        }
        if let Some(end) = end {
            break end;
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
    held.write_before(&mut w, u32::MAX, u64::MAX)?;
    let counts = w.finish()?;
    Ok((end, counts))
}

/// Takes the current scene and object names (the server keeps them in history, so they are
/// there once the subscribers are) and writes them, waiting up to `timeout` for the scene: the
/// first frame comes only after the recorder says it is ready, and a scene of 500k Gaussians
/// then costs no frame. A server that publishes no scene in time (a replay of a recording
/// without one) is recorded all the same.
fn take_initial_scene(
    conn: &mut Connection,
    held: &mut Held,
    w: &mut RunWriter,
    timeout: Duration,
) -> Result<(), RecordError> {
    let start = Instant::now();
    let generation = loop {
        if let Some(s) = conn.recv_scene()? {
            let h = *s.user_header();
            held.scenes.push_back((h, s.payload().to_vec()));
            break h.scene_generation;
        }
        // A signal ends the wait; the main loop sees it too and finishes the file.
        if start.elapsed() >= timeout || conn.node().wait(Duration::from_millis(1)).is_err() {
            return Ok(());
        }
    };
    while let Some(n) = conn.recv_object_names()? {
        held.names
            .push_back((*n.user_header(), n.payload().to_vec()));
    }
    held.write_before(w, generation, 0)
}

/// Messages taken from the services but not written yet, so that the file is in frame order:
/// a generation's scene and object names just before its first frame, each frame's objects right
/// after it.
#[derive(Default)]
struct Held {
    /// The newest scene generation written.
    written: Option<u32>,
    /// Generation and frame index of the newest frame written.
    last_frame: Option<(u32, u64)>,
    scenes: VecDeque<(SceneHeader, Vec<SceneGaussian>)>,
    names: VecDeque<(FrameHeader, Vec<ObjectName>)>,
    objects: VecDeque<(FrameHeader, Vec<ObjectState>)>,
}

impl Held {
    /// Whether the scene of `generation` (or a later one) was written or is held.
    fn has_scene(&self, generation: u32) -> bool {
        self.written.is_some_and(|g| g >= generation)
            || self
                .scenes
                .iter()
                .any(|(h, _)| h.scene_generation >= generation)
    }

    /// Writes the scenes and names of generations up to `generation` and the objects of frames
    /// before `frame_index`, each in the order received.
    fn write_before(
        &mut self,
        w: &mut RunWriter,
        generation: u32,
        frame_index: u64,
    ) -> Result<(), RecordError> {
        while let Some((h, _)) = self.scenes.front()
            && h.scene_generation <= generation
        {
            let (h, payload) = self.scenes.pop_front().expect("front exists");
            w.scene(&h, &payload)?;
            self.written = Some(h.scene_generation);
        }
        while let Some((h, _)) = self.names.front()
            && h.scene_generation <= generation
        {
            let (h, payload) = self.names.pop_front().expect("front exists");
            w.object_names(&h, &payload)?;
        }
        while let Some((h, _)) = self.objects.front()
            && h.frame_index < frame_index
        {
            let (h, payload) = self.objects.pop_front().expect("front exists");
            w.objects(&h, &payload)?;
        }
        Ok(())
    }
}
