//! The status heartbeat: a thread that publishes [`Status`] at [`STATUS_PERIOD`] (10 Hz),
//! independent of how long a simulation step takes, so clients can tell a slow server from a
//! dead one. The server loop updates the shared snapshot; the thread stamps the heartbeat
//! counter and publishes. On stop it publishes one last status with the given extra flags
//! (e.g. [`crate::wire::STATUS_SHUTTING_DOWN`]).
//!
//! Liveness is not the beat itself: the server loop counts its progress ([`Heartbeat::tick`],
//! once per loop iteration and once per substep) and the thread publishes how long the count
//! has stood still; past [`STALL_THRESHOLD`] it sets [`STATUS_STALLED`]. So a client tells a
//! server that is gone (no beat) from one that is stalled (beats, no progress).

use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;

use crate::error::IpcError;
use crate::services::{
    Role, STALL_THRESHOLD, STATUS_PERIOD, ServiceNames, create_node, status_service,
};
use crate::wire::{STATUS_STALLED, Status};

/// Handle to the heartbeat thread.
#[derive(Debug)]
pub struct Heartbeat {
    snapshot: Arc<Mutex<Status>>,
    stop: Arc<AtomicBool>,
    final_flags: Arc<AtomicU32>,
    progress: Arc<AtomicU64>,
    thread: Option<JoinHandle<Result<u64, IpcError>>>,
}

impl Heartbeat {
    /// Creates the `status` service (as its owner) and starts beating.
    ///
    /// # Errors
    /// When the service cannot be created; reported before the thread returns.
    pub fn start(names: &ServiceNames) -> Result<Self, IpcError> {
        let snapshot = Arc::new(Mutex::new(Status::default()));
        let stop = Arc::new(AtomicBool::new(false));
        let final_flags = Arc::new(AtomicU32::new(0));
        let progress = Arc::new(AtomicU64::new(0));
        let (ready_tx, ready_rx) = std::sync::mpsc::channel::<Result<(), IpcError>>();
        let thread = {
            let (names, snapshot, stop, final_flags, progress) = (
                names.clone(),
                snapshot.clone(),
                stop.clone(),
                final_flags.clone(),
                progress.clone(),
            );
            std::thread::Builder::new()
                .name("splatphys-heartbeat".into())
                .spawn(move || -> Result<u64, IpcError> {
                    let setup = (|| {
                        let node = create_node("splatphys-heartbeat")?;
                        let service = status_service(&node, &names, Role::Owner)?;
                        let publisher = service.publisher_builder().create().map_err(|e| {
                            IpcError::iox("create publisher", &names.name("status"), e)
                        })?;
                        Ok((node, service, publisher))
                    })();
                    let (_node, _service, publisher) = match setup {
                        Ok(v) => {
                            let _ = ready_tx.send(Ok(()));
                            v
                        }
                        Err(e) => {
                            let _ = ready_tx.send(Err(e));
                            return Ok(0);
                        }
                    };
                    let mut beat = 0u64;
                    let mut seen = (u64::MAX, std::time::Instant::now());
                    let mut publish = |extra: u32| {
                        beat += 1;
                        let mut s = *snapshot.lock().unwrap_or_else(PoisonError::into_inner);
                        s.heartbeat = beat;
                        let now = progress.load(Ordering::Acquire);
                        if now != seen.0 {
                            seen = (now, std::time::Instant::now());
                        }
                        let age = seen.1.elapsed();
                        s.progress = now;
                        s.progress_age_ms = age.as_millis().min(u32::MAX as u128) as u32;
                        if age > STALL_THRESHOLD {
                            s.flags |= STATUS_STALLED;
                        }
                        s.flags |= extra;
                        publisher
                            .send_copy(s)
                            .map_err(|e| IpcError::iox("send status", "status", e))
                    };
                    while !stop.load(Ordering::Acquire) {
                        publish(0)?;
                        // Sleep in small slices so a stop is seen quickly.
                        let until = std::time::Instant::now() + STATUS_PERIOD;
                        while std::time::Instant::now() < until && !stop.load(Ordering::Acquire) {
                            std::thread::sleep(std::time::Duration::from_millis(5));
                        }
                    }
                    publish(final_flags.load(Ordering::Acquire))?;
                    Ok(beat)
                })
                .map_err(|e| IpcError::iox("spawn heartbeat thread", "status", e))?
        };
        match ready_rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(e),
            Err(_) => return Err(IpcError::iox("start heartbeat", "status", "thread died")),
        }
        Ok(Self {
            snapshot,
            stop,
            final_flags,
            progress,
            thread: Some(thread),
        })
    }

    /// Counts one unit of main-loop progress (a loop iteration or a substep).
    pub fn tick(&self) {
        self.progress.fetch_add(1, Ordering::Release);
    }

    /// Replaces the snapshot the next beats publish (the heartbeat counter is filled in).
    pub fn update(&self, status: &Status) {
        *self.snapshot.lock().unwrap_or_else(PoisonError::into_inner) = *status;
    }

    /// Publishes a last status with `final_flags` added, stops, and returns the beats sent.
    ///
    /// # Errors
    /// When a status could not be sent.
    pub fn finish(mut self, final_flags: u32) -> Result<u64, IpcError> {
        self.final_flags.store(final_flags, Ordering::Release);
        self.stop.store(true, Ordering::Release);
        match self.thread.take().map(JoinHandle::join) {
            Some(Ok(r)) => r,
            Some(Err(_)) => Err(IpcError::iox("join heartbeat", "status", "thread panicked")),
            None => Ok(0),
        }
    }
}

impl Drop for Heartbeat {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
