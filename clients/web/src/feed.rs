//! The bridge's one subscriber: a thread that follows a server's `scene`, `object_names`,
//! `frame` (newest only, best effort: the server never waits for the viewer), `objects` and
//! `status` services and keeps the latest of each in `watch` channels for the WebSocket tasks.
//!
//! When the server stops or dies the last scene and frame stay; the status says the server is
//! gone, and the thread waits for a server under the same prefix to come back.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use serde::Serialize;
use splatphys_ipc::IpcError;
use splatphys_ipc::client::{ClientOptions, Connection};
use splatphys_ipc::services::create_node;
use splatphys_ipc::wire::{
    FrameGaussian, FrameHeader, STATUS_FAILED, STATUS_FINISHED, STATUS_PAUSED, STATUS_STALLED,
    Status, read_fixed_str,
};
use tokio::sync::watch;

use crate::messages::scene_message;

/// A scene generation as the page gets it.
#[derive(Debug)]
pub struct SceneData {
    /// Scene generation.
    pub generation: u32,
    /// The binary scene message ([`crate::messages`]).
    pub binary: Vec<u8>,
    /// Object names, `names[id]`.
    pub names: Vec<String>,
    /// Scene name.
    pub scene_name: String,
}

/// The newest frame.
#[derive(Debug)]
pub struct FrameData {
    /// Its header.
    pub header: FrameHeader,
    /// Every Gaussian, in scene order.
    pub gaussians: Vec<FrameGaussian>,
}

/// The server's status as the page shows it (JSON `{"type": "status", ...}`).
#[derive(Debug, Clone, Default, Serialize, PartialEq)]
pub struct StatusJson {
    /// Always "status".
    #[serde(rename = "type")]
    pub kind: &'static str,
    /// Step of the newest frame.
    pub step: u64,
    /// Simulated time, s.
    pub time_s: f64,
    /// The server's steps per wall second.
    pub steps_per_s: f64,
    /// Stepping is paused.
    pub paused: bool,
    /// The scene's duration has been simulated: the server holds the last frame (resume runs
    /// one more duration, reset starts over).
    pub finished: bool,
    /// The last step failed; the server restored the frame before and paused.
    pub failed: bool,
    /// The server's main loop has made no progress for its stall threshold.
    pub stalled: bool,
    /// A server is connected and beating.
    pub server_alive: bool,
    /// Why the last step failed, if it did.
    pub failure_reason: String,
    /// Scene generation.
    pub generation: u32,
}

impl StatusJson {
    fn from_status(s: &Status) -> Self {
        Self {
            kind: "status",
            step: s.step,
            time_s: s.time_s,
            steps_per_s: s.steps_per_s,
            paused: s.flags & STATUS_PAUSED != 0,
            finished: s.flags & STATUS_FINISHED != 0,
            failed: s.flags & STATUS_FAILED != 0,
            stalled: s.flags & STATUS_STALLED != 0,
            server_alive: true,
            failure_reason: read_fixed_str(&s.failure_reason),
            generation: s.scene_generation,
        }
    }
}

/// One object in the `objects` JSON message.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ObjectJson {
    /// Object id.
    pub id: u32,
    /// Centre of mass, m.
    pub com_m: [f32; 3],
    /// COM velocity, m/s.
    pub velocity_m_s: [f32; 3],
    /// Mass, kg.
    pub mass_kg: f32,
}

/// The latest of everything, for the WebSocket tasks.
#[derive(Debug, Clone)]
pub struct FeedReceivers {
    /// The current scene generation.
    pub scene: watch::Receiver<Option<Arc<SceneData>>>,
    /// The newest frame.
    pub frame: watch::Receiver<Option<Arc<FrameData>>>,
    /// The newest status.
    pub status: watch::Receiver<StatusJson>,
    /// The newest objects (JSON `{"type": "objects", ...}`).
    pub objects: watch::Receiver<Arc<String>>,
    /// Set by a page that is ready for a frame newer than `frame`'s: the feed then copies the
    /// newest one out of shared memory (and clears it).
    pub wanted: Arc<AtomicBool>,
}

/// How often status reaches the page.
const STATUS_PERIOD: Duration = Duration::from_millis(100);

/// Starts the feed thread for `prefix`; it runs until `stop` is set or a signal arrives (then
/// it sets `stop` itself, so the web server ends too).
pub fn start(prefix: &str, stop: Arc<AtomicBool>) -> FeedReceivers {
    let (scene_tx, scene) = watch::channel(None);
    let (frame_tx, frame) = watch::channel(None);
    let (status_tx, status) = watch::channel(StatusJson {
        kind: "status",
        ..StatusJson::default()
    });
    let (objects_tx, objects) = watch::channel(Arc::new(String::new()));
    let wanted = Arc::new(AtomicBool::new(true));
    let wanted_tx = wanted.clone();
    let prefix = prefix.to_owned();
    std::thread::spawn(move || {
        let tx = Senders {
            wanted: wanted_tx,
            scene: scene_tx,
            frame: frame_tx,
            status: status_tx,
            objects: objects_tx,
        };
        // Each kind of error is said once (a server that is gone fails the same way, with a
        // different wait time, every retry).
        let mut last_error = None;
        // iceoryx2 takes SIGINT/SIGTERM once a node exists; between connections a node of our
        // own waits, so a signal still ends the bridge.
        let waiter = create_node("splatphys-web-feed").ok();
        while !stop.load(Ordering::Acquire) {
            match follow(&prefix, &tx, &stop) {
                Err(IpcError::Interrupted) => stop.store(true, Ordering::Release),
                Err(e) => {
                    tx.status.send_modify(|s| s.server_alive = false);
                    let kind = std::mem::discriminant(&e);
                    if last_error != Some(kind) {
                        eprintln!("splatphys-web: {e}; waiting for a server under `{prefix}`");
                        last_error = Some(kind);
                    }
                    let pause = Duration::from_millis(500);
                    match &waiter {
                        Some(node) if node.wait(pause).is_err() => {
                            stop.store(true, Ordering::Release);
                        }
                        Some(_) => {}
                        None => std::thread::sleep(pause),
                    }
                }
                Ok(()) => {}
            }
        }
    });
    FeedReceivers {
        scene,
        frame,
        status,
        objects,
        wanted,
    }
}

struct Senders {
    wanted: Arc<AtomicBool>,
    scene: watch::Sender<Option<Arc<SceneData>>>,
    frame: watch::Sender<Option<Arc<FrameData>>>,
    status: watch::Sender<StatusJson>,
    objects: watch::Sender<Arc<String>>,
}

/// Follows one server until it stops, dies, or `stop`.
fn follow(prefix: &str, tx: &Senders, stop: &AtomicBool) -> Result<(), IpcError> {
    let mut opts = ClientOptions::new(prefix);
    opts.node_name = "splatphys-web".into();
    opts.commands = false;
    opts.connect_timeout = Duration::from_secs(1);
    let mut conn = Connection::connect(&opts)?;
    let mut names: Vec<String> = Vec::new();
    let mut held = None;
    let mut copied = None;
    let mut last_status = Instant::now() - STATUS_PERIOD;
    while !stop.load(Ordering::Acquire) {
        let mut busy = false;
        while let Some(n) = conn.recv_object_names()? {
            names = n.payload().iter().map(|n| n.text()).collect();
        }
        while let Some(s) = conn.recv_scene()? {
            let h = s.user_header();
            if names.len() != h.object_count as usize {
                names = h
                    .object_names
                    .iter()
                    .take(h.object_count as usize)
                    .map(|n| read_fixed_str(n))
                    .collect();
            }
            let data = SceneData {
                generation: h.scene_generation,
                binary: scene_message(h, s.payload()),
                names: names.clone(),
                scene_name: read_fixed_str(&h.scene_name),
            };
            tx.scene.send_replace(Some(Arc::new(data)));
            busy = true;
        }
        // The newest frame stays borrowed from shared memory until a page asks for one:
        // copying every published frame while pages draw a few a second would cost the bridge
        // most of its CPU. (Release the held sample before borrowing the next.)
        if held.is_none() || conn.frame_pending()? {
            drop(held.take());
            held = conn.latest_frame()?;
            busy |= held.is_some();
        }
        if let Some(f) = &held
            && copied != Some(f.user_header().frame_index)
            && tx.wanted.swap(false, Ordering::AcqRel)
        {
            copied = Some(f.user_header().frame_index);
            let data = FrameData {
                header: *f.user_header(),
                gaussians: f.payload().to_vec(),
            };
            tx.frame.send_replace(Some(Arc::new(data)));
        }
        let mut newest_objects = None;
        while let Some(o) = conn.recv_objects()? {
            newest_objects = Some((*o.user_header(), o.payload().to_vec()));
        }
        if let Some((h, objs)) = newest_objects {
            let list: Vec<ObjectJson> = objs
                .iter()
                .map(|o| ObjectJson {
                    id: o.id,
                    com_m: o.position_m,
                    velocity_m_s: o.velocity_m_s,
                    mass_kg: o.mass_kg,
                })
                .collect();
            let json = serde_json::json!({"type": "objects", "step": h.step, "objects": list});
            tx.objects.send_replace(Arc::new(json.to_string()));
        }
        if last_status.elapsed() >= STATUS_PERIOD {
            last_status = Instant::now();
            if let Some(s) = conn.poll_status()? {
                let json = StatusJson::from_status(&s);
                tx.status.send_if_modified(|old| {
                    let changed = *old != json;
                    *old = json;
                    changed
                });
            }
        }
        let idle = if busy {
            Duration::ZERO
        } else {
            Duration::from_millis(1)
        };
        conn.node().wait(idle).map_err(|_| IpcError::Interrupted)?;
    }
    Ok(())
}
