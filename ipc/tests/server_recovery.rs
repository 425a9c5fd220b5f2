//! What the server does when a step fails, stalls or must stop mid-step, against an in-process
//! server and the free-fall stand-in:
//! - a failing step restores the last published frame, pauses, reports the failure in the
//!   status and the command log, and the server keeps answering (step, reset);
//! - `pause` cancels what is left of a `step N`;
//! - the stop flag is seen between substeps of a long step;
//! - a step that does not return shows up as stalled (beats, no progress), and a command sent
//!   then fails with `ServerStalled`, not `NoReply`.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use splatphys_ipc::client::{ClientOptions, Connection};
use splatphys_ipc::command::{Command, Reply};
use splatphys_ipc::fake::FreeFall;
use splatphys_ipc::server::{ServerConfig, StopReason, serve};
use splatphys_ipc::services::STALL_THRESHOLD;
use splatphys_ipc::wire::{
    FrameGaussian, LOG_EVENT_STEP_FAILED, ObjectState, STATUS_FAILED, STATUS_PAUSED,
    STATUS_STALLED, SceneGaussian, Status, read_fixed_str,
};
use splatphys_ipc::{Advance, IpcError, Simulation, SimulationError};

mod common;

/// The iceoryx2 file prefix of this binary (its tests share it and run at once, so none checks
/// /dev/shm for leftovers; the process tests in `tests/` do).
fn init() -> String {
    common::init("sprec")
}

fn connect(prefix: &str, command_log: bool) -> Connection {
    let mut opts = ClientOptions::new(prefix);
    opts.connect_timeout = Duration::from_secs(30);
    opts.command_log = command_log;
    opts.frames = false;
    opts.objects = false;
    Connection::connect(&opts).expect("connect")
}

fn accepted(conn: &mut Connection, cmd: Command) -> (u64, u32) {
    match conn.command(&cmd, Duration::from_secs(30)).expect("reply") {
        Reply::Accepted {
            effective_step,
            generation,
        } => (effective_step, generation),
        r => panic!("{cmd:?} was not accepted: {r:?}"),
    }
}

/// Polls the status until `done` holds (the deadline only catches a hang).
fn status_until(conn: &mut Connection, done: impl Fn(&Status) -> bool) -> Status {
    let t0 = Instant::now();
    loop {
        if let Some(s) = conn.poll_status().expect("status")
            && done(&s)
        {
            return s;
        }
        assert!(t0.elapsed() < Duration::from_secs(60), "status never came");
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn a_failing_step_restores_the_last_frame_pauses_and_keeps_answering() {
    init();
    let stop = Arc::new(AtomicBool::new(false));
    let cfg = ServerConfig {
        prefix: Some("t/fail".into()),
        start_paused: true,
        stop: stop.clone(),
        ..ServerConfig::default()
    };
    let server = std::thread::spawn(move || {
        let mut sim = FreeFall::new("fail", 2, 10, 0.01, None);
        sim.fail_at_step = Some(5);
        serve(&mut sim, &cfg).expect("the server survives a failing step")
    });
    let mut conn = connect("t/fail", true);

    accepted(&mut conn, Command::Step { count: 10 });
    let s = status_until(&mut conn, |s| s.flags & STATUS_FAILED != 0);
    assert_eq!(s.step, 4, "the last good frame is restored");
    assert_eq!(s.failure_step, 4);
    assert_ne!(s.flags & STATUS_PAUSED, 0, "paused after the failure");
    assert!(read_fixed_str(&s.failure_reason).contains("injected failure"));
    // The rest of `step 10` was cancelled: the step stays at 4.
    std::thread::sleep(Duration::from_millis(200));
    assert_eq!(
        conn.poll_status().expect("status").expect("a status").step,
        4
    );

    // The failure is in the command log, with the step it went back to.
    let t0 = Instant::now();
    let entry = loop {
        match conn.recv_command_log().expect("command log") {
            Some(e) if e.event == LOG_EVENT_STEP_FAILED => break e,
            Some(_) => {}
            None => {
                assert!(t0.elapsed() < Duration::from_secs(30), "no failure entry");
                std::thread::sleep(Duration::from_millis(5));
            }
        }
    };
    assert_eq!(entry.received_step, 4);
    assert!(read_fixed_str(&entry.reply.message).contains("injected failure"));

    // It keeps answering: stepping resumes from the restored state and clears the flag ...
    accepted(&mut conn, Command::Step { count: 3 });
    let s = status_until(&mut conn, |s| s.step == 7);
    assert_eq!(s.flags & STATUS_FAILED, 0);
    // ... and a reset names the new generation and its first step.
    assert_eq!(accepted(&mut conn, Command::Reset), (0, 1));
    stop.store(true, Ordering::Release);
    let report = server.join().expect("server thread");
    assert_eq!(report.step_failures, 1);
}

#[test]
fn pause_cancels_what_is_left_of_step_n() {
    init();
    let stop = Arc::new(AtomicBool::new(false));
    let cfg = ServerConfig {
        prefix: Some("t/pause".into()),
        start_paused: true,
        stop: stop.clone(),
        ..ServerConfig::default()
    };
    let server = std::thread::spawn(move || {
        let mut sim = Scripted::new(FreeFall::new("pause", 1, 10, 0.01, None));
        sim.substep_sleep = Duration::from_millis(1);
        serve(&mut sim, &cfg).expect("server")
    });
    let mut conn = connect("t/pause", false);
    accepted(&mut conn, Command::Step { count: 1_000_000 });
    status_until(&mut conn, |s| s.step >= 3);
    accepted(&mut conn, Command::Pause);
    // The status is refreshed every 100 ms: wait until one is newer than the pause.
    std::thread::sleep(Duration::from_millis(300));
    let at = conn.poll_status().expect("status").expect("status").step;
    std::thread::sleep(Duration::from_millis(300));
    let later = conn.poll_status().expect("status").expect("status").step;
    assert!(at < 1_000_000, "the step N ran to its end");
    assert_eq!(later, at, "still stepping after pause");
    stop.store(true, Ordering::Release);
    server.join().expect("server thread");
}

#[test]
fn the_stop_flag_ends_a_long_step_between_substeps() {
    init();
    let stop = Arc::new(AtomicBool::new(false));
    let cfg = ServerConfig {
        prefix: Some("t/longstep".into()),
        stop: stop.clone(),
        ..ServerConfig::default()
    };
    let (step_started_tx, step_started) = std::sync::mpsc::channel();
    let server = std::thread::spawn(move || {
        // 1,000 substeps of 10 ms: one frame takes 10 s.
        let mut sim = Scripted::new(FreeFall::new("longstep", 1, 10, 0.01, None));
        sim.substeps = 1000;
        sim.substep_sleep = Duration::from_millis(10);
        sim.started = Some(step_started_tx);
        serve(&mut sim, &cfg).expect("server")
    });
    step_started.recv().expect("a step started");
    let t0 = Instant::now();
    stop.store(true, Ordering::Release);
    let report = server.join().expect("server thread");
    assert_eq!(report.reason, StopReason::StopFlag);
    assert_eq!(report.step, 0, "the abandoned step is not counted");
    // Seen within a substep or a few (10 ms each), not at the end of the 10 s frame.
    assert!(t0.elapsed() < Duration::from_secs(5), "{:?}", t0.elapsed());
}

#[test]
fn a_step_that_never_ends_is_reported_as_stalled_not_gone() {
    init();
    let stop = Arc::new(AtomicBool::new(false));
    let cfg = ServerConfig {
        prefix: Some("t/stall".into()),
        start_paused: true,
        stop: stop.clone(),
        ..ServerConfig::default()
    };
    let hang = STALL_THRESHOLD + Duration::from_secs(2);
    let (step_started_tx, step_started) = std::sync::mpsc::channel();
    let server = std::thread::spawn(move || {
        // One substep that takes longer than the stall threshold, without a progress call.
        let mut sim = Scripted::new(FreeFall::new("stall", 1, 10, 0.01, None));
        sim.substeps = 1;
        sim.substep_sleep = hang;
        sim.silent = true;
        sim.started = Some(step_started_tx);
        serve(&mut sim, &cfg).expect("server")
    });
    let mut conn = connect("t/stall", false);
    accepted(&mut conn, Command::Step { count: 1 });
    // A pause that reaches the server in the same drain as the step would cancel it before it
    // begins: send it only once the step is under way.
    step_started.recv().expect("the step started");
    let err = conn
        .command(
            &Command::Pause,
            STALL_THRESHOLD + Duration::from_millis(500),
        )
        .expect_err("no reply while the step hangs");
    assert!(
        matches!(err, IpcError::ServerStalled { .. }),
        "stalled, not {err:?}"
    );
    let s = conn.poll_status().expect("still beating").expect("status");
    assert_ne!(s.flags & STATUS_STALLED, 0);
    assert!(s.progress_age_ms as u128 > STALL_THRESHOLD.as_millis());
    // Once the step ends, the loop moves again and the flag clears.
    status_until(&mut conn, |s| s.step == 1 && s.flags & STATUS_STALLED == 0);
    stop.store(true, Ordering::Release);
    server.join().expect("server thread");
}

/// The free-fall stand-in with slow substeps: `substeps` per frame, each sleeping
/// `substep_sleep` and then calling the progress callback (unless `silent`).
struct Scripted {
    inner: FreeFall,
    substeps: u32,
    substep_sleep: Duration,
    silent: bool,
    started: Option<std::sync::mpsc::Sender<()>>,
}

impl Scripted {
    fn new(inner: FreeFall) -> Self {
        Self {
            inner,
            substeps: 1,
            substep_sleep: Duration::ZERO,
            silent: false,
            started: None,
        }
    }
}

impl Simulation for Scripted {
    fn scene_name(&self) -> &str {
        self.inner.scene_name()
    }
    fn scene_generation(&self) -> u32 {
        self.inner.scene_generation()
    }
    fn gaussian_count(&self) -> usize {
        self.inner.gaussian_count()
    }
    fn object_count(&self) -> usize {
        self.inner.object_count()
    }
    fn object_name(&self, id: u32) -> Option<&str> {
        self.inner.object_name(id)
    }
    fn sh_degree(&self) -> u32 {
        self.inner.sh_degree()
    }
    fn frame_dt_s(&self) -> f64 {
        self.inner.frame_dt_s()
    }
    fn step(&self) -> u64 {
        self.inner.step()
    }
    fn time_s(&self) -> f64 {
        self.inner.time_s()
    }
    fn substeps(&self) -> u64 {
        self.inner.substeps()
    }
    fn write_scene(&self, out: &mut [SceneGaussian]) {
        self.inner.write_scene(out);
    }
    fn advance(
        &mut self,
        keep_going: &mut dyn FnMut() -> bool,
    ) -> Result<Advance, SimulationError> {
        if let Some(tx) = self.started.take() {
            let _ = tx.send(());
        }
        for _ in 0..self.substeps {
            std::thread::sleep(self.substep_sleep);
            if !self.silent && !keep_going() {
                return Err(SimulationError::Interrupted {
                    step: self.inner.step() + 1,
                });
            }
        }
        self.inner.advance(&mut || true)
    }
    fn checkpoint(&mut self) {
        self.inner.checkpoint();
    }
    fn restore_checkpoint(&mut self) -> bool {
        self.inner.restore_checkpoint()
    }
    fn write_frame(&self, out: &mut [FrameGaussian]) {
        self.inner.write_frame(out);
    }
    fn write_objects(&self, out: &mut [ObjectState]) {
        self.inner.write_objects(out);
    }
    fn apply(&mut self, command: &Command) -> Result<u64, String> {
        self.inner.apply(command)
    }
    fn is_finished(&self) -> bool {
        self.inner.is_finished()
    }
}

#[test]
fn a_client_holding_64_requests_open_cannot_stop_stepping() {
    init();
    let stop = Arc::new(AtomicBool::new(false));
    let cfg = ServerConfig {
        prefix: Some("t/hostile".into()),
        stop: stop.clone(),
        ..ServerConfig::default()
    };
    let server = std::thread::spawn(move || {
        let mut sim = Scripted::new(FreeFall::new("hostile", 2, 10, 0.01, None));
        sim.substep_sleep = Duration::from_millis(1);
        serve(&mut sim, &cfg).expect("server")
    });
    // The hostile client sends as many requests as the service lets one client hold and never
    // reads a reply.
    let mut hostile = connect("t/hostile", false);
    let impulse = Command::Impulse {
        object: 0,
        impulse_n_s: [0.0, 0.0, 0.01],
        point_m: None,
    };
    let held: Vec<_> = (0..64)
        .map(|_| hostile.send_command(&impulse).expect("send").1)
        .collect();
    let mut conn = connect("t/hostile", false);
    let before = status_until(&mut conn, |s| s.step > 0).step;
    std::thread::sleep(Duration::from_millis(500));
    let after = conn.poll_status().expect("status").expect("status").step;
    assert!(after > before + 10, "stepping stopped: {before} -> {after}");
    // Another client is still answered.
    accepted(&mut conn, Command::Pause);
    drop(held);
    stop.store(true, Ordering::Release);
    let report = server.join().expect("server thread");
    assert_eq!(report.commands_received, 65);
}
