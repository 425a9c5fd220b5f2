//! Client regressions against an in-process server (free-fall stand-in):
//! - `Connection::latest_frame` failed with iceoryx2's `ExceedsMaxBorrows` when more frames
//!   were pending than the `frame` service lets a subscriber borrow (one): it kept the previous
//!   sample while taking the next;
//! - a command sent right after connecting was lost when the server was slow to create its
//!   ports: `status` (what clients wait for) existed before the command server port, and
//!   iceoryx2 delivers a request only to the servers connected when it is sent.
//!
//! Every test calls [`init`], which sets `SPLATPHYS_IOX2_PREFIX` once for the process before
//! any iceoryx2 node exists; the tests use different service prefixes, and the last one to
//! finish checks that nothing of the file prefix is left in /dev/shm.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use splatphys_ipc::client::{ClientOptions, Connection};
use splatphys_ipc::command::{Command, Reply};
use splatphys_ipc::fake::FreeFall;
use splatphys_ipc::server::{ServerConfig, serve};
use splatphys_ipc::services::MAX_FRAME_BUFFER;
use splatphys_ipc::wire::{FrameGaussian, ObjectState, SceneGaussian};
use splatphys_ipc::{Advance, Simulation, SimulationError};

mod common;
use common::leftovers;

/// The iceoryx2 file prefix of this test binary.
fn init() -> String {
    common::init("spxl")
}

/// Tests of this binary.
const TESTS: usize = 3;

/// Marks a test done; the last one checks that nothing of `iox` is left in /dev/shm (before
/// that, the other test's files may still exist).
fn finish(iox: &str) {
    static DONE: AtomicUsize = AtomicUsize::new(0);
    if DONE.fetch_add(1, Ordering::AcqRel) + 1 == TESTS {
        assert_eq!(leftovers(iox), Vec::<String>::new());
    }
}

/// Steps the paused server `count` frames and waits until its status shows them published
/// (the status is updated after the frame of the same step is sent).
fn step_and_wait(conn: &mut Connection, count: u64, target_step: u64) {
    let reply = conn
        .command(&Command::Step { count }, Duration::from_secs(30))
        .expect("step command");
    assert!(matches!(reply, Reply::Accepted { .. }), "{reply:?}");
    let t0 = Instant::now();
    // The deadline only catches a hang (no wall-clock speed is asserted).
    while conn.poll_status().expect("status").map_or(0, |s| s.step) < target_step {
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "server never reached step {target_step}"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
}

#[test]
fn latest_frame_drains_more_pending_frames_than_the_borrow_limit() {
    let iox = init();
    let stop = Arc::new(AtomicBool::new(false));
    let cfg = ServerConfig {
        prefix: Some("t/latest".into()),
        start_paused: true,
        stop: stop.clone(),
        ..ServerConfig::default()
    };
    let server = std::thread::spawn(move || {
        let mut sim = FreeFall::new("latest", 1, 10, 0.01, None);
        serve(&mut sim, &cfg).expect("server")
    });

    let mut opts = ClientOptions::new("t/latest");
    opts.frame_buffer = MAX_FRAME_BUFFER;
    opts.connect_timeout = Duration::from_secs(30);
    let mut conn = Connection::connect(&opts).expect("connect");

    // Four frames (steps 1..=4) pending, one borrow allowed.
    let n = MAX_FRAME_BUFFER as u64;
    step_and_wait(&mut conn, n, n);
    let newest = conn
        .latest_frame()
        .expect("latest_frame must not exceed the borrow limit")
        .expect("a frame was pending");
    assert_eq!(newest.user_header().step, n);
    assert_eq!(newest.payload().len(), 10);
    drop(newest);
    assert!(
        conn.recv_frame().expect("recv").is_none(),
        "the older frames were released, not left behind"
    );

    // And again after two more steps: the newest is step 6.
    step_and_wait(&mut conn, 2, n + 2);
    let newest = conn.latest_frame().expect("latest").expect("a frame");
    assert_eq!(newest.user_header().step, n + 2);
    drop(newest);

    drop(conn);
    stop.store(true, Ordering::Release);
    let report = server.join().expect("server thread");
    assert_eq!(report.step, n + 2);
    finish(&iox);
}

/// The free-fall stand-in, but the server's first look at its Gaussian count (while it sets up
/// its publishers) takes 500 ms, as a large scene's shared-memory setup can on a loaded host.
struct SlowSetup {
    inner: FreeFall,
    first: AtomicBool,
}

impl Simulation for SlowSetup {
    fn scene_name(&self) -> &str {
        self.inner.scene_name()
    }
    fn scene_generation(&self) -> u32 {
        self.inner.scene_generation()
    }
    fn gaussian_count(&self) -> usize {
        if self.first.swap(false, Ordering::AcqRel) {
            std::thread::sleep(Duration::from_millis(500));
        }
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
        self.inner.advance(keep_going)
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
fn a_command_sent_right_after_connecting_is_answered() {
    let iox = init();
    let stop = Arc::new(AtomicBool::new(false));
    let cfg = ServerConfig {
        prefix: Some("t/early-command".into()),
        start_paused: true,
        stop: stop.clone(),
        ..ServerConfig::default()
    };
    let server = std::thread::spawn(move || {
        let mut sim = SlowSetup {
            inner: FreeFall::new("early", 1, 10, 0.01, None),
            first: AtomicBool::new(true),
        };
        serve(&mut sim, &cfg).expect("server")
    });
    let mut opts = ClientOptions::new("t/early-command");
    opts.frames = false;
    opts.objects = false;
    opts.connect_timeout = Duration::from_secs(30);
    let mut conn = Connection::connect(&opts).expect("connect");
    // The reply arrives in well under a millisecond once the server loop runs; 30 s only
    // catches a request that reached no server.
    let reply = conn
        .command(&Command::Step { count: 1 }, Duration::from_secs(30))
        .expect("a reply to a command sent right after connecting");
    assert!(matches!(reply, Reply::Accepted { .. }), "{reply:?}");
    drop(conn);
    stop.store(true, Ordering::Release);
    server.join().expect("server thread");
    finish(&iox);
}

#[test]
fn every_object_name_travels_beyond_the_scene_header() {
    let iox = init();
    let stop = Arc::new(AtomicBool::new(false));
    let cfg = ServerConfig {
        prefix: Some("t/names".into()),
        start_paused: true,
        stop: stop.clone(),
        ..ServerConfig::default()
    };
    // More objects than the scene header names (64).
    let objects = splatphys_ipc::wire::MAX_NAMED_OBJECTS + 6;
    let server = std::thread::spawn(move || {
        let mut sim = FreeFall::new("names", objects, 2, 0.01, None);
        serve(&mut sim, &cfg).expect("server")
    });
    let mut opts = ClientOptions::new("t/names");
    opts.connect_timeout = Duration::from_secs(30);
    let mut conn = Connection::connect(&opts).expect("connect");
    let t0 = Instant::now();
    let names: Vec<String> = loop {
        if let Some(n) = conn.recv_object_names().expect("names") {
            assert_eq!(n.user_header().count as usize, objects);
            break n.payload().iter().map(|n| n.text()).collect();
        }
        assert!(t0.elapsed() < Duration::from_secs(30), "no object names");
        std::thread::sleep(Duration::from_millis(5));
    };
    assert_eq!(names.len(), objects);
    assert_eq!(names[0], "cube0");
    assert_eq!(names[objects - 1], format!("cube{}", objects - 1));
    drop(conn);
    stop.store(true, Ordering::Release);
    server.join().expect("server thread");
    finish(&iox);
}
