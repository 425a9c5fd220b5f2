//! Commands from the page: JSON in the scene-file form (`{"command": "impulse", "object": 0,
//! "impulse_n_s": [..]}`, see [`CommandToml`]), sent to the server on a connection of their own
//! so that a slow reply never holds up the frames, and answered with the server's reply.

use std::sync::mpsc;
use std::time::Duration;

use serde::Serialize;
use splatphys_ipc::client::{ClientOptions, Connection};
use splatphys_ipc::command::{Command, CommandToml, Reply};
use tokio::sync::oneshot;

/// The page's view of a reply (JSON `{"type": "reply", ...}`).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ReplyJson {
    /// Always "reply".
    #[serde(rename = "type")]
    pub kind: &'static str,
    /// The page's request number.
    pub request: u64,
    /// Whether the server accepted the command.
    pub accepted: bool,
    /// Why not (the server's reason, or the bridge's when it never reached the server).
    pub reason: String,
    /// The step it takes effect on (accepted only).
    pub effective_step: Option<u64>,
}

impl ReplyJson {
    /// A refusal by the bridge itself.
    pub fn refused(request: u64, reason: impl Into<String>) -> Self {
        Self {
            kind: "reply",
            request,
            accepted: false,
            reason: reason.into(),
            effective_step: None,
        }
    }
}

/// Parses the page's command object into a command, or says what is wrong with it.
///
/// # Errors
/// A message naming the bad key or value.
pub fn parse(command: &serde_json::Value) -> Result<Command, String> {
    let toml: CommandToml<u32> = serde_json::from_value(command.clone())
        .map_err(|e| format!("bad command {command}: {e}"))?;
    toml.into_command()
}

/// A command on its way to the server, with where its reply goes.
pub struct Request {
    /// The page's request number.
    pub request: u64,
    /// The command.
    pub command: Command,
    /// Where the reply goes.
    pub reply: oneshot::Sender<ReplyJson>,
}

/// How long a command may wait for the server's reply.
const REPLY_TIMEOUT: Duration = Duration::from_secs(5);

/// Starts the command thread for `prefix`; it ends when every sender is dropped.
pub fn start(prefix: &str) -> mpsc::Sender<Request> {
    let (tx, rx) = mpsc::channel::<Request>();
    let prefix = prefix.to_owned();
    std::thread::spawn(move || {
        let mut conn: Option<Connection> = None;
        for req in rx {
            let reply = send(&prefix, &mut conn, &req);
            let _ = req.reply.send(reply);
        }
    });
    tx
}

fn send(prefix: &str, conn: &mut Option<Connection>, req: &Request) -> ReplyJson {
    if conn.is_none() {
        let mut opts = ClientOptions::new(prefix);
        opts.node_name = "splatphys-web-commands".into();
        opts.frames = false;
        opts.objects = false;
        opts.connect_timeout = Duration::from_secs(1);
        match Connection::connect(&opts) {
            Ok(c) => *conn = Some(c),
            Err(e) => return ReplyJson::refused(req.request, format!("no server: {e}")),
        }
    }
    let Some(c) = conn.as_mut() else {
        return ReplyJson::refused(req.request, "no server");
    };
    match c.command(&req.command, REPLY_TIMEOUT) {
        Ok(Reply::Accepted { effective_step, .. }) => ReplyJson {
            kind: "reply",
            request: req.request,
            accepted: true,
            reason: String::new(),
            effective_step: Some(effective_step),
        },
        Ok(Reply::Rejected { reason, .. }) => ReplyJson::refused(req.request, reason),
        Err(e) => {
            // The server may be gone: connect afresh next time.
            *conn = None;
            ReplyJson::refused(req.request, e.to_string())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_page_commands_parse_and_bad_ones_say_why() {
        let c = parse(
            &serde_json::json!({"command": "impulse", "object": 2, "impulse_n_s": [0.0, 0.0, 1.5]}),
        )
        .unwrap();
        assert_eq!(
            c,
            Command::Impulse {
                object: 2,
                impulse_n_s: [0.0, 0.0, 1.5],
                point_m: None
            }
        );
        assert_eq!(
            parse(&serde_json::json!({"command": "step", "count": 3})).unwrap(),
            Command::Step { count: 3 }
        );
        let e = parse(
            &serde_json::json!({"command": "edit-material", "object": 0, "youngs_modulus": 1e5}),
        )
        .unwrap_err();
        assert!(e.contains("youngs_modulus"), "{e}");
        let e = parse(&serde_json::json!({"command": "fly"})).unwrap_err();
        assert!(e.contains("unknown command"), "{e}");
    }
}
