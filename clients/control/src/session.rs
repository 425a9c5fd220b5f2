//! A connection to one server, for controllers: reads the scene header once (object names),
//! resolves [`ObjectRef`]s to ids and sends commands with replies.
//!
//! Object references resolve by exact name first (every object's name from the `object_names`
//! service; from a server without it, the first 64 in
//! [`splatphys_ipc::wire::SceneHeader::object_names`]), then as a number (`3` or `#3`).
//! Numbered references need no scene header; named ones wait for it (it is kept in the `scene`
//! service's history, so it arrives right after connecting).

use std::time::{Duration, Instant};

use splatphys_ipc::IpcError;
use splatphys_ipc::client::{ClientOptions, Connection};
use splatphys_ipc::command::{Command, Reply};
use splatphys_ipc::wire::{MAX_NAMED_OBJECTS, ObjectName, SceneHeader, read_fixed_str};

use crate::action::{Action, ObjectRef};
use crate::error::ControlError;

/// What the scene header says about the scene.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneInfo {
    /// Scene name.
    pub scene_name: String,
    /// Scene generation of this header.
    pub generation: u32,
    /// Published Gaussians.
    pub gaussian_count: u32,
    /// Objects; ids are `0..object_count`.
    pub object_count: u32,
    /// Simulated time between published frames, seconds.
    pub frame_dt_s: f64,
    /// Object names by id: every object's once the `object_names` list of this generation
    /// arrived, else the header's first `min(object_count, 64)` (empty when unnamed).
    pub object_names: Vec<String>,
}

impl SceneInfo {
    /// Reads a scene header.
    pub fn from_header(h: &SceneHeader) -> Self {
        let named = (h.object_count as usize).min(MAX_NAMED_OBJECTS);
        Self {
            scene_name: read_fixed_str(&h.scene_name),
            generation: h.scene_generation,
            gaussian_count: h.gaussian_count,
            object_count: h.object_count,
            frame_dt_s: h.frame_dt_s,
            object_names: h.object_names[..named]
                .iter()
                .map(|n| read_fixed_str(n))
                .collect(),
        }
    }

    /// The id of `object`: an exact name match first, then a number.
    ///
    /// # Errors
    /// [`ControlError::UnknownObject`] listing the known names.
    pub fn resolve(&self, object: &ObjectRef) -> Result<u32, ControlError> {
        if let ObjectRef::Name(name) = object
            && let Some(i) = self.object_names.iter().position(|n| n == name)
        {
            return Ok(i as u32);
        }
        object.as_id().ok_or_else(|| ControlError::UnknownObject {
            name: object.to_string(),
            known: self.object_names.join(", "),
        })
    }

    /// The display name of object `id` (`name` or `#id`).
    pub fn label(&self, id: u32) -> String {
        match self.object_names.get(id as usize) {
            Some(n) if !n.is_empty() => n.clone(),
            _ => format!("#{id}"),
        }
    }
}

/// How to connect.
#[derive(Debug, Clone)]
pub struct SessionOptions {
    /// Service prefix of the server.
    pub prefix: String,
    /// How long to wait for the server to appear. Default 5 s.
    pub connect_timeout: Duration,
    /// How long to wait for a reply (and for the scene header). Default 2 s.
    pub reply_timeout: Duration,
    /// Subscribe to the `objects` service (best effort). Default false.
    pub objects: bool,
    /// iceoryx2 node name. Default `splatphys-control`.
    pub node_name: String,
}

impl SessionOptions {
    /// Defaults for `prefix`.
    pub fn new(prefix: &str) -> Self {
        Self {
            prefix: prefix.to_owned(),
            connect_timeout: Duration::from_secs(5),
            reply_timeout: Duration::from_secs(2),
            objects: false,
            node_name: "splatphys-control".into(),
        }
    }
}

/// A controller's connection to one server.
#[derive(Debug)]
pub struct Session {
    conn: Connection,
    scene: Option<SceneInfo>,
    /// The newest `object_names` list and its scene generation.
    names: Option<(u32, Vec<String>)>,
    reply_timeout: Duration,
}

impl Session {
    /// Connects (commands always; `objects` when asked; never frames).
    ///
    /// # Errors
    /// [`IpcError::ServerNotFound`] after the connect timeout, iceoryx2 failures.
    pub fn connect(opts: &SessionOptions) -> Result<Self, ControlError> {
        let mut c = ClientOptions::new(&opts.prefix);
        c.node_name = opts.node_name.clone();
        c.connect_timeout = opts.connect_timeout;
        c.frames = false;
        c.objects = opts.objects;
        c.commands = true;
        Ok(Self {
            conn: Connection::connect(&c)?,
            scene: None,
            names: None,
            reply_timeout: opts.reply_timeout,
        })
    }

    /// The underlying connection (objects, status, raw commands).
    pub fn connection(&mut self) -> &mut Connection {
        &mut self.conn
    }

    /// The reply timeout.
    pub fn reply_timeout(&self) -> Duration {
        self.reply_timeout
    }

    /// Takes any newer scene header that arrived (e.g. after a reset).
    ///
    /// # Errors
    /// iceoryx2 failures, layout mismatch.
    pub fn refresh_scene(&mut self) -> Result<(), ControlError> {
        while let Some(s) = self.conn.recv_scene()? {
            self.scene = Some(SceneInfo::from_header(s.user_header()));
        }
        while let Some(n) = self.conn.recv_object_names()? {
            let names = n.payload().iter().map(ObjectName::text).collect();
            self.names = Some((n.user_header().scene_generation, names));
        }
        if let (Some(scene), Some((generation, names))) = (&mut self.scene, &self.names)
            && scene.generation == *generation
        {
            scene.object_names.clone_from(names);
        }
        Ok(())
    }

    /// The scene header, waiting up to the reply timeout for it.
    ///
    /// # Errors
    /// [`ControlError::NoScene`], [`IpcError::ServerGone`], [`IpcError::Interrupted`].
    pub fn scene(&mut self) -> Result<&SceneInfo, ControlError> {
        let start = Instant::now();
        self.refresh_scene()?;
        while self.scene.is_none() {
            if start.elapsed() >= self.reply_timeout {
                return Err(ControlError::NoScene {
                    waited_ms: start.elapsed().as_millis() as u64,
                });
            }
            self.conn.poll_status()?;
            self.conn
                .node()
                .wait(Duration::from_millis(1))
                .map_err(|_| IpcError::Interrupted)?;
            self.refresh_scene()?;
        }
        self.scene
            .as_ref()
            .ok_or(ControlError::NoScene { waited_ms: 0 })
    }

    /// The scene header if one has been received, without waiting.
    pub fn scene_now(&self) -> Option<&SceneInfo> {
        self.scene.as_ref()
    }

    /// The id of `object` (waits for the scene header only for names).
    ///
    /// # Errors
    /// [`ControlError::UnknownObject`], [`ControlError::NoScene`].
    pub fn resolve(&mut self, object: &ObjectRef) -> Result<u32, ControlError> {
        if let ObjectRef::Id(id) = object {
            return Ok(*id);
        }
        match self.scene() {
            Ok(scene) => scene.resolve(object),
            // Without a header, numbers still work.
            Err(e) => object.as_id().ok_or(e),
        }
    }

    /// The wire command for `action`, its object resolved.
    ///
    /// # Errors
    /// As [`Session::resolve`].
    pub fn command_for(&mut self, action: &Action) -> Result<Command, ControlError> {
        action.clone().map_object(|o| self.resolve(&o))
    }

    /// Resolves, sends and waits for the reply.
    ///
    /// # Errors
    /// Resolution errors, [`IpcError::NoReply`], [`IpcError::ServerGone`].
    pub fn run(&mut self, action: &Action) -> Result<Reply, ControlError> {
        let cmd = self.command_for(action)?;
        Ok(self.conn.command(&cmd, self.reply_timeout)?)
    }
}

/// One line describing a reply: `accepted, takes effect at step 42 (generation 0)` or
/// `rejected (OutOfRange): nu = 0.7 outside (-1, 0.5)`.
pub fn describe_reply(reply: &Reply) -> String {
    match reply {
        Reply::Accepted {
            effective_step,
            generation,
        } => {
            format!("accepted, takes effect at step {effective_step} (generation {generation})")
        }
        Reply::Rejected { code, reason } => format!("rejected ({code:?}): {reason}"),
    }
}

/// The reply as a JSON object (`{"accepted":true,"effective_step":42,"generation":0}` or
/// `{"accepted":false,"reject_code":"OutOfRange","reason":"..."}`).
pub fn reply_json(reply: &Reply) -> serde_json::Value {
    match reply {
        Reply::Accepted {
            effective_step,
            generation,
        } => serde_json::json!({
            "accepted": true,
            "effective_step": effective_step,
            "generation": generation,
        }),
        Reply::Rejected { code, reason } => serde_json::json!({
            "accepted": false,
            "reject_code": format!("{code:?}"),
            "reason": reason,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use splatphys_ipc::wire::write_fixed_str;

    fn info(names: &[&str]) -> SceneInfo {
        let mut h = SceneHeader {
            object_count: names.len() as u32,
            ..Default::default()
        };
        for (i, n) in names.iter().enumerate() {
            write_fixed_str(&mut h.object_names[i], n);
        }
        SceneInfo::from_header(&h)
    }

    #[test]
    fn names_resolve_before_numbers() {
        let s = info(&["donut", "7", "vase"]);
        assert_eq!(s.resolve(&ObjectRef::Name("vase".into())).unwrap(), 2);
        // An object literally named "7" wins over id 7.
        assert_eq!(s.resolve(&ObjectRef::Name("7".into())).unwrap(), 1);
        assert_eq!(s.resolve(&ObjectRef::Name("#0".into())).unwrap(), 0);
        let e = s.resolve(&ObjectRef::Name("teapot".into())).unwrap_err();
        assert!(e.to_string().contains("donut, 7, vase"), "{e}");
        assert_eq!(s.label(0), "donut");
        assert_eq!(s.label(9), "#9");
    }
}
