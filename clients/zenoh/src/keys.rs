//! The Zenoh key expressions of a bridged server, in one place (the bridge, its tests and
//! remote clients use these). Under a key prefix `K` (by default the server's service prefix):
//!
//! | key | what | how |
//! |---|---|---|
//! | `K/frame` | `FrameHeader` + `[N] FrameGaussian` | put, best effort, newest only (dropped under congestion) |
//! | `K/objects` | `FrameHeader` + `[M] ObjectState` | put, reliable |
//! | `K/status` | `Status` | put, reliable, about 10 Hz |
//! | `K/scene` | `SceneHeader` + `[N] SceneGaussian` | put once per generation; also answered to a get (late joiners) |
//! | `K/object_names` | `FrameHeader` + `[M] ObjectName` | as `K/scene` |
//! | `K/command` | query: `CommandMsg` → reply `ReplyMsg` | get with the command as payload; refused unless `--allow-commands` |
//! | `K/alive/bridge` | liveliness token | while the bridge runs |
//! | `K/alive/server` | liveliness token | while the bridge hears the server |
//!
//! Byte layouts are the shared-memory contract's (`docs/reference/protocol.md`), little-endian,
//! the header's bytes followed by the payload's: a remote reader decodes with the same code.

/// The keys under one prefix.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Keys {
    prefix: String,
}

impl Keys {
    /// The keys under `prefix` (no trailing `/`).
    pub fn new(prefix: &str) -> Self {
        Self {
            prefix: prefix.trim_end_matches('/').to_string(),
        }
    }

    /// The prefix.
    pub fn prefix(&self) -> &str {
        &self.prefix
    }

    fn key(&self, name: &str) -> String {
        format!("{}/{name}", self.prefix)
    }

    /// `K/frame`.
    pub fn frame(&self) -> String {
        self.key("frame")
    }
    /// `K/objects`.
    pub fn objects(&self) -> String {
        self.key("objects")
    }
    /// `K/status`.
    pub fn status(&self) -> String {
        self.key("status")
    }
    /// `K/scene`.
    pub fn scene(&self) -> String {
        self.key("scene")
    }
    /// `K/object_names`.
    pub fn object_names(&self) -> String {
        self.key("object_names")
    }
    /// `K/command`.
    pub fn command(&self) -> String {
        self.key("command")
    }
    /// `K/alive/bridge`.
    pub fn bridge_alive(&self) -> String {
        self.key("alive/bridge")
    }
    /// `K/alive/server`.
    pub fn server_alive(&self) -> String {
        self.key("alive/server")
    }
    /// `K/alive/*`, both tokens.
    pub fn alive(&self) -> String {
        self.key("alive/*")
    }
}
