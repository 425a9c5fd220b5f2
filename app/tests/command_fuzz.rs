//! A command fuzzer against the real simulation behind a real server: proptest draws batches of
//! up to 10 commands (finite extremes, NaN and infinities, lever arms, unknown objects, every
//! material model and object kind, pause/resume/step/reset) and sends each batch to an
//! in-process `serve` of a small scene (a jelly ball, a rigid box and a floor; a few hundred
//! particles) between frames. Every command must be answered, the server must never panic or
//! stall, and every published object state must stay finite.
//!
//! `SPLATPHYS_FUZZ_COMMANDS` sets the number of commands (default 10,000),
//! `SPLATPHYS_FUZZ_FRAME_HZ` the frame rate (default 240: short frames, so a batch, which waits
//! for one frame, stays cheap even when the objects were pushed to 100 m/s),
//! `SPLATPHYS_FUZZ_SEED` the byte the random stream's seed is filled with (default 7).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use proptest::prelude::*;
use proptest::strategy::ValueTree;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use splatphys::world_sim::WorldSim;
use splatphys_core::material::MaterialSpec;
use splatphys_core::scene::{ColliderSpec, ObjectKind as SceneKind, Scene, SceneObject};
use splatphys_ipc::client::{ClientOptions, Connection};
use splatphys_ipc::command::{Command, MaterialEdit, MaterialModel, ObjectKind, Reply};
use splatphys_ipc::server::{ServerConfig, serve};
use splatphys_ipc::wire::STATUS_FAILED;

/// f64 values a careless or hostile client sends: extremes, non-finite, tiny, ordinary.
fn value() -> impl Strategy<Value = f64> {
    prop_oneof![
        2 => -10.0..10.0f64,
        1 => -1e6..1e6f64,
        1 => prop_oneof![
            Just(f64::MAX),
            Just(-f64::MAX),
            Just(f64::MIN_POSITIVE),
            Just(1e-300),
            Just(1e39),
            Just(0.0),
            Just(-0.0),
            Just(0.4999),
            Just(0.5),
            Just(f64::NAN),
            Just(f64::INFINITY),
            Just(f64::NEG_INFINITY),
        ],
    ]
}

fn vec3() -> impl Strategy<Value = [f64; 3]> {
    [value(), value(), value()]
}

/// Object ids: the two objects, and ids that do not exist.
fn object() -> impl Strategy<Value = u32> {
    prop_oneof![4 => 0..2u32, 1 => Just(2u32), 1 => Just(u32::MAX)]
}

fn edit() -> impl Strategy<Value = MaterialEdit> {
    (
        proptest::option::of(proptest::sample::select(vec![
            MaterialModel::FixedCorotated,
            MaterialModel::NeoHookean,
            MaterialModel::Snow,
            MaterialModel::Sand,
            MaterialModel::Metal,
            MaterialModel::Plasticine,
            MaterialModel::Foam,
        ])),
        proptest::option::of(prop_oneof![value(), 1e3..1e9f64]),
        proptest::option::of(value()),
        proptest::option::of(prop_oneof![value(), 100.0..5000.0f64]),
        proptest::option::of(value()),
        proptest::option::of(value()),
    )
        .prop_map(|(model, e, nu, rho, restitution, friction)| MaterialEdit {
            model,
            youngs_modulus_pa: e,
            poisson_ratio: nu,
            density_kg_m3: rho,
            restitution,
            friction,
        })
}

fn command() -> impl Strategy<Value = Command> {
    prop_oneof![
        6 => (object(), vec3(), proptest::option::of(vec3())).prop_map(|(object, j, p)| {
            Command::Impulse { object, impulse_n_s: j, point_m: p }
        }),
        3 => (object(), vec3(), proptest::option::of(vec3())).prop_map(|(object, v, w)| {
            Command::SetVelocity { object, velocity_m_s: v, angular_velocity_rad_s: w }
        }),
        3 => (object(), vec3(), [value(), value(), value(), value()], proptest::option::of(0..400u64))
            .prop_map(|(object, p, q, at_step)| Command::SetPose {
                object,
                position_m: p,
                orientation_wxyz: q,
                at_step,
            }),
        4 => (object(), edit()).prop_map(|(object, edit)| Command::EditMaterial { object, edit }),
        2 => (object(), proptest::sample::select(ObjectKind::ALL.to_vec()))
            .prop_map(|(object, kind)| Command::SetKind { object, kind }),
        1 => Just(Command::Pause),
        2 => Just(Command::Resume),
        1 => prop_oneof![0..4u64, Just(u64::MAX)].prop_map(|count| Command::Step { count }),
        1 => Just(Command::Reset),
    ]
}

fn env_or<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn scene() -> Scene {
    Scene::builder()
        .grid_dx_m(0.02)
        .duration_s(1e6)
        .frame_rate_hz(env_or("SPLATPHYS_FUZZ_FRAME_HZ", 240.0))
        .object(
            SceneObject::sphere("ball", [0.0, 0.0, 0.12], 0.06)
                .material(MaterialSpec::jelly(2e5, 0.3, 1000.0)),
        )
        .object(
            SceneObject::cuboid("box", [0.15, -0.04, 0.0], [0.23, 0.04, 0.08])
                .kind(SceneKind::Rigid)
                .material(MaterialSpec::jelly(1e6, 0.3, 500.0)),
        )
        .collider(ColliderSpec::ground("floor"))
        .build()
        .expect("scene")
}

#[test]
fn ten_thousand_hostile_commands_never_panic_stall_or_leave_a_non_finite_state() {
    let total: usize = env_or("SPLATPHYS_FUZZ_COMMANDS", 10_000);
    // SAFETY: set before any iceoryx2 node exists, in the only test of this binary.
    unsafe {
        std::env::set_var(
            "SPLATPHYS_IOX2_PREFIX",
            format!("spfz_{}_", std::process::id()),
        )
    };
    let stop = Arc::new(AtomicBool::new(false));
    let cfg = ServerConfig {
        prefix: Some("t/fuzz".into()),
        stop: stop.clone(),
        exit_when_finished: false,
        ..ServerConfig::default()
    };
    let mut sim = WorldSim::new("fuzz", &scene()).expect("world");
    let particles = sim.world.particle_count();
    assert!(particles <= 2000, "{particles} particles");
    let server = std::thread::spawn(move || {
        let report = serve(&mut sim, &cfg).expect("the server never fails");
        (report, sim.world.bodies().len())
    });

    let mut opts = ClientOptions::new("t/fuzz");
    opts.connect_timeout = Duration::from_secs(30);
    opts.frames = false;
    let mut conn = Connection::connect(&opts).expect("connect");

    let mut runner = TestRunner::new_with_rng(
        Config::default(),
        TestRng::from_seed(
            RngAlgorithm::ChaCha,
            &[env_or("SPLATPHYS_FUZZ_SEED", 7u8); 32],
        ),
    );
    let batch = proptest::collection::vec(command(), 1..=10);
    let (mut sent, mut accepted, mut rejected, mut frames_checked) = (0usize, 0, 0, 0);
    let started = Instant::now();
    while sent < total {
        let commands = batch.new_tree(&mut runner).expect("batch").current();
        let pending: Vec<_> = commands
            .iter()
            .map(|c| conn.send_command(c).expect("send").1)
            .collect();
        sent += pending.len();
        for p in &pending {
            let t0 = Instant::now();
            let reply = loop {
                if let Some(r) = conn.poll_reply(p).expect("reply") {
                    break r;
                }
                conn.poll_status().expect("the server is alive");
                // Answered within one frame of a few hundred particles; 30 s only catches a stall.
                assert!(
                    t0.elapsed() < Duration::from_secs(30),
                    "a command got no reply"
                );
                std::thread::sleep(Duration::from_micros(200));
            };
            match reply {
                Reply::Accepted { .. } => accepted += 1,
                Reply::Rejected { .. } => rejected += 1,
            }
        }
        while let Some(objects) = conn.recv_objects().expect("objects") {
            frames_checked += 1;
            for o in objects.payload() {
                let finite = o.position_m.iter().all(|x| x.is_finite())
                    && o.velocity_m_s.iter().all(|x| x.is_finite())
                    && o.angular_velocity_rad_s.iter().all(|x| x.is_finite())
                    && o.orientation_wxyz.iter().all(|x| x.is_finite())
                    && o.mass_kg.is_finite();
                assert!(finite, "non-finite object state published: {o:?}");
            }
        }
    }
    let status = conn.poll_status().expect("status").expect("a status");
    stop.store(true, Ordering::Release);
    let (report, objects) = server.join().expect("the server thread never panics");
    assert_eq!(objects, 2);
    assert_eq!(report.commands_received as usize, sent);
    assert_eq!(accepted + rejected, sent, "every command answered");
    eprintln!(
        "command fuzz: {sent} commands ({accepted} accepted, {rejected} rejected) in {:.1} s; \
         {frames_checked} object frames checked finite; {} steps, {} step failures restored{}",
        started.elapsed().as_secs_f64(),
        report.step,
        report.step_failures,
        if status.flags & STATUS_FAILED != 0 {
            " (paused on one at the end)"
        } else {
            ""
        }
    );
}
