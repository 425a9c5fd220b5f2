//! The bridge loop: a best-effort client of the server's shared-memory services (never waited
//! for, never in the lossless handshake) that republishes what it hears on Zenoh under
//! [`Keys`], answers late joiners' gets of the scene and the object names, and forwards command
//! queries when allowed. Liveliness tokens tell remote clients that the bridge and the server
//! are there; Zenoh drops a token within its lease when the bridge dies, and the bridge drops the
//! server's within the heartbeat timeout (1 s) of a silent server.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use splatphys_ipc::IpcError;
use splatphys_ipc::client::{ClientOptions, Connection};
use splatphys_ipc::command::decode;
use splatphys_ipc::wire::{CommandMsg, FrameHeader, ObjectState, SceneHeader};
use zenoh::Wait;
use zenoh::qos::CongestionControl;
use zenoh::query::Query;

use crate::keys::Keys;
use crate::ros2::{Ros2, Ros2Options};

/// How the bridge runs.
#[derive(Debug, Clone)]
pub struct BridgeOptions {
    /// Service prefix of the server (`splatphys/<scene>`).
    pub prefix: String,
    /// Zenoh key prefix (default: the service prefix).
    pub key: Option<String>,
    /// Forward command queries to the server (refused with a reason otherwise).
    pub allow_commands: bool,
    /// Zenoh endpoints to listen on; default `tcp/127.0.0.1:7447` (loopback only).
    pub listen: Vec<String>,
    /// Zenoh endpoints to connect to (a router, another peer).
    pub connect: Vec<String>,
    /// A Zenoh configuration file (JSON5: TLS, access control, scouting), applied first.
    pub config: Option<PathBuf>,
    /// How long to wait for the server.
    pub connect_timeout: Duration,
    /// How long a forwarded command may wait for the server's reply.
    pub command_timeout: Duration,
    /// Also speak ROS 2 (rmw_zenoh's conventions); without `listen`, `connect` and `config`,
    /// the bridge then joins the `rmw_zenohd` router at `tcp/localhost:7447` instead of
    /// listening there.
    pub ros2: Option<Ros2Options>,
}

/// Why the bridge stopped without an error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BridgeEnd {
    /// The server shut down cleanly.
    ServerShutDown,
    /// SIGINT or SIGTERM.
    Interrupted,
}

/// What can go wrong.
#[derive(Debug, thiserror::Error)]
pub enum BridgeError {
    /// The Zenoh configuration or session failed.
    #[error("zenoh: {what}: {message}")]
    Zenoh {
        /// What was being done.
        what: String,
        /// Zenoh's message.
        message: String,
    },
    /// The server could not be reached or went away.
    #[error(transparent)]
    Ipc(#[from] IpcError),
}

fn zerr(what: &str) -> impl FnOnce(zenoh::Error) -> BridgeError + '_ {
    move |e| BridgeError::Zenoh {
        what: what.to_string(),
        message: e.to_string(),
    }
}

/// The Zenoh configuration of `opts`: the file first, then the endpoints; without a file,
/// loopback only, multicast scouting off and a 2 s link lease; with ROS 2 and no endpoints, the
/// `rmw_zenohd` router at `tcp/localhost:7447`.
///
/// # Errors
/// [`BridgeError::Zenoh`] for an unreadable file or a bad endpoint.
pub fn zenoh_config(opts: &BridgeOptions) -> Result<zenoh::Config, BridgeError> {
    let mut config = match &opts.config {
        Some(path) => zenoh::Config::from_file(path).map_err(zerr("reading the configuration"))?,
        None => {
            let mut c = zenoh::Config::default();
            c.insert_json5("scouting/multicast/enabled", "false")
                .map_err(zerr("scouting"))?;
            // A link silent for 2 s is dropped (and the bridge's tokens with it), so remote
            // clients learn within 3 s that the bridge is gone even without a clean close.
            c.insert_json5("transport/link/tx/lease", "2000")
                .map_err(zerr("lease"))?;
            c
        }
    };
    let bare = opts.listen.is_empty() && opts.connect.is_empty() && opts.config.is_none();
    let (listen, connect) = match (bare, opts.ros2.is_some()) {
        // The ROS 2 router listens on 7447; the bridge joins it as ROS nodes do.
        (true, true) => (vec![], vec!["tcp/localhost:7447".to_string()]),
        (true, false) => (vec!["tcp/127.0.0.1:7447".to_string()], vec![]),
        (false, _) => (opts.listen.clone(), opts.connect.clone()),
    };
    let json = |v: &[String]| {
        format!(
            "[{}]",
            v.iter()
                .map(|e| format!("{e:?}"))
                .collect::<Vec<_>>()
                .join(",")
        )
    };
    if !listen.is_empty() {
        config
            .insert_json5("listen/endpoints", &json(&listen))
            .map_err(zerr("listen endpoints"))?;
    }
    if !connect.is_empty() {
        config
            .insert_json5("connect/endpoints", &json(&connect))
            .map_err(zerr("connect endpoints"))?;
    }
    Ok(config)
}

fn bytes_of<H: bytemuck::Pod, T: bytemuck::Pod>(header: &H, payload: &[T]) -> Vec<u8> {
    let mut out = Vec::with_capacity(size_of::<H>() + size_of_val(payload));
    out.extend_from_slice(bytemuck::bytes_of(header));
    out.extend_from_slice(bytemuck::cast_slice(payload));
    out
}

/// Runs the bridge until the server shuts down, a signal arrives, or an error.
///
/// # Errors
/// [`BridgeError`]: Zenoh could not start, the server was not found or went silent.
pub fn run(opts: &BridgeOptions) -> Result<BridgeEnd, BridgeError> {
    let keys = Keys::new(opts.key.as_deref().unwrap_or(&opts.prefix));
    let session = zenoh::open(zenoh_config(opts)?)
        .wait()
        .map_err(zerr("opening the session"))?;
    let _bridge_token = session
        .liveliness()
        .declare_token(keys.bridge_alive())
        .wait()
        .map_err(zerr("liveliness"))?;
    let mut client = ClientOptions::new(&opts.prefix);
    client.node_name = "splatphys-zenoh".into();
    client.connect_timeout = opts.connect_timeout;
    client.commands = opts.allow_commands;
    let mut conn = Connection::connect(&client)?;
    let server_token = session
        .liveliness()
        .declare_token(keys.server_alive())
        .wait()
        .map_err(zerr("liveliness"))?;
    let publisher = |key: String, drop_when_congested: bool| {
        session
            .declare_publisher(key)
            .congestion_control(if drop_when_congested {
                CongestionControl::Drop
            } else {
                CongestionControl::Block
            })
            .express(drop_when_congested)
            .wait()
            .map_err(zerr("declaring a publisher"))
    };
    let frame_pub = publisher(keys.frame(), true)?;
    let objects_pub = publisher(keys.objects(), false)?;
    let status_pub = publisher(keys.status(), false)?;
    let scene_pub = publisher(keys.scene(), false)?;
    let names_pub = publisher(keys.object_names(), false)?;
    let queryable = |key: String| {
        session
            .declare_queryable(key)
            .wait()
            .map_err(zerr("declaring a queryable"))
    };
    let mut ros = match &opts.ros2 {
        Some(o) => Some(Ros2::new(&session, o.clone(), opts.allow_commands)?),
        None => None,
    };
    let scene_q = queryable(keys.scene())?;
    let names_q = queryable(keys.object_names())?;
    let command_q = queryable(keys.command())?;
    let mut scene: Option<(Vec<u8>, u32)> = None;
    let mut names: Option<Vec<u8>> = None;
    let mut last_heartbeat: Option<u64> = None;
    // The turn's newest objects sample for the ROS 2 side, in a buffer kept across turns.
    let mut newest_objects: Vec<ObjectState> = Vec::new();
    let put = |p: &zenoh::pubsub::Publisher<'_>, bytes: Vec<u8>| {
        p.put(bytes).wait().map_err(zerr("publishing"))
    };
    let end = loop {
        let result = (|| -> Result<(), BridgeError> {
            while let Some(s) = conn.recv_scene()? {
                let bytes = bytes_of::<SceneHeader, _>(s.user_header(), s.payload());
                scene = Some((bytes.clone(), s.user_header().scene_generation));
                put(&scene_pub, bytes)?;
                if let Some(r) = &mut ros {
                    r.on_scene(s.payload());
                }
            }
            while let Some(n) = conn.recv_object_names()? {
                let bytes = bytes_of::<FrameHeader, _>(n.user_header(), n.payload());
                names = Some(bytes.clone());
                put(&names_pub, bytes)?;
                if let Some(r) = &mut ros {
                    r.on_object_names(n.payload())?;
                }
            }
            if let Some(f) = conn.latest_frame()? {
                let bytes = bytes_of(f.user_header(), f.payload());
                if let Some(r) = &mut ros {
                    r.on_frame(f.user_header(), f.payload())?;
                }
                drop(f);
                put(&frame_pub, bytes)?;
            }
            // Bounded: a server that steps faster than Zenoh takes the samples must not keep
            // the loop here (the bridge is a best-effort subscriber; older samples drop).
            let mut newest = None;
            for _ in 0..MAX_OBJECTS_PER_TURN {
                let Some(o) = conn.recv_objects()? else { break };
                put(&objects_pub, bytes_of(o.user_header(), o.payload()))?;
                if ros.is_some() {
                    newest = Some(*o.user_header());
                    newest_objects.clear();
                    newest_objects.extend_from_slice(o.payload());
                }
            }
            if let (Some(r), Some(header)) = (&mut ros, newest) {
                r.on_objects(&header, &newest_objects)?;
            }
            // The newest status (poll_status drains the service and returns the last one, also
            // when nothing new came): published once per heartbeat.
            if let Some(s) = conn.poll_status()?
                && last_heartbeat != Some(s.heartbeat)
            {
                last_heartbeat = Some(s.heartbeat);
                put(&status_pub, bytemuck::bytes_of(&s).to_vec())?;
            }

            while let Ok(Some(q)) = scene_q.try_recv() {
                answer_latest(&q, scene.as_ref().map(|s| &s.0), "scene");
            }
            while let Ok(Some(q)) = names_q.try_recv() {
                answer_latest(&q, names.as_ref(), "object names");
            }
            if let Some(r) = &mut ros {
                r.forward_commands(&mut conn)?;
            }
            while let Ok(Some(q)) = command_q.try_recv() {
                let generation = scene.as_ref().map_or(0, |s| s.1);
                forward_command(&q, &mut conn, opts, generation);
            }
            Ok(())
        })();
        match result {
            Ok(()) => {}
            Err(BridgeError::Ipc(IpcError::ServerShutDown { .. })) => {
                // The server's last status says it shut down cleanly: remote clients must hear
                // it before the server's token goes, or they would take the end for a crash.
                // Express: sent at once, not batched behind the token's end.
                if let Ok(Some(s)) = conn.poll_status() {
                    let _ = session
                        .put(keys.status(), bytemuck::bytes_of(&s).to_vec())
                        .express(true)
                        .congestion_control(CongestionControl::Block)
                        .wait();
                }
                break BridgeEnd::ServerShutDown;
            }
            Err(e) => {
                drop(server_token);
                return Err(e);
            }
        }
        // A WaitSet-free wait that still sees SIGINT/SIGTERM (iceoryx2 swallows them otherwise).
        if conn.node().wait(Duration::from_millis(1)).is_err() {
            break BridgeEnd::Interrupted;
        }
    };
    drop(server_token);
    Ok(end)
}

/// Objects samples republished per turn of the loop at most.
const MAX_OBJECTS_PER_TURN: usize = 8;

fn answer_latest(q: &Query, latest: Option<&Vec<u8>>, what: &str) {
    let _ = match latest {
        Some(bytes) => q.reply(q.key_expr().clone(), bytes.clone()).wait(),
        None => q
            .reply_err(format!("no {what} received from the server yet"))
            .wait(),
    };
}

/// Forwards one command query to the server and answers with its `ReplyMsg` bytes, or a
/// reason why not (commands not allowed, wrong size, undecodable, no reply).
fn forward_command(q: &Query, conn: &mut Connection, opts: &BridgeOptions, generation: u32) {
    let refuse = |why: String| {
        let _ = q.reply_err(why).wait();
    };
    if !opts.allow_commands {
        return refuse(
            "commands are refused by this bridge: start splatphys-zenoh with --allow-commands"
                .into(),
        );
    }
    let Some(payload) = q.payload() else {
        return refuse(format!(
            "a command query carries a CommandMsg ({} bytes) as payload",
            size_of::<CommandMsg>()
        ));
    };
    let bytes = payload.to_bytes();
    if bytes.len() != size_of::<CommandMsg>() {
        return refuse(format!(
            "payload of {} bytes; a CommandMsg is {}",
            bytes.len(),
            size_of::<CommandMsg>()
        ));
    }
    let msg: CommandMsg = bytemuck::pod_read_unaligned(&bytes);
    let cmd = match decode(&msg) {
        Ok(cmd) => cmd,
        Err(e) => return refuse(format!("command: {e}")),
    };
    let started = Instant::now();
    match conn.command(&cmd, opts.command_timeout) {
        Ok(reply) => {
            let m = reply.to_msg(msg.sequence, generation);
            let _ = q
                .reply(q.key_expr().clone(), bytemuck::bytes_of(&m).to_vec())
                .wait();
        }
        Err(e) => refuse(format!(
            "no reply from the server after {:.1} s: {e}",
            started.elapsed().as_secs_f64()
        )),
    }
}
