//! `splatphys-render mcap` on small recordings written with the record crate's writer: every
//! recorded frame is rendered, gaps in the frame index count as dropped, and a recording cut off
//! by a killed recorder is rendered up to its last closed chunk.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use splatphys_ipc::Simulation;
use splatphys_ipc::fake::FreeFall;
use splatphys_ipc::wire::{
    FrameGaussian, FrameHeader, LAYOUT_VERSION, SceneGaussian, SceneHeader, write_fixed_str,
};
use splatphys_record::writer::{RunWriter, WriterOptions};
use splatphys_tests::{Exit, Proc, bin, lit_pixels, pngs, summary};

/// Records the free-fall stand-in for steps 0..=`last`, leaving out the frames in `missing`.
fn record(path: &Path, last: u64, missing: &[u64]) {
    let mut sim = FreeFall::new("rec", 2, 300, 0.01, None);
    let n = sim.gaussian_count();
    let opts = WriterOptions {
        chunk_size_bytes: 8 << 10, // about one frame per chunk
        ..WriterOptions::default()
    };
    let mut w = RunWriter::create(path, opts).expect("create recording");
    let mut scene = vec![SceneGaussian::default(); n];
    sim.write_scene(&mut scene);
    let mut sh = SceneHeader {
        scene_generation: 0,
        layout_version: LAYOUT_VERSION,
        gaussian_count: n as u32,
        object_count: 2,
        sh_degree: 0,
        frame_dt_s: 0.01,
        ..SceneHeader::default()
    };
    write_fixed_str(&mut sh.scene_name, "rec");
    w.scene(&sh, &scene).expect("scene");
    let mut frame = vec![FrameGaussian::default(); n];
    for step in 0..=last {
        if step > 0 {
            sim.advance(&mut || true).expect("advance");
        }
        if missing.contains(&step) {
            continue;
        }
        sim.write_frame(&mut frame);
        let h = FrameHeader {
            step,
            time_s: sim.time_s(),
            substeps: sim.substeps(),
            frame_index: step,
            count: n as u32,
            scene_generation: 0,
            layout_version: LAYOUT_VERSION,
            ..Default::default()
        };
        w.frame(&h, &frame).expect("frame");
    }
    w.finish().expect("finish");
}

fn render_mcap(file: &Path, out: &Path, extra: &[&str]) -> Exit {
    Proc::spawn(
        Command::new(bin("splatphys-render"))
            .args(["--threads", "2", "mcap"])
            .arg(file)
            .arg("--out-dir")
            .arg(out)
            .args(["--width", "160", "--height", "120"])
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped()),
    )
    .wait_exit(Duration::from_secs(60))
}

#[test]
fn mcap_renders_every_recorded_frame() {
    let dir = tempfile::tempdir().expect("tempdir");
    let file = dir.path().join("run.mcap");
    record(&file, 6, &[3]);
    let out = dir.path().join("frames");
    let e = render_mcap(&file, &out, &[]);
    assert_eq!(e.code, Some(0), "{}", e.err);
    let s = summary(&e.out);
    assert_eq!(s["frames_rendered"].as_u64(), Some(6), "{s}");
    assert_eq!(s["frames_dropped"].as_u64(), Some(1), "{s}");
    assert_eq!(s["last_step"].as_u64(), Some(6), "{s}");
    let files = pngs(&out);
    assert_eq!(files.len(), 6, "{files:?}");
    assert!(!out.join("frame_00003.png").exists());
    let lit: Vec<usize> = files.iter().map(|f| lit_pixels(f)).collect();
    assert!(lit.iter().all(|&n| n > 0), "blank frame: {lit:?}");
    // The cubes fall: the camera is fixed, so the images change.
    let first = image::open(&files[0]).expect("png").into_rgb8();
    let last = image::open(&files[5]).expect("png").into_rgb8();
    assert_ne!(first.as_raw(), last.as_raw());
    assert!(out.join("animation.gif").is_file());
}

#[test]
fn mcap_every_keeps_the_final_frame() {
    let dir = tempfile::tempdir().expect("tempdir");
    let file = dir.path().join("run.mcap");
    record(&file, 6, &[]);
    let out = dir.path().join("frames");
    let gif = dir.path().join("run.gif");
    let e = render_mcap(
        &file,
        &out,
        &["--every", "4", "--gif", gif.to_str().unwrap()],
    );
    assert_eq!(e.code, Some(0), "{}", e.err);
    let s = summary(&e.out);
    // Steps 0 and 4 by `--every`, then the final step 6.
    assert_eq!(s["frames_rendered"].as_u64(), Some(3), "{s}");
    assert_eq!(s["frames_dropped"].as_u64(), Some(0), "{s}");
    assert_eq!(s["last_step"].as_u64(), Some(6), "{s}");
    assert!(gif.is_file());
}

#[test]
fn mcap_cut_off_recording_renders_closed_chunks() {
    let dir = tempfile::tempdir().expect("tempdir");
    let file = dir.path().join("run.mcap");
    record(&file, 20, &[]);
    let bytes = std::fs::read(&file).expect("read");
    std::fs::write(&file, &bytes[..bytes.len() / 2]).expect("truncate");
    let out = dir.path().join("frames");
    let e = render_mcap(&file, &out, &[]);
    assert_eq!(e.code, Some(0), "{}", e.err);
    let s = summary(&e.out);
    let n = s["frames_rendered"].as_u64().expect("frames_rendered");
    assert!((1..21).contains(&n), "{s}\n{}", e.err);
    assert!(e.err.contains("incomplete"), "{}", e.err);
}

#[test]
fn mcap_missing_file_fails_clearly() {
    let dir = tempfile::tempdir().expect("tempdir");
    let e = render_mcap(&dir.path().join("nope.mcap"), dir.path(), &[]);
    assert_ne!(e.code, Some(0));
    assert!(e.err.contains("nope.mcap"), "{}", e.err);
}
