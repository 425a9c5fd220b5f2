//! Timelines: commands scheduled at simulated times, from a TOML file.
//!
//! ```toml
//! # Every event: `at_s` (simulated seconds) and `command`; the other keys depend on it. The
//! # same keys as a scene file's [[event]] (splatphys_types::CommandToml).
//! [[event]]
//! at_s = 0.5
//! command = "impulse"          # object, impulse_n_s, optional point_m
//! object = "donut"             # a name from the scene header, or an id: 0 / "#0"
//! impulse_n_s = [0.0, 0.0, 2.0]
//!
//! [[event]]
//! at_s = 1.0
//! command = "edit-material"    # object; any of model, youngs_modulus_pa, poisson_ratio,
//! object = 1                   # density_kg_m3, restitution, friction
//! model = "snow"
//! youngs_modulus_pa = 1.4e5
//!
//! [[event]]
//! at_s = 2.0
//! command = "set-velocity"     # object, velocity_m_s
//! object = "donut"
//! velocity_m_s = [0.0, 0.0, 0.0]
//!
//! [[event]]
//! at_s = 3.0
//! command = "set-kind"         # object, kind = deformable | rigid | static
//! object = "donut"
//! kind = "rigid"
//!
//! # pause, resume, reset, shutdown take nothing; step takes count.
//! ```
//!
//! An event is sent as soon as the server's simulated time (from the `objects` frames and the
//! status heartbeat) reaches `at_s`; events at the same time go in file order. Unknown keys,
//! and keys that do not belong to the event's command, are errors.

use std::collections::VecDeque;
use std::path::Path;
use std::time::{Duration, Instant};

use serde::Deserialize;
use splatphys_ipc::IpcError;
use splatphys_ipc::client::PendingCommand;
use splatphys_ipc::command::{CommandToml, Reply};

use crate::action::{Action, ObjectRef};
use crate::error::ControlError;
use crate::session::Session;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    #[serde(default)]
    event: Vec<toml::Table>,
}

/// One scheduled command.
#[derive(Debug, Clone, PartialEq)]
pub struct TimedAction {
    /// Simulated time at which it is sent, seconds.
    pub at_s: f64,
    /// What to send.
    pub action: Action,
}

/// One `[[event]]` table: `at_s` and a [`CommandToml`].
fn parse_event(mut table: toml::Table) -> Result<(f64, Action), (f64, String)> {
    let at_s = match table.remove("at_s") {
        Some(toml::Value::Float(t)) => t,
        Some(toml::Value::Integer(t)) => t as f64,
        Some(other) => {
            return Err((
                f64::NAN,
                format!("`at_s` = {other} is not a number of seconds"),
            ));
        }
        None => return Err((f64::NAN, "`at_s` is missing".into())),
    };
    let spec: CommandToml<ObjectRef> =
        CommandToml::deserialize(table).map_err(|e| (at_s, e.to_string()))?;
    let action = spec.into_command().map_err(|e| (at_s, e))?;
    Ok((at_s, action))
}

/// Parses a timeline from TOML text; `path` is only used in messages. Events come back sorted
/// by time (stable: same-time events keep their file order).
///
/// # Errors
/// [`ControlError::Timeline`] for TOML errors (with line and column),
/// [`ControlError::TimelineEvent`] for an incomplete or inconsistent event or a time that is
/// negative or not finite.
pub fn parse_timeline(text: &str, path: &str) -> Result<Vec<TimedAction>, ControlError> {
    let file: File = toml::from_str(text).map_err(|e| ControlError::Timeline {
        path: path.to_owned(),
        detail: e.to_string(),
    })?;
    let mut out = Vec::with_capacity(file.event.len());
    for (index, table) in file.event.into_iter().enumerate() {
        let err = |at_s: f64, detail: String| ControlError::TimelineEvent {
            path: path.to_owned(),
            index,
            at_s,
            detail,
        };
        let (at_s, action) = parse_event(table).map_err(|(at_s, e)| err(at_s, e))?;
        if !(at_s.is_finite() && at_s >= 0.0) {
            return Err(err(at_s, "`at_s` must be a finite time >= 0 s".into()));
        }
        out.push(TimedAction { at_s, action });
    }
    out.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
    Ok(out)
}

/// Reads and parses a timeline file.
///
/// # Errors
/// As [`parse_timeline`], plus unreadable files.
pub fn load_timeline(path: &Path) -> Result<Vec<TimedAction>, ControlError> {
    let text = std::fs::read_to_string(path).map_err(|e| ControlError::Timeline {
        path: path.display().to_string(),
        detail: e.to_string(),
    })?;
    parse_timeline(&text, &path.display().to_string())
}

/// What happened to one timeline event.
#[derive(Debug, Clone, PartialEq)]
pub struct EventOutcome {
    /// Index in the (sorted) timeline.
    pub index: usize,
    /// Scheduled simulated time, seconds.
    pub at_s: f64,
    /// Server's simulated time when it was sent, seconds.
    pub sent_at_s: f64,
    /// Command name.
    pub command: &'static str,
    /// Resolved object id, if any.
    pub object: Option<u32>,
    /// The reply, or the local error that kept it from being sent.
    pub reply: Result<Reply, String>,
}

/// Totals of a timeline run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TimelineReport {
    /// Events sent.
    pub sent: usize,
    /// Accepted by the server.
    pub accepted: usize,
    /// Rejected by the server or not sendable (e.g. unknown object name).
    pub rejected: usize,
}

struct Pending {
    index: usize,
    sent_at_s: f64,
    object: Option<u32>,
    pending: PendingCommand,
    deadline: Instant,
}

/// Sends every event once the server's simulated time reaches it (with `relative`, once it
/// reaches the time of the first status or frame seen plus `at_s`), and waits for every reply.
/// `on_outcome` sees each event's outcome as its reply arrives. The session must have been
/// connected with `objects` enabled for frame-accurate timing (otherwise the 10 Hz status
/// time is used).
///
/// # Errors
/// Connection errors ([`IpcError::ServerGone`], [`IpcError::ServerShutDown`] before the last
/// event, [`IpcError::NoReply`], [`IpcError::Interrupted`]).
pub fn run_timeline(
    session: &mut Session,
    events: &[TimedAction],
    relative: bool,
    mut on_outcome: impl FnMut(&EventOutcome),
) -> Result<TimelineReport, ControlError> {
    let mut report = TimelineReport::default();
    let mut next = 0;
    let mut in_flight: VecDeque<Pending> = VecDeque::new();
    let mut now_s = f64::NEG_INFINITY;
    // With `relative`, event times are offsets from the first server time seen.
    let mut origin_s: Option<f64> = (!relative).then_some(0.0);
    let reply_timeout = session.reply_timeout();
    let mut finish = |o: EventOutcome, report: &mut TimelineReport| {
        match &o.reply {
            Ok(Reply::Accepted { .. }) => report.accepted += 1,
            _ => report.rejected += 1,
        }
        on_outcome(&o);
    };

    while next < events.len() || !in_flight.is_empty() {
        // Simulated time: the newest objects frame, else the status heartbeat.
        if let Some(s) = session.connection().poll_status()? {
            now_s = now_s.max(s.time_s);
        }
        loop {
            match session.connection().recv_objects() {
                Ok(Some(s)) => now_s = now_s.max(s.user_header().time_s),
                Ok(None) => break,
                // Shut down: only a problem if something is still to be sent or answered.
                Err(e @ IpcError::ServerShutDown { .. }) => {
                    if next < events.len() || !in_flight.is_empty() {
                        return Err(e.into());
                    }
                    break;
                }
                Err(e) => return Err(e.into()),
            }
        }

        if origin_s.is_none() && now_s.is_finite() {
            origin_s = Some(now_s);
        }
        let due_s = now_s - origin_s.unwrap_or(f64::INFINITY);
        while next < events.len() && events[next].at_s <= due_s {
            let ev = &events[next];
            let object = ev.action.object().map(|o| session.resolve(o)).transpose();
            match object.and_then(|_| session.command_for(&ev.action)) {
                Ok(cmd) => {
                    let (_, pending) = session.connection().send_command(&cmd)?;
                    report.sent += 1;
                    in_flight.push_back(Pending {
                        index: next,
                        sent_at_s: now_s,
                        object: cmd.object().copied(),
                        pending,
                        deadline: Instant::now() + reply_timeout,
                    });
                }
                Err(e) if e.is_connection() => return Err(e),
                Err(e) => finish(
                    EventOutcome {
                        index: next,
                        at_s: ev.at_s,
                        sent_at_s: now_s,
                        command: ev.action.name(),
                        object: None,
                        reply: Err(e.to_string()),
                    },
                    &mut report,
                ),
            }
            next += 1;
        }

        let mut i = 0;
        while i < in_flight.len() {
            let p = &in_flight[i];
            match session.connection().poll_reply(&p.pending)? {
                Some(reply) => {
                    let ev = &events[p.index];
                    let o = EventOutcome {
                        index: p.index,
                        at_s: ev.at_s,
                        sent_at_s: p.sent_at_s,
                        command: ev.action.name(),
                        object: p.object,
                        reply: Ok(reply),
                    };
                    in_flight.remove(i);
                    finish(o, &mut report);
                }
                None if Instant::now() > p.deadline => {
                    return Err(IpcError::NoReply {
                        sequence: p.index as u64,
                        waited_ms: reply_timeout.as_millis() as u64,
                    }
                    .into());
                }
                None => i += 1,
            }
        }

        session
            .connection()
            .node()
            .wait(Duration::from_micros(200))
            .map_err(|_| IpcError::Interrupted)?;
    }
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use splatphys_ipc::command::{MaterialModel, ObjectKind};

    #[test]
    fn events_parse_and_sort_by_time_keeping_file_order() {
        let t = parse_timeline(
            r##"
            [[event]]
            at_s = 1.0
            command = "edit-material"
            object = 1
            model = "snow"
            poisson_ratio = 0.3
            [[event]]
            at_s = 0.5
            command = "impulse"
            object = "donut"
            impulse_n_s = [0, 0, 2]
            point_m = [0.1, 0, 1]
            [[event]]
            at_s = 1.0
            command = "set-kind"
            object = "#2"
            kind = "rigid"
            [[event]]
            at_s = 2.0
            command = "step"
            count = 3
            "##,
            "t.toml",
        )
        .unwrap();
        assert_eq!(t.len(), 4);
        assert_eq!(
            t[0].action,
            Action::Impulse {
                object: ObjectRef::Name("donut".into()),
                impulse_n_s: [0.0, 0.0, 2.0],
                point_m: Some([0.1, 0.0, 1.0]),
            }
        );
        let Action::EditMaterial { object, edit } = &t[1].action else {
            panic!("{:?}", t[1]);
        };
        assert_eq!(*object, ObjectRef::Id(1));
        assert_eq!(edit.model, Some(MaterialModel::Snow));
        assert_eq!(edit.poisson_ratio, Some(0.3));
        assert_eq!(edit.youngs_modulus_pa, None);
        assert!(matches!(
            t[2].action,
            Action::SetKind {
                kind: ObjectKind::Rigid,
                ..
            }
        ));
        assert_eq!(t[3].action, Action::Step { count: 3 });
    }

    #[test]
    fn bad_events_name_the_event_and_the_problem() {
        let cases = [
            (
                "at_s = 1.0\ncommand = \"impulse\"\nobject = 0",
                "needs `impulse_n_s`",
            ),
            (
                "at_s = 1.0\ncommand = \"pause\"\nobject = 0",
                "does not apply",
            ),
            ("at_s = -1.0\ncommand = \"pause\"", "finite time"),
            ("at_s = 1.0\ncommand = \"explode\"", "unknown command"),
            (
                "at_s = 1.0\ncommand = \"set-kind\"\nobject = 0\nkind = \"gas\"",
                "unknown variant `gas`",
            ),
            (
                "at_s = 1.0\ncommand = \"edit-material\"\nobject = 0",
                "changes nothing",
            ),
        ];
        for (body, want) in cases {
            let text = format!("[[event]]\n{body}\n");
            let e = parse_timeline(&text, "t.toml").unwrap_err();
            assert!(
                matches!(e, ControlError::TimelineEvent { index: 0, .. }),
                "{e}"
            );
            assert!(e.to_string().contains(want), "{e} lacks {want}");
        }
        let e = parse_timeline("[[event]]\nat_s = 1\ncommand = \"pause\"\nbogus = 1\n", "t")
            .unwrap_err();
        assert!(e.to_string().contains("bogus"), "{e}");
    }
}
