//! Time-limited backpressure for lossless subscribers.
//!
//! The `frame` and `objects` services do not overflow, so a full subscriber buffer calls the
//! publisher's backpressure handler. [`LagBook::handler`] decides per subscriber:
//! - a best-effort subscriber (renderer, controller) loses the frame at once (it takes the
//!   newest frame anyway) and the drop is counted;
//! - a lossless subscriber (port name [`crate::services::LOSSLESS_PORT_NAME`], the recorder) is
//!   waited for up to the limit (default 2 s); past it the frame is dropped for it, counted
//!   as lost, and the subscriber is marked lagging: while lagging it is not waited for again,
//!   so a stopped (SIGSTOP) or dead recorder cannot freeze the server. It stops lagging as soon
//!   as a frame is delivered to it without backpressure.

use std::collections::{HashMap, HashSet};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use iceoryx2::port::{BackpressureAction, BackpressureInfo};

use crate::wire::{MAX_REPORTED_SUBSCRIBERS, SubscriberLag};

/// Per-subscriber counters.
#[derive(Debug, Clone, Copy, Default)]
struct SubscriberStats {
    dropped: u64,
    max_wait: Duration,
    lagging: bool,
    last_full_frame: u64,
}

#[derive(Debug, Default)]
struct Book {
    lossless: HashSet<u128>,
    stats: HashMap<u128, SubscriberStats>,
    best_effort_dropped: u64,
    lossless_lost: u64,
}

/// Shared state between the server loop and a publisher's backpressure handler.
#[derive(Debug, Clone)]
pub struct LagBook {
    limit: Duration,
    frame: Arc<AtomicU64>,
    book: Arc<Mutex<Book>>,
}

/// Totals for the status message.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LagTotals {
    /// Frames best-effort subscribers skipped.
    pub best_effort_dropped: u64,
    /// Frames lossless subscribers lost past the limit.
    pub lossless_lost: u64,
    /// Lossless subscribers currently lagging.
    pub lagging: u32,
}

impl LagBook {
    /// A book waiting at most `limit` on a lossless subscriber.
    pub fn new(limit: Duration) -> Self {
        Self {
            limit,
            frame: Arc::new(AtomicU64::new(0)),
            book: Arc::default(),
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Book> {
        self.book.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// The handler to give the publisher.
    pub fn handler(&self) -> impl Fn(&BackpressureInfo) -> BackpressureAction + Send + 'static {
        let this = self.clone();
        move |info: &BackpressureInfo| this.decide(info.receiver_port_id, info.elapsed_time)
    }

    /// The decision for subscriber `id` after waiting `elapsed` on it.
    pub fn decide(&self, id: u128, elapsed: Duration) -> BackpressureAction {
        let frame = self.frame.load(Ordering::Relaxed);
        let mut book = self.lock();
        let lossless = book.lossless.contains(&id);
        let limit = self.limit;
        let s = book.stats.entry(id).or_default();
        s.last_full_frame = frame;
        s.max_wait = s.max_wait.max(elapsed);
        if lossless && !s.lagging && elapsed < limit {
            // Yield the core while the recorder catches up; the retry loop calls us again.
            std::thread::sleep(Duration::from_micros(50));
            return BackpressureAction::Retry;
        }
        s.dropped += 1;
        if lossless {
            s.lagging = true;
            book.lossless_lost += 1;
        } else {
            book.best_effort_dropped += 1;
        }
        BackpressureAction::DiscardData
    }

    /// Call before sending frame `frame_index`.
    pub fn begin_frame(&self, frame_index: u64) {
        self.frame.store(frame_index, Ordering::Relaxed);
    }

    /// Call after sending frame `frame_index`: a lagging subscriber that took it without
    /// backpressure has caught up.
    pub fn end_frame(&self, frame_index: u64) {
        let mut book = self.lock();
        for s in book.stats.values_mut() {
            if s.lagging && s.last_full_frame != frame_index {
                s.lagging = false;
            }
        }
    }

    /// Replaces the set of connected subscribers and which of them are lossless.
    pub fn set_subscribers(&self, all: &[(u128, bool)]) {
        let mut book = self.lock();
        book.lossless = all.iter().filter(|(_, l)| *l).map(|(id, _)| *id).collect();
        book.stats.retain(|id, _| all.iter().any(|(a, _)| a == id));
        for (id, _) in all {
            book.stats.entry(*id).or_default();
        }
    }

    /// Totals so far.
    pub fn totals(&self) -> LagTotals {
        let book = self.lock();
        LagTotals {
            best_effort_dropped: book.best_effort_dropped,
            lossless_lost: book.lossless_lost,
            lagging: book.stats.values().filter(|s| s.lagging).count() as u32,
        }
    }

    /// Per-subscriber figures for the status (at most 8), resetting the per-period max wait.
    pub fn report(&self) -> Vec<SubscriberLag> {
        let mut book = self.lock();
        let lossless = book.lossless.clone();
        let mut out: Vec<SubscriberLag> = book
            .stats
            .iter_mut()
            .map(|(id, s)| {
                let lag = SubscriberLag {
                    id_lo: *id as u64,
                    id_hi: (*id >> 64) as u64,
                    frames_dropped: s.dropped,
                    max_wait_ms: s.max_wait.as_secs_f32() * 1e3,
                    lossless: u32::from(lossless.contains(id)),
                };
                s.max_wait = Duration::ZERO;
                lag
            })
            .collect();
        out.sort_by_key(|l| (std::cmp::Reverse(l.lossless), l.id_hi, l.id_lo));
        out.truncate(MAX_REPORTED_SUBSCRIBERS);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn best_effort_subscriber_is_dropped_at_once() {
        let b = LagBook::new(Duration::from_millis(100));
        b.set_subscribers(&[(1, false)]);
        assert_eq!(b.decide(1, Duration::ZERO), BackpressureAction::DiscardData);
        assert_eq!(b.totals().best_effort_dropped, 1);
        assert_eq!(b.totals().lossless_lost, 0);
    }

    #[test]
    fn lossless_subscriber_is_waited_for_until_the_limit_then_marked_lagging() {
        let b = LagBook::new(Duration::from_millis(100));
        b.set_subscribers(&[(7, true)]);
        b.begin_frame(1);
        assert_eq!(
            b.decide(7, Duration::from_millis(99)),
            BackpressureAction::Retry
        );
        assert_eq!(
            b.decide(7, Duration::from_millis(100)),
            BackpressureAction::DiscardData
        );
        assert_eq!(b.totals().lossless_lost, 1);
        assert_eq!(b.totals().lagging, 1);
        b.end_frame(1);
        // Still lagging: frame 2 also hits a full buffer, and is dropped without waiting.
        b.begin_frame(2);
        assert_eq!(b.decide(7, Duration::ZERO), BackpressureAction::DiscardData);
        b.end_frame(2);
        assert_eq!(b.totals().lossless_lost, 2);
        // Frame 3 is delivered without backpressure: caught up.
        b.begin_frame(3);
        b.end_frame(3);
        assert_eq!(b.totals().lagging, 0);
        assert_eq!(b.decide(7, Duration::ZERO), BackpressureAction::Retry);
    }
}
