//! `splatphys-record export`: chosen frames of a recording as PLY and SPZ files that render as
//! the simulation's frame did (same centres, covariances and colours).

use std::path::Path;
use std::process::Command;

use glam::{Mat3, Quat, Vec3};
use splatphys_formats::gaussians::GaussianCloud;
use splatphys_formats::gaussians::sh_rotation::sh_basis;
use splatphys_ipc::wire::{
    BACKGROUND_OBJECT_ID, FrameGaussian, FrameHeader, SceneGaussian, SceneHeader,
};
use splatphys_record::writer::{RunWriter, WriterOptions};

/// Two Gaussians, SH degree 1: the first in object 0 and sheared as a frame goes on, turned by
/// a polar rotation about z; the second the captured background, at rest.
fn write_recording(path: &Path) -> Vec<Vec<FrameGaussian>> {
    let mut w = RunWriter::create(path, WriterOptions::default()).unwrap();
    let mut sh = [0.0f32; 48];
    sh[0] = 0.4;
    sh[3] = 0.3; // coefficient 1 (−C1 y), red
    sh[7] = -0.2; // coefficient 2 (C1 z), green
    let scene = [
        SceneGaussian {
            sh,
            opacity: 0.8,
            object_id: 0,
            ..SceneGaussian::default()
        },
        SceneGaussian {
            sh,
            opacity: 0.3,
            object_id: BACKGROUND_OBJECT_ID,
            ..SceneGaussian::default()
        },
    ];
    let header = SceneHeader {
        gaussian_count: 2,
        object_count: 1,
        sh_degree: 1,
        ..SceneHeader::default()
    };
    w.scene(&header, &scene).unwrap();
    let mut frames = Vec::new();
    for k in 0..4u64 {
        let t = k as f32 * 0.1;
        let r = Quat::from_rotation_z(t * 3.0);
        let f = Mat3::from_quat(r)
            * Mat3::from_cols(Vec3::new(1.0, 0.0, 0.0), Vec3::new(t, 1.0, 0.0), Vec3::Z);
        let sigma0 = Mat3::from_diagonal(Vec3::new(4e-4, 1e-4, 2.5e-5));
        let s = f * sigma0 * f.transpose();
        let upper = [
            s.x_axis.x, s.y_axis.x, s.z_axis.x, s.y_axis.y, s.z_axis.y, s.z_axis.z,
        ];
        let payload = vec![
            FrameGaussian {
                position_m: [t, 0.0, 0.5 - t],
                covariance_m2: upper,
                rotation_wxyz: [r.w, r.x, r.y, r.z],
            },
            FrameGaussian {
                position_m: [1.0, 1.0, 0.0],
                covariance_m2: [1e-4, 0.0, 0.0, 1e-4, 0.0, 1e-4],
                rotation_wxyz: [1.0, 0.0, 0.0, 0.0],
            },
        ];
        let fh = FrameHeader {
            step: 10 * k,
            time_s: f64::from(t),
            frame_index: k,
            count: 2,
            ..FrameHeader::default()
        };
        w.frame(&fh, &payload).unwrap();
        frames.push(payload);
    }
    w.finish().unwrap();
    frames
}

fn export(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_splatphys-record"))
        .arg("export")
        .args(args)
        .output()
        .expect("run splatphys-record export")
}

/// The colour a renderer computes towards world direction `d` from a cloud's SH (band 1 only).
fn band1(cloud: &GaussianCloud, i: usize, d: glam::DVec3) -> [f64; 3] {
    let b = sh_basis(d);
    let k = cloud.sh_rest_len / 3;
    [0, 1, 2].map(|c| {
        (0..3)
            .map(|j| f64::from(cloud.sh_rest[i * cloud.sh_rest_len + c * k + j]) * b[j])
            .sum()
    })
}

#[test]
fn exported_frames_render_as_the_simulated_ones() {
    let dir = tempfile::tempdir().unwrap();
    let mcap = dir.path().join("run.mcap");
    let frames = write_recording(&mcap);
    let out = dir.path().join("ply");
    let o = export(&[
        mcap.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--every",
        "2",
        "--format",
        "ply",
        "--format",
        "spz",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "frame_000000.ply",
            "frame_000000.spz",
            "frame_000002.ply",
            "frame_000002.spz"
        ]
    );

    let cloud = splatphys_formats::read_gaussians(out.join("frame_000002.ply")).unwrap();
    let frame = &frames[2];
    assert_eq!(cloud.len(), 2);
    assert_eq!(cloud.sh_degree, 1);
    let ids = &cloud
        .extra
        .iter()
        .find(|(n, _)| n == "object_id")
        .unwrap()
        .1;
    assert_eq!(ids, &vec![0.0, -1.0]);
    for (i, g) in frame.iter().enumerate() {
        assert_eq!(cloud.positions[i], g.position_m);
        let c = cloud.covariance(i);
        let want = g.covariance_m2;
        let got = [
            c.x_axis.x, c.y_axis.x, c.z_axis.x, c.y_axis.y, c.z_axis.y, c.z_axis.z,
        ];
        for (a, b) in got.iter().zip(want) {
            assert!((a - b).abs() < 1e-9, "Gaussian {i}: {got:?} vs {want:?}");
        }
    }
    assert!((cloud.opacity(0) - 0.8).abs() < 1e-6);
    // Colour towards R d now equals the scene's colour towards d.
    let r = Quat::from_xyzw(
        frame[0].rotation_wxyz[1],
        frame[0].rotation_wxyz[2],
        frame[0].rotation_wxyz[3],
        frame[0].rotation_wxyz[0],
    )
    .as_dquat();
    let scene_rest = [0.3, 0.0, 0.0, 0.0, -0.2, 0.0, 0.0, 0.0, 0.0];
    for d in [glam::DVec3::X, glam::DVec3::new(0.2, 0.9, -0.3).normalize()] {
        let b = sh_basis(d);
        let then = [0, 1, 2].map(|c| (0..3).map(|j| scene_rest[c * 3 + j] * b[j]).sum::<f64>());
        let now = band1(&cloud, 0, r * d);
        for c in 0..3 {
            assert!(
                (now[c] - then[c]).abs() < 1e-5,
                "channel {c}: {now:?} vs {then:?}"
            );
        }
    }
    // The SPZ of the same frame: y up, within its quantisation.
    let spz = splatphys_formats::read_gaussians(out.join("frame_000002.spz")).unwrap();
    assert_eq!(spz.len(), 2);
}

#[test]
fn steps_outside_the_recording_export_nothing_and_say_so() {
    let dir = tempfile::tempdir().unwrap();
    let mcap = dir.path().join("run.mcap");
    write_recording(&mcap);
    let out = dir.path().join("none");
    let o = export(&[
        mcap.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--steps",
        "1000..",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(err.contains("no frame") && err.contains("--steps"), "{err}");
    let o = export(&[
        mcap.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--steps",
        "20",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.join("frame_000002.ply").is_file());
    let o = export(&[
        mcap.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--steps",
        "9..3",
    ]);
    assert_eq!(o.status.code(), Some(2), "a bad range is a usage error");
}
