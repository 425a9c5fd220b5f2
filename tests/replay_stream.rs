//! Replay streams from disk: its peak memory does not grow with the length of the recording,
//! and a damaged file is refused before anything is published unless `--recover` is given.
//!
//! Recordings are written directly with the recorder's writer (no server), then replayed by a
//! `splatphys-record replay --fast` process, which prints its peak resident memory. The size is
//! `SPLATPHYS_REPLAY_GAUSSIANS` Gaussians per frame (default 2,000: a replay that held the whole
//! file would need about 100 MB more at 2,000 frames than at 100).

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use splatphys_ipc::wire::{
    FrameGaussian, FrameHeader, ObjectName, ObjectState, SceneGaussian, SceneHeader,
};
use splatphys_record::read::{Recording, frame_headers, read_all, verify};
use splatphys_record::writer::{RunWriter, WriterOptions};
use splatphys_tests::{IOX_PREFIX_ENV, Proc, bin, iox_prefix, service_prefix};

/// Writes a recording of `frames` frames of `gaussians` Gaussians at pseudo-random positions
/// (which compress about as badly as real ones) and one object, in chunks of `chunk_bytes`.
fn write_recording(path: &Path, gaussians: usize, frames: u64, chunk_bytes: u64) {
    let opts = WriterOptions {
        pointcloud_every: 0,
        chunk_size_bytes: chunk_bytes,
        ..WriterOptions::default()
    };
    let mut w = RunWriter::create(path, opts).expect("create");
    let scene = SceneHeader {
        gaussian_count: gaussians as u32,
        object_count: 1,
        frame_dt_s: 1.0 / 30.0,
        ..SceneHeader::default()
    };
    w.scene(&scene, &vec![SceneGaussian::default(); gaussians])
        .expect("scene");
    let names_header = FrameHeader {
        count: 1,
        ..FrameHeader::default()
    };
    w.object_names(&names_header, &[ObjectName::new("cloud")])
        .expect("names");
    let mut payload = vec![FrameGaussian::default(); gaussians];
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    let mut random = move || {
        // xorshift64: reproducible noise in [0, 1).
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    for f in 0..frames {
        for g in &mut payload {
            g.position_m = [random(), random(), random()];
            g.covariance_m2 = [1e-4, 0.0, 0.0, 1e-4, 0.0, 1e-4];
            g.rotation_wxyz = [1.0, 0.0, 0.0, 0.0];
        }
        let h = FrameHeader {
            step: f,
            time_s: f as f64 / 30.0,
            frame_index: f,
            count: gaussians as u32,
            ..FrameHeader::default()
        };
        w.frame(&h, &payload).expect("frame");
        w.objects(&FrameHeader { count: 1, ..h }, &[ObjectState::default()])
            .expect("objects");
    }
    w.finish().expect("finish");
}

/// Runs `splatphys-record replay --fast <file> <extra>` to the end; returns (success, stderr).
fn replay(iox: &str, file: &Path, extra: &[&str]) -> (bool, String) {
    let mut c = Command::new(bin("splatphys-record"));
    c.arg("replay")
        .arg(file)
        .args(["--prefix", &service_prefix("rs"), "--fast"])
        .args(extra)
        .env(IOX_PREFIX_ENV, iox)
        .stderr(Stdio::piped());
    let out = Proc::spawn(&mut c).wait_exit(Duration::from_secs(600));
    (out.code == Some(0), out.err)
}

/// The `peak memory X MB` of a replay's last line.
fn peak_mb(stderr: &str) -> f64 {
    let tail = stderr
        .rsplit("peak memory ")
        .next()
        .and_then(|t| t.split_whitespace().next())
        .unwrap_or_else(|| panic!("no peak memory in {stderr}"));
    tail.parse()
        .unwrap_or_else(|_| panic!("bad peak memory in {stderr}"))
}

#[test]
fn replay_memory_does_not_grow_with_the_recording() {
    let gaussians: usize = std::env::var("SPLATPHYS_REPLAY_GAUSSIANS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2_000);
    let iox = iox_prefix("rs");
    let dir = tempfile::tempdir().expect("tempdir");
    let mut peaks = Vec::new();
    for frames in [100u64, 2_000] {
        let file = dir.path().join(format!("{frames}.mcap"));
        write_recording(&file, gaussians, frames, 4 << 20);
        let mb = std::fs::metadata(&file).expect("size").len() as f64 / 1e6;
        let (ok, err) = replay(&iox, &file, &[]);
        assert!(ok, "replay failed: {err}");
        assert!(
            err.contains(&format!("{frames} frames")),
            "replayed every frame: {err}"
        );
        let peak = peak_mb(&err);
        eprintln!(
            "replay_stream: {gaussians} Gaussians x {frames} frames ({mb:.0} MB file): peak memory {peak:.1} MB"
        );
        peaks.push(peak);
        std::fs::remove_file(&file).expect("remove");
    }
    let ratio = peaks[1] / peaks[0];
    assert!(
        (0.9..=1.1).contains(&ratio),
        "peak memory at 2,000 frames is {ratio:.2}x that at 100 ({peaks:?} MB)"
    );
    assert!(peaks[1] < 1000.0, "{peaks:?} MB");
}

#[test]
fn a_damaged_recording_is_refused_unless_recovered() {
    let iox = iox_prefix("rs-bad");
    let dir = tempfile::tempdir().expect("tempdir");
    let whole = dir.path().join("whole.mcap");
    write_recording(&whole, 2_000, 60, 256 << 10);
    verify(&whole).expect("a whole file verifies");
    let bytes = std::fs::read(&whole).expect("read");

    // Cut in the middle (a killed recorder): refused, with the way out named; nothing replayed.
    let cut = dir.path().join("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).expect("write");
    let (ok, err) = replay(&iox, &cut, &[]);
    assert!(!ok, "a truncated file must be refused");
    assert!(
        err.contains("truncated or corrupt") && err.contains("--recover"),
        "{err}"
    );
    assert!(
        !err.contains("frames, "),
        "refused before publishing: {err}"
    );
    // With --recover: the closed chunks before the cut, in order, and a note.
    let (ok, err) = replay(&iox, &cut, &["--recover"]);
    assert!(ok, "{err}");
    assert!(err.contains("ends early"), "{err}");
    let recovered = frame_headers(Recording::open(&cut, true).expect("open"), &cut).expect("read");
    assert!(
        !recovered.is_empty() && recovered.len() < 60,
        "{} frames",
        recovered.len()
    );
    assert!(
        recovered
            .iter()
            .enumerate()
            .all(|(i, h)| h.step == i as u64)
    );
    assert!(
        err.contains(&format!("{} frames", recovered.len())),
        "{err}"
    );

    // One byte flipped inside the data section: the CRCs catch it.
    let flipped = dir.path().join("flipped.mcap");
    let mut bad = bytes.clone();
    let at = bad.len() / 3;
    bad[at] ^= 0x40;
    std::fs::write(&flipped, &bad).expect("write");
    assert!(
        verify(&flipped).is_err(),
        "a flipped byte must fail verification"
    );
    assert!(read_all(&flipped, false).is_err());
    let (ok, err) = replay(&iox, &flipped, &[]);
    assert!(!ok && err.contains("truncated or corrupt"), "{err}");
}
