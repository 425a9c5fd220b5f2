//! `splatphys-zenoh` against `splatphys serve --fake`, heard by an in-test Zenoh session as a
//! remote client would: frames and the scene with the shared-memory byte layouts, a command as a
//! query and its reply, a bridge without `--allow-commands` refusing with the reason, and the
//! server's liveliness token gone within 3 s of a kill -9.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use splatphys_ipc::command::{Command as Cmd, encode};
use splatphys_ipc::wire::{FrameGaussian, FrameHeader, ReplyMsg, SceneHeader};
use splatphys_tests::{
    IOX_PREFIX_ENV, Proc, bin, free_port, iox_prefix, service_prefix, stepping_server,
};
use splatphys_zenoh::keys::Keys;
use zenoh::Wait;
use zenoh::sample::SampleKind;

fn bridge(iox: &str, prefix: &str, port: u16, extra: &[&str]) -> Proc {
    Proc::spawn(
        Command::new(bin("splatphys-zenoh"))
            .args([
                "--prefix",
                prefix,
                "--listen",
                &format!("tcp/127.0.0.1:{port}"),
            ])
            .args(extra)
            .env(IOX_PREFIX_ENV, iox)
            .stdout(Stdio::null())
            .stderr(Stdio::piped()),
    )
}

/// A Zenoh client session connected to the bridge only (no scouting), retried while the
/// bridge starts.
fn remote(port: u16) -> zenoh::Session {
    let t0 = Instant::now();
    loop {
        let mut c = zenoh::Config::default();
        c.insert_json5("mode", "\"client\"").unwrap();
        c.insert_json5("scouting/multicast/enabled", "false")
            .unwrap();
        c.insert_json5("connect/endpoints", &format!("[\"tcp/127.0.0.1:{port}\"]"))
            .unwrap();
        match zenoh::open(c).wait() {
            Ok(session) => return session,
            Err(e) if t0.elapsed() > Duration::from_secs(30) => panic!("no bridge at {port}: {e}"),
            Err(_) => std::thread::sleep(Duration::from_millis(100)),
        }
    }
}

/// Waits until a get of `key` answers (the bridge may still be starting: a query before its
/// queryables exist times out, and is asked again); the reply's payload or error text.
fn get(session: &zenoh::Session, key: &str, payload: Option<Vec<u8>>) -> Result<Vec<u8>, String> {
    let t0 = Instant::now();
    loop {
        let mut builder = session.get(key).timeout(Duration::from_secs(5));
        if let Some(p) = &payload {
            builder = builder.payload(p.clone());
        }
        let replies = builder.wait().expect("get");
        if let Ok(reply) = replies.recv() {
            match reply.result() {
                Ok(sample) => return Ok(sample.payload().to_bytes().to_vec()),
                Err(e) => {
                    let text = String::from_utf8_lossy(&e.payload().to_bytes()).into_owned();
                    if text != "Timeout" {
                        return Err(text);
                    }
                }
            }
        }
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "no answer to a get of {key}"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn a_remote_client_hears_frames_sends_commands_and_sees_the_server_go() {
    let iox = iox_prefix("zenoh");
    let prefix = service_prefix("zenoh");
    let mut server = stepping_server(&iox, &prefix, 100, &[]);
    let (port, closed_port) = (free_port(), free_port());
    let open = bridge(&iox, &prefix, port, &["--allow-commands"]);
    let closed = bridge(&iox, &prefix, closed_port, &[]);
    let keys = Keys::new(&prefix);
    let session = remote(port);
    let alive = session
        .liveliness()
        .declare_subscriber(keys.alive())
        .history(true)
        .wait()
        .unwrap();

    // The scene, late: answered from the bridge's copy.
    let scene = loop {
        match get(&session, &keys.scene(), None) {
            Ok(bytes) => break bytes,
            Err(_) => std::thread::sleep(Duration::from_millis(100)),
        }
    };
    let header: SceneHeader = bytemuck::pod_read_unaligned(&scene[..size_of::<SceneHeader>()]);
    assert_eq!(
        header.gaussian_count, 200,
        "two fake objects of 100 Gaussians"
    );

    // Frames: the shared-memory layout, 200 Gaussians each, steps increasing.
    let frames = session.declare_subscriber(keys.frame()).wait().unwrap();
    let mut steps = Vec::new();
    while steps.len() < 5 {
        let sample = frames
            .recv_timeout(Duration::from_secs(20))
            .unwrap()
            .expect("a frame within 20 s");
        let bytes = sample.payload().to_bytes();
        let h: FrameHeader = bytemuck::pod_read_unaligned(&bytes[..size_of::<FrameHeader>()]);
        assert_eq!(
            (bytes.len() - size_of::<FrameHeader>()) / size_of::<FrameGaussian>(),
            200
        );
        assert_eq!(h.count, 200);
        steps.push(h.step);
    }
    assert!(steps.windows(2).all(|w| w[1] > w[0]), "{steps:?}");

    // A command as a query, and its reply.
    let push = Cmd::Impulse {
        object: 1,
        impulse_n_s: [0.0, 0.0, 0.01],
        point_m: None,
    };
    let msg = encode(&push, 7);
    let reply = get(
        &session,
        &keys.command(),
        Some(bytemuck::bytes_of(&msg).to_vec()),
    )
    .expect("a reply");
    let reply: ReplyMsg = bytemuck::pod_read_unaligned(&reply);
    assert_eq!((reply.accepted, reply.sequence), (1, 7), "{reply:?}");
    let wrong = get(&session, &keys.command(), Some(vec![1, 2, 3])).unwrap_err();
    assert!(wrong.contains("CommandMsg"), "{wrong}");
    let refused = get(
        &remote(closed_port),
        &keys.command(),
        Some(bytemuck::bytes_of(&msg).to_vec()),
    )
    .unwrap_err();
    assert!(refused.contains("--allow-commands"), "{refused}");

    // Both tokens alive; the server's goes within 3 s of a kill -9.
    let server_key = keys.server_alive();
    let mut seen = std::collections::HashSet::new();
    let t0 = Instant::now();
    while seen.len() < 2 && t0.elapsed() < Duration::from_secs(20) {
        if let Ok(Some(s)) = alive.recv_timeout(Duration::from_millis(200))
            && s.kind() == SampleKind::Put
        {
            seen.insert(s.key_expr().as_str().to_string());
        }
    }
    assert!(
        seen.contains(&server_key) && seen.contains(&keys.bridge_alive()),
        "{seen:?}"
    );
    server.kill9();
    let killed = Instant::now();
    let gone = loop {
        let s = alive
            .recv_timeout(Duration::from_secs(10))
            .unwrap()
            .expect("liveliness news within 10 s");
        if s.kind() == SampleKind::Delete && s.key_expr().as_str() == server_key {
            break killed.elapsed();
        }
    };
    eprintln!(
        "server token gone {:.2} s after kill -9",
        gone.as_secs_f64()
    );
    assert!(gone < Duration::from_secs(3), "{gone:?}");
    let exit = open.wait_exit(Duration::from_secs(20));
    assert_ne!(
        exit.code,
        Some(0),
        "a bridge whose server died fails: {}",
        exit.err
    );
    assert!(
        exit.err.to_lowercase().contains("gone") || exit.err.contains("heartbeat"),
        "{}",
        exit.err
    );
    let _ = closed.wait_exit(Duration::from_secs(20));
}
