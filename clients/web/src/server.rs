//! The web side of the bridge: the page and its scripts (compiled into the binary) and one
//! WebSocket per open page.
//!
//! Per page, frames are sent only when the page has drawn the one before (it answers each frame
//! with `{"type": "ready"}`); frames published meanwhile are skipped and the page gets the
//! newest. A frame carries only the Gaussians that changed since the page's last one.

use std::net::{IpAddr, SocketAddr};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

use axum::Router;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Path, Query, State};
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use serde::{Deserialize, Serialize};
use tokio::sync::mpsc;

use crate::commands::{self, ReplyJson, Request};
use crate::feed::{self, FeedReceivers, FrameData};
use crate::messages::{changed, frame_message};

/// The page and its scripts: (file name, content type, text).
const FILES: &[(&str, &str, &str)] = &[
    (
        "index.html",
        "text/html; charset=utf-8",
        include_str!("../static/index.html"),
    ),
    (
        "viewer.js",
        "text/javascript; charset=utf-8",
        include_str!("../static/viewer.js"),
    ),
    (
        "splat.js",
        "text/javascript; charset=utf-8",
        include_str!("../static/splat.js"),
    ),
];

/// The camera the page starts from (the scene file's), JSON as the page reads it.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct CameraJson {
    /// Centre of projection, m.
    pub position_m: [f32; 3],
    /// Point looked at, m.
    pub look_at_m: [f32; 3],
    /// Up direction.
    pub up: [f32; 3],
    /// Vertical field of view, degrees.
    pub fov_y_deg: f32,
    /// Image width, px.
    pub width_px: u32,
    /// Image height, px.
    pub height_px: u32,
}

/// How to serve.
#[derive(Debug, Clone)]
pub struct WebConfig {
    /// Service prefix of the server to show.
    pub prefix: String,
    /// Address to listen on; loopback unless exposing on purpose.
    pub host: IpAddr,
    /// Port (0 = any free port).
    pub port: u16,
    /// Pages must open the URL with `?token=<token>`; without one, a viewer exposed beyond
    /// loopback is read-only.
    pub token: Option<String>,
    /// The camera the page starts from (`None`: the page frames the scene).
    pub camera: Option<CameraJson>,
}

impl WebConfig {
    /// Whether a page with `token` may send commands, or may connect at all (`None`).
    fn access(&self, token: Option<&str>) -> Option<bool> {
        match (&self.token, token) {
            (Some(want), Some(got)) if want == got => Some(true),
            // A token is set and this page does not have it.
            (Some(_), _) => None,
            // No token: full control on loopback, read-only when exposed.
            (None, _) => Some(self.host.is_loopback()),
        }
    }

    /// The URL to open.
    pub fn url(&self, addr: SocketAddr) -> String {
        let host = if addr.ip().is_unspecified() {
            "localhost".to_owned()
        } else {
            addr.ip().to_string()
        };
        match &self.token {
            Some(t) => format!("http://{host}:{}/?token={t}", addr.port()),
            None => format!("http://{host}:{}/", addr.port()),
        }
    }
}

#[derive(Clone)]
struct AppState {
    cfg: Arc<WebConfig>,
    feed: FeedReceivers,
    commands: std::sync::mpsc::Sender<Request>,
    stats: Arc<Stats>,
}

/// What the bridge sent, over all pages.
#[derive(Debug, Default)]
pub struct Stats {
    /// Frame messages sent.
    pub frames: AtomicU64,
    /// Bytes of frame messages sent.
    pub frame_bytes: AtomicU64,
    /// Time spent finding the changes and encoding frame messages, ns.
    pub encode_ns: AtomicU64,
}

impl Stats {
    /// One line for the log: frames, bytes per frame, encoding time per frame and the process's
    /// CPU time per frame (Linux; `None` elsewhere).
    pub fn summary(&self) -> String {
        let frames = self.frames.load(Ordering::Relaxed);
        let per = |x: f64| x / frames.max(1) as f64;
        let cpu = process_cpu_s().map_or("unknown".into(), |s| format!("{:.2} ms", per(s) * 1e3));
        format!(
            "{frames} frames sent, {:.2} MB a frame, {:.2} ms encoding a frame, CPU {cpu} a frame",
            per(self.frame_bytes.load(Ordering::Relaxed) as f64) / 1e6,
            per(self.encode_ns.load(Ordering::Relaxed) as f64) / 1e6,
        )
    }
}

/// User + system CPU time of this process, seconds (`/proc/self/stat`; Linux only).
fn process_cpu_s() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let rest = stat.rsplit_once(") ")?.1;
    let fields: Vec<&str> = rest.split_whitespace().collect();
    // Fields 14 and 15 of stat(5) (utime, stime), counted after "pid (comm)": 11 and 12 here.
    let ticks: f64 = fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// Serves until `stop` is set (or the feed sees SIGINT/SIGTERM). `on_listen` gets the bound
/// address (to print the URL). Returns what was sent.
///
/// # Errors
/// When the address cannot be bound.
pub fn serve(
    cfg: WebConfig,
    stop: Arc<AtomicBool>,
    on_listen: impl FnOnce(SocketAddr),
) -> anyhow::Result<Arc<Stats>> {
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    let result = runtime.block_on(async move {
        let listener = tokio::net::TcpListener::bind((cfg.host, cfg.port))
            .await
            .map_err(|e| anyhow::anyhow!("cannot listen on {}:{}: {e}", cfg.host, cfg.port))?;
        on_listen(listener.local_addr()?);
        let stats = Arc::new(Stats::default());
        let state = AppState {
            feed: feed::start(&cfg.prefix, stop.clone()),
            commands: commands::start(&cfg.prefix),
            cfg: Arc::new(cfg),
            stats: stats.clone(),
        };
        let app = Router::new()
            .route("/", get(|| async { file("index.html") }))
            .route(
                "/static/{name}",
                get(|Path(name): Path<String>| async move { file(&name) }),
            )
            .route("/ws", get(ws))
            .with_state(state);
        // SIGINT/SIGTERM end the bridge whatever the feed is doing (it may be waiting for a
        // server that is gone).
        for kind in [
            tokio::signal::unix::SignalKind::interrupt(),
            tokio::signal::unix::SignalKind::terminate(),
        ] {
            let stop = stop.clone();
            let mut signal = tokio::signal::unix::signal(kind)?;
            tokio::spawn(async move {
                signal.recv().await;
                stop.store(true, Ordering::Release);
            });
        }
        let stopped = {
            let stop = stop.clone();
            async move {
                while !stop.load(Ordering::Acquire) {
                    tokio::time::sleep(Duration::from_millis(100)).await;
                }
            }
        };
        // Open pages (WebSockets) do not hold the shutdown up for more than a second.
        let grace = async move {
            while !stop.load(Ordering::Acquire) {
                tokio::time::sleep(Duration::from_millis(100)).await;
            }
            tokio::time::sleep(Duration::from_secs(1)).await;
        };
        tokio::select! {
            served = axum::serve(listener, app).with_graceful_shutdown(stopped) => served?,
            () = grace => {}
        }
        Ok(stats)
    });
    runtime.shutdown_timeout(Duration::from_secs(1));
    result
}

fn file(name: &str) -> Response {
    match FILES.iter().find(|(n, _, _)| *n == name) {
        Some((_, mime, text)) => ([(header::CONTENT_TYPE, *mime)], *text).into_response(),
        None => (StatusCode::NOT_FOUND, format!("no file {name}")).into_response(),
    }
}

#[derive(Deserialize)]
struct WsQuery {
    token: Option<String>,
}

async fn ws(
    upgrade: WebSocketUpgrade,
    Query(q): Query<WsQuery>,
    State(state): State<AppState>,
) -> Response {
    let Some(control) = state.cfg.access(q.token.as_deref()) else {
        return (
            StatusCode::UNAUTHORIZED,
            "this viewer needs its token: open the URL splatphys-web printed",
        )
            .into_response();
    };
    upgrade.on_upgrade(move |socket| async move {
        // A page that goes away ends its task; nothing else depends on it.
        let _ = Page::new(state, control).run(socket).await;
    })
}

/// Messages from the page.
#[derive(Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
enum FromPage {
    /// The page drew its last frame and takes the next.
    Ready,
    /// A command for the server.
    Command {
        request: u64,
        command: serde_json::Value,
    },
}

/// One open page.
struct Page {
    state: AppState,
    control: bool,
    /// Generation of the scene the page holds.
    generation: Option<u32>,
    /// The frame the page holds (what the next one is a change of).
    shown: Option<Arc<FrameData>>,
    ready: bool,
}

impl Page {
    fn new(state: AppState, control: bool) -> Self {
        Self {
            state,
            control,
            generation: None,
            shown: None,
            ready: true,
        }
    }

    async fn run(mut self, mut socket: WebSocket) -> Result<(), axum::Error> {
        let hello = serde_json::json!({"type": "hello", "read_only": !self.control});
        socket.send(Message::Text(hello.to_string().into())).await?;
        let (reply_tx, mut replies) = mpsc::unbounded_channel::<ReplyJson>();
        let mut feed = self.state.feed.clone();
        feed.status.mark_changed();
        feed.objects.mark_changed();
        loop {
            self.offer(&mut socket).await?;
            tokio::select! {
                msg = socket.recv() => match msg {
                    Some(Ok(Message::Text(text))) => self.handle_message(&text, &reply_tx, &mut socket).await?,
                    Some(Ok(Message::Close(_))) | None | Some(Err(_)) => return Ok(()),
                    Some(Ok(_)) => {}
                },
                Ok(()) = feed.scene.changed() => {}
                Ok(()) = feed.frame.changed() => {}
                Ok(()) = feed.status.changed() => {
                    let s = serde_json::to_string(&*feed.status.borrow_and_update()).unwrap_or_default();
                    socket.send(Message::Text(s.into())).await?;
                }
                Ok(()) = feed.objects.changed() => {
                    let o = feed.objects.borrow_and_update().clone();
                    if !o.is_empty() {
                        socket.send(Message::Text(o.as_str().into())).await?;
                    }
                }
                Some(r) = replies.recv() => {
                    let s = serde_json::to_string(&r).unwrap_or_default();
                    socket.send(Message::Text(s.into())).await?;
                }
            }
        }
    }

    async fn handle_message(
        &mut self,
        text: &str,
        replies: &mpsc::UnboundedSender<ReplyJson>,
        socket: &mut WebSocket,
    ) -> Result<(), axum::Error> {
        let refuse = |request, reason: String| {
            let r = ReplyJson::refused(request, reason);
            Message::Text(serde_json::to_string(&r).unwrap_or_default().into())
        };
        match serde_json::from_str::<FromPage>(text) {
            Ok(FromPage::Ready) => self.ready = true,
            Ok(FromPage::Command { request, .. }) if !self.control => {
                let why = "this viewer is read-only: open it with its token to send commands";
                socket.send(refuse(request, why.into())).await?;
            }
            Ok(FromPage::Command { request, command }) => match commands::parse(&command) {
                Ok(command) => {
                    let (tx, rx) = tokio::sync::oneshot::channel();
                    let req = Request {
                        request,
                        command,
                        reply: tx,
                    };
                    if self.state.commands.send(req).is_err() {
                        socket
                            .send(refuse(request, "the bridge is stopping".into()))
                            .await?;
                    } else {
                        let replies = replies.clone();
                        tokio::spawn(async move {
                            if let Ok(r) = rx.await {
                                let _ = replies.send(r);
                            }
                        });
                    }
                }
                Err(e) => socket.send(refuse(request, e)).await?,
            },
            // Not ours: say so and carry on.
            Err(e) => socket.send(refuse(0, format!("bad message: {e}"))).await?,
        }
        Ok(())
    }

    /// Sends the scene when its generation is new, then the newest frame if the page is ready
    /// for one.
    async fn offer(&mut self, socket: &mut WebSocket) -> Result<(), axum::Error> {
        let scene = self.state.feed.scene.borrow().clone();
        if let Some(scene) = scene
            && self.generation != Some(scene.generation)
        {
            let objects: Vec<_> = scene
                .names
                .iter()
                .enumerate()
                .map(|(id, name)| serde_json::json!({"id": id, "name": name}))
                .collect();
            let info = serde_json::json!({
                "type": "scene_info",
                "generation": scene.generation,
                "scene_name": scene.scene_name,
                "objects": objects,
                "camera": self.state.cfg.camera,
            });
            socket.send(Message::Text(info.to_string().into())).await?;
            socket
                .send(Message::Binary(scene.binary.clone().into()))
                .await?;
            self.generation = Some(scene.generation);
            self.shown = None;
            self.ready = true;
        }
        if !self.ready {
            return Ok(());
        }
        let frame = self.state.feed.frame.borrow().clone();
        let newer = frame.filter(|f| {
            Some(f.header.scene_generation) == self.generation
                && self
                    .shown
                    .as_ref()
                    .is_none_or(|s| s.header.frame_index != f.header.frame_index)
        });
        let Some(frame) = newer else {
            // Ready, and nothing newer than what the page holds: ask the feed for the next.
            self.state.feed.wanted.store(true, Ordering::Release);
            return Ok(());
        };
        let t0 = std::time::Instant::now();
        let indices = changed(
            &frame.gaussians,
            self.shown.as_ref().map(|s| s.gaussians.as_slice()),
        );
        let bytes = frame_message(&frame.header, &frame.gaussians, &indices);
        let stats = &self.state.stats;
        stats
            .encode_ns
            .fetch_add(t0.elapsed().as_nanos() as u64, Ordering::Relaxed);
        stats.frames.fetch_add(1, Ordering::Relaxed);
        stats
            .frame_bytes
            .fetch_add(bytes.len() as u64, Ordering::Relaxed);
        socket.send(Message::Binary(bytes.into())).await?;
        self.shown = Some(frame);
        self.ready = false;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg(host: &str, token: Option<&str>) -> WebConfig {
        WebConfig {
            prefix: "p".into(),
            host: host.parse().unwrap(),
            port: 0,
            token: token.map(str::to_owned),
            camera: None,
        }
    }

    #[test]
    fn exposed_viewers_are_read_only_or_need_their_token() {
        // Loopback, no token: full control.
        assert_eq!(cfg("127.0.0.1", None).access(None), Some(true));
        // Exposed, no token: everyone may watch, nobody may push.
        assert_eq!(cfg("0.0.0.0", None).access(None), Some(false));
        assert_eq!(cfg("0.0.0.0", None).access(Some("x")), Some(false));
        // A token: only pages that have it connect, and they control.
        let t = cfg("0.0.0.0", Some("s3cret"));
        assert_eq!(t.access(Some("s3cret")), Some(true));
        assert_eq!(t.access(Some("guess")), None);
        assert_eq!(t.access(None), None);
        let url = t.url("0.0.0.0:8080".parse().unwrap());
        assert_eq!(url, "http://localhost:8080/?token=s3cret");
    }

    #[test]
    fn every_file_the_page_loads_is_in_the_binary() {
        let index = FILES[0].2;
        for (name, _, text) in FILES {
            assert!(!text.is_empty(), "{name}");
        }
        assert!(
            index.contains("/static/viewer.js"),
            "index.html loads viewer.js"
        );
        let viewer = FILES[1].2;
        assert!(viewer.contains("./splat.js"), "viewer.js imports splat.js");
    }
}
