//! How a server runs ([`ServerConfig`]), why it stopped ([`StopReason`]) and what it did
//! ([`ServerReport`]).

use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

#[cfg(doc)]
use crate::error::IpcError;
use crate::validate::Limits;
#[cfg(doc)]
use crate::wire::STATUS_FINISHED;

/// How the server runs.
#[derive(Debug, Clone)]
pub struct ServerConfig {
    /// Service prefix; `None` = `splatphys/<scene name>`.
    pub prefix: Option<String>,
    /// Pace frames to simulated time instead of running as fast as possible.
    pub realtime: bool,
    /// Longest wait on a full lossless subscriber per frame. Default 2 s: a live recorder that
    /// is slower than the simulation is waited for (lossless means the run slows down, not
    /// that frames go missing); a stopped one costs one such wait, then is not waited for
    /// until it catches up ([`crate::backpressure`]).
    pub lossless_limit: Duration,
    /// Command value limits.
    pub limits: Limits,
    /// Period of dead-node cleanup. Default 1 s.
    pub cleanup_period: Duration,
    /// Stop after publishing this many frames after the initial one.
    pub max_frames: Option<u64>,
    /// Stop when the simulation reports it is finished. Otherwise the server holds the last
    /// frame, paused, with [`STATUS_FINISHED`] in `status`, and keeps answering: `step N` steps
    /// past the end, `resume` runs one more scene duration, `reset` starts over. Default true
    /// (a job); `splatphys serve` turns it off unless `--exit-at-end`.
    pub exit_when_finished: bool,
    /// Start paused.
    pub start_paused: bool,
    /// Set to stop the server from another thread.
    pub stop: Arc<AtomicBool>,
    /// Publish no frame until this many lossless subscribers (recorders) have said they are
    /// ready: every port connected and the scene taken (0 = do not wait). Past
    /// [`ServerConfig::wait_timeout`] the server fails with [`IpcError::LosslessNotReady`].
    /// The main job uses it so the recording holds every step, the initial one once.
    pub wait_for_lossless: usize,
    /// Publish no frame until this many `frame` subscribers of any kind are connected (0 = do
    /// not wait); past [`ServerConfig::wait_timeout`] the server says so and starts anyway.
    /// For tools and tests whose best-effort clients should see the initial frame.
    pub wait_for_subscribers: usize,
    /// Longest wait for those subscribers. Default 10 s.
    pub wait_timeout: Duration,
}

impl Default for ServerConfig {
    fn default() -> Self {
        Self {
            prefix: None,
            realtime: false,
            lossless_limit: Duration::from_secs(2),
            limits: Limits::default(),
            cleanup_period: Duration::from_secs(1),
            max_frames: None,
            exit_when_finished: true,
            start_paused: false,
            stop: Arc::default(),
            wait_for_lossless: 0,
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
    /// Frames lossless subscribers lost: dropped past the backpressure limit, or not taken
    /// when the server stopped.
    pub recorder_frames_lost: u64,
    /// Steps that failed and were rolled back to the last good frame.
    pub step_failures: u64,
    /// Wall time spent stepping vs. publishing, seconds.
    pub step_wall_s: f64,
    /// Wall time spent loaning, writing and sending frames and objects, seconds.
    pub publish_wall_s: f64,
    /// Wall time spent saving the checkpoint a failed step goes back to, seconds.
    pub checkpoint_wall_s: f64,
}
