//! An exported frame is the simulation's frame: a deformed, turned patch of a real capture (the
//! PlayCanvas playbot, SH degree 2) written as a recording, exported with `splatphys-record
//! export`'s library, renders to the same image as the frame itself (PSNR ≥ 50 dB), and reads
//! back in Python's `plyfile` (where installed) with the frame's centres and object ids.

use std::path::Path;
use std::process::Command;

use glam::{Mat3, Quat, Vec3};
use splatphys_core::formats::read_gaussians;
use splatphys_core::gaussians::sh_coeffs_per_channel;
use splatphys_core::scene::transform::{apply_similarity, subset};
use splatphys_ipc::wire::{FrameGaussian, FrameHeader, SceneGaussian, SceneHeader};
use splatphys_record::export::{ExportFormat, ExportOptions, export_frames};
use splatphys_record::read::Recording;
use splatphys_record::writer::{RunWriter, WriterOptions};
use splatphys_render::camera::Camera;
use splatphys_render::render::{RenderSettings, render};
use splatphys_render::splats::{SplatView, Splats};

fn psnr_db(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let mse: f64 = a
        .iter()
        .zip(b)
        .flat_map(|(p, q)| {
            (0..3).map(move |c| f64::from(p[c].clamp(0.0, 1.0) - q[c].clamp(0.0, 1.0)).powi(2))
        })
        .sum::<f64>()
        / (3 * a.len()) as f64;
    10.0 * (1.0 / mse.max(1e-20)).log10()
}

#[test]
fn an_exported_frame_renders_as_the_frame() {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/playcanvas_playbot.ply");
    let full = read_gaussians(&path).unwrap();
    // The robot stands above y = −0.2 in the file (y down); every 8th opaque Gaussian of it.
    let keep: Vec<usize> = (0..full.len())
        .filter(|&i| full.positions[i][1] < -0.2 && full.opacity(i) > 0.5)
        .step_by(8)
        .collect();
    let mut cloud = subset(&full, &keep);
    apply_similarity(
        &mut cloud,
        1.0,
        Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2),
        Vec3::ZERO,
    );
    assert_eq!(cloud.sh_degree, 2);
    let n = cloud.len();
    eprintln!(
        "{n} Gaussians of the playbot, SH degree {}",
        cloud.sh_degree
    );
    let k = sh_coeffs_per_channel(cloud.sh_degree);

    // The scene: SH coefficient-major, as the server publishes it.
    let scene: Vec<SceneGaussian> = (0..n)
        .map(|i| {
            let mut sh = [0.0f32; 48];
            for (j, rgb) in cloud.sh_coefficients(i).iter().enumerate() {
                sh[3 * j..3 * j + 3].copy_from_slice(rgb);
            }
            SceneGaussian {
                sh,
                opacity: cloud.opacity(i),
                object_id: (i % 3) as u32,
                ..SceneGaussian::default()
            }
        })
        .collect();
    // A frame: each Gaussian sheared and turned by an amount that varies along z (as a
    // deforming body's would), its SH turned by the rotation.
    let frame: Vec<FrameGaussian> = (0..n)
        .map(|i| {
            let p = cloud.position(i);
            let r = Quat::from_rotation_z(1.5 * p.z) * Quat::from_rotation_x(0.4 * p.x);
            let f = Mat3::from_quat(r)
                * Mat3::from_cols(
                    Vec3::X,
                    Vec3::new(0.3 * p.z, 1.0, 0.0),
                    Vec3::new(0.0, 0.1, 0.9),
                );
            let s = f * cloud.covariance(i) * f.transpose();
            FrameGaussian {
                position_m: (r * p + Vec3::new(0.05, 0.0, 0.02)).to_array(),
                covariance_m2: [
                    s.x_axis.x, s.y_axis.x, s.z_axis.x, s.y_axis.y, s.z_axis.y, s.z_axis.z,
                ],
                rotation_wxyz: [r.w, r.x, r.y, r.z],
            }
        })
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let mcap = dir.path().join("run.mcap");
    let mut w = RunWriter::create(&mcap, WriterOptions::default()).unwrap();
    let header = SceneHeader {
        gaussian_count: n as u32,
        object_count: 3,
        sh_degree: 2,
        ..SceneHeader::default()
    };
    w.scene(&header, &scene).unwrap();
    let fh = FrameHeader {
        step: 7,
        frame_index: 1,
        count: n as u32,
        ..FrameHeader::default()
    };
    w.frame(&fh, &frame).unwrap();
    w.finish().unwrap();
    let out = dir.path().join("export");
    let opts = ExportOptions {
        formats: vec![ExportFormat::Ply],
        ..ExportOptions::default()
    };
    let report = export_frames(
        Recording::open(&mcap, false).unwrap(),
        &mcap,
        &out,
        &opts,
        |_| {},
    )
    .unwrap();
    assert_eq!(report.frames, 1);
    let ply = out.join("frame_000001.ply");
    let exported = read_gaussians(&ply).unwrap();

    // Both rendered from two sides, SH degree 2 evaluated.
    let positions: Vec<[f32; 3]> = frame.iter().map(|g| g.position_m).collect();
    let covariances: Vec<[f32; 6]> = frame.iter().map(|g| g.covariance_m2).collect();
    let rotations: Vec<[f32; 4]> = frame.iter().map(|g| g.rotation_wxyz).collect();
    let opacities: Vec<f32> = scene.iter().map(|g| g.opacity).collect();
    let sh: Vec<[f32; 3]> = scene
        .iter()
        .flat_map(|g| (0..k).map(move |j| [g.sh[3 * j], g.sh[3 * j + 1], g.sh[3 * j + 2]]))
        .collect();
    let frame_view =
        SplatView::new(&positions, &covariances, &opacities, &sh, 2, &rotations).unwrap();
    let splats = Splats::from_cloud(&exported);
    for position in [Vec3::new(1.6, -1.9, 1.1), Vec3::new(-1.2, 1.5, 0.4)] {
        let camera = Camera {
            position,
            look_at: Vec3::new(0.05, 0.0, 0.45),
            up: Vec3::Z,
            fov_y_deg: 40.0,
            width_px: 160,
            height_px: 120,
        };
        let settings = RenderSettings::default();
        let a = render(&frame_view, &camera, &settings).unwrap();
        let b = render(&splats.view().unwrap(), &camera, &settings).unwrap();
        let lit = a
            .pixels
            .iter()
            .filter(|p| p.iter().any(|v| *v > 0.05))
            .count();
        assert!(
            lit > a.pixels.len() / 20,
            "the robot fills part of the view ({lit} px)"
        );
        let psnr = psnr_db(&a.pixels, &b.pixels);
        eprintln!("camera at {position}: PSNR {psnr:.1} dB");
        assert!(psnr >= 50.0, "camera at {position}: {psnr:.1} dB");
    }

    // Python's plyfile, where installed (CI installs it): the same centres and object ids.
    let script = "import sys, json; from plyfile import PlyData; v = PlyData.read(sys.argv[1])['vertex']; \
                  print(json.dumps({'n': len(v), 'xyz': [[float(v['x'][i]), float(v['y'][i]), float(v['z'][i])] for i in range(0, len(v), 97)], \
                  'ids': [int(v['object_id'][i]) for i in range(0, len(v), 97)], 'rest': sum(1 for p in v.properties if p.name.startswith('f_rest_'))}))";
    match Command::new("python3")
        .args(["-c", script])
        .arg(&ply)
        .output()
    {
        Ok(o) if o.status.success() => {
            let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
            assert_eq!(j["n"].as_u64().unwrap() as usize, n);
            assert_eq!(j["rest"], 24, "degree 2: 24 f_rest_* properties");
            for (m, i) in (0..n).step_by(97).enumerate() {
                let xyz: Vec<f32> = j["xyz"][m]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|v| v.as_f64().unwrap() as f32)
                    .collect();
                assert_eq!(xyz, positions[i].to_vec(), "Gaussian {i}");
                assert_eq!(j["ids"][m].as_u64().unwrap() as usize, i % 3);
            }
        }
        _ => eprintln!(
            "plyfile check skipped: python3 with plyfile not installed (pip install plyfile)"
        ),
    }
}
