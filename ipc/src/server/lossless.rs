//! The server's side of the lossless contract: the acknowledgements of lossless subscribers
//! (recorders) on `lossless_ack`.
//!
//! Before its first frame the server waits until every expected lossless subscriber has said
//! it is ready ([`ACK_READY`]: every port connected, the current scene taken); before it shuts
//! down it waits until every ready one has taken the last published frame ([`ACK_TOOK_FRAME`]),
//! for as long as it keeps making progress (each wait bounded by the lossless limit), and
//! reports what was not taken. Best-effort subscribers never acknowledge and never count.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use iceoryx2::node::Node;
use iceoryx2::port::subscriber::Subscriber;

use crate::error::IpcError;
use crate::heartbeat::Heartbeat;
use crate::services::{
    FrameService, Iox, LosslessAckService, Role, ServiceNames, frame_subscribers,
    lossless_ack_service,
};
use crate::wire::{ACK_READY, ACK_TOOK_FRAME, LAYOUT_VERSION, LosslessAck};

/// What one lossless subscriber said last.
#[derive(Debug, Clone, Copy)]
struct Acked {
    ready: bool,
    /// Newest frame index it took.
    taken: Option<u64>,
    /// When `taken` last moved (or it became ready).
    progressed: Instant,
}

/// A lossless subscriber still behind the last published frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Behind {
    /// Frames it has not acknowledged.
    frames: u64,
    /// Time since it last acknowledged a new frame.
    idle: Duration,
}

/// The `lossless_ack` subscriber and what each lossless subscriber said, by the id of its
/// `frame` subscriber port.
pub(super) struct LosslessAcks {
    _service: LosslessAckService,
    sub: Subscriber<Iox, LosslessAck, ()>,
    acked: BTreeMap<u128, Acked>,
}

impl LosslessAcks {
    /// Creates the service (the server owns it) and its one subscriber.
    pub(super) fn create(node: &Node<Iox>, names: &ServiceNames) -> Result<Self, IpcError> {
        let service = lossless_ack_service(node, names, Role::Owner)?;
        let sub = service
            .subscriber_builder()
            .buffer_size(64)
            .create()
            .map_err(|e| IpcError::iox("create subscriber", &names.name("lossless_ack"), e))?;
        Ok(Self {
            _service: service,
            sub,
            acked: BTreeMap::new(),
        })
    }

    /// Takes every pending acknowledgement. One of another layout version is ignored (its
    /// sender fails on our frames anyway).
    pub(super) fn poll(&mut self) -> Result<(), IpcError> {
        while let Some(s) = self
            .sub
            .receive()
            .map_err(|e| IpcError::iox("receive", "lossless_ack", e))?
        {
            let ack = *s.payload();
            if ack.layout_version != LAYOUT_VERSION {
                continue;
            }
            let now = Instant::now();
            let entry = self.acked.entry(ack.subscriber_id()).or_insert(Acked {
                ready: false,
                taken: None,
                progressed: now,
            });
            entry.ready |= ack.flags & ACK_READY != 0;
            if ack.flags & ACK_TOOK_FRAME != 0 && entry.taken.is_none_or(|t| ack.frame_index > t) {
                entry.taken = Some(ack.frame_index);
                entry.progressed = now;
            }
        }
        Ok(())
    }

    /// Ready lossless subscribers among the connected `frame` subscribers `connected`
    /// ((id, lossless) pairs): a recorder that died after saying so does not count.
    pub(super) fn ready(&self, connected: &[(u128, bool)]) -> usize {
        connected
            .iter()
            .filter(|(id, lossless)| *lossless && self.acked.get(id).is_some_and(|a| a.ready))
            .count()
    }

    /// Waits until every ready lossless subscriber has taken frame `last` (the last published),
    /// as long as each one that is behind keeps making progress: the wait ends when all are
    /// there, when none of those behind acknowledged a new frame for `limit`, or on a signal.
    /// `node` is looked at for that signal; `None` after one (the wait is then 1 s at most, so
    /// SIGTERM still ends the server within 2 s). Returns the frames not taken, summed over
    /// subscribers.
    pub(super) fn wait_for_last_frame(
        &mut self,
        last: u64,
        frame_service: &FrameService,
        limit: Duration,
        node: Option<&Node<Iox>>,
        heartbeat: &Heartbeat,
    ) -> u64 {
        let limit = match node {
            Some(_) => limit,
            None => limit.min(Duration::from_secs(1)),
        };
        let since = Instant::now();
        loop {
            heartbeat.tick();
            if self.poll().is_err() {
                return 0;
            }
            let behind = self.behind(last, &frame_subscribers(frame_service), since);
            let frames = behind.iter().map(|b| b.frames).sum();
            if behind.is_empty() || behind.iter().all(|b| b.idle >= limit) {
                return frames;
            }
            match node {
                Some(node) if node.wait(Duration::from_millis(1)).is_err() => return frames,
                Some(_) => {}
                None => std::thread::sleep(Duration::from_millis(1)),
            }
        }
    }

    /// The connected ready lossless subscribers that have not taken frame `last`, with the
    /// time since each last made progress (counted from `since` at the latest).
    fn behind(&self, last: u64, connected: &[(u128, bool)], since: Instant) -> Vec<Behind> {
        connected
            .iter()
            .filter(|(_, lossless)| *lossless)
            .filter_map(|(id, _)| self.acked.get(id).filter(|a| a.ready))
            .filter_map(|a| {
                let frames = match a.taken {
                    Some(t) if t >= last => return None,
                    Some(t) => last - t,
                    None => last + 1,
                };
                Some(Behind {
                    frames,
                    idle: a.progressed.max(since).elapsed(),
                })
            })
            .collect()
    }
}
