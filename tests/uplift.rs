//! The whole stage-1 path through the command line: the donut, training cameras as
//! transforms.json, colour-rule feature maps as .npy files, `splatphys uplift --pca 2 --refine 1`
//! writing a PLY with `feat_*` and the basis, then a scene file that selects "icing" by text
//! through that basis. Plus the command's refusals.

// The stage-1 fixtures (training cameras, transforms.json, the donut's colour rule) are shared
// with the stage-1 crate's own tests: one copy, in its tests folder.
#[path = "../stage1/tests/common/mod.rs"]
mod common;

use std::path::PathBuf;
use std::process::Command;

use common::{colour_rule, ring_cameras, transforms_json};
use glam::Vec3;
use splatphys_core::formats::npy::read_npy_f32;
use splatphys_core::formats::read_gaussians;
use splatphys_core::scene::load_scene_str;
use splatphys_render::{RenderSettings, Splats, render};
use splatphys_stage1::FeatureMap;
use splatphys_tests::{bin, workspace};

/// The captured donut, in the data folder beside the workspace.
fn donut() -> PathBuf {
    workspace().join("../shared/data/v3dg_donut.ply")
}

/// `splatphys uplift`.
fn uplift() -> Command {
    let mut c = Command::new(bin("splatphys"));
    c.arg("uplift");
    c
}

#[test]
fn donut_from_feature_maps_to_a_text_selected_object() {
    let donut = donut();
    let cloud = read_gaussians(&donut).unwrap();
    let splats = Splats::from_cloud(&cloud);
    let view = splats.view().unwrap();
    let (lo, hi) = splats.positions.iter().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(lo, hi), p| (lo.min(Vec3::from(*p)), hi.max(Vec3::from(*p))),
    );
    let dir = tempfile::tempdir().unwrap();
    let feats = dir.path().join("features");
    std::fs::create_dir(&feats).unwrap();
    let cams = ring_cameras(0.5 * (lo + hi), 0.45, &[15.0, 50.0], 6, [160, 120]);
    for (camera, tv) in &cams {
        let image = render(&view, camera, &RenderSettings::default()).unwrap();
        // Three channels: icing, dough and a small constant (so the PCA has work to do).
        let data = image
            .pixels
            .iter()
            .flat_map(|&px| {
                let [i, d] = colour_rule(px);
                [i, d, 0.1 * (i + d)]
            })
            .collect();
        FeatureMap {
            height: image.height as usize,
            width: image.width as usize,
            dim: 3,
            data,
        }
        .write(&feats.join(format!("{}.npy", tv.name)))
        .unwrap();
    }
    let views: Vec<_> = cams.iter().map(|(_, v)| v.clone()).collect();
    let transforms = dir.path().join("transforms.json");
    std::fs::write(&transforms, transforms_json(&views).to_string()).unwrap();

    let out = dir.path().join("donut_feat.ply");
    let run = uplift()
        .args(["--ply", donut.to_str().unwrap(), "--cameras"])
        .arg(&transforms)
        .arg("--features")
        .arg(&feats)
        .arg("--out")
        .arg(&out)
        .args(["--pca", "2", "--refine", "1", "--threads", "2"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    let summary: serde_json::Value =
        serde_json::from_slice(run.stdout.trim_ascii_end()).expect("one JSON line");
    assert_eq!(summary["views"], 12);
    assert_eq!(summary["channels_in"], 3);
    assert_eq!(summary["channels_out"], 2);
    assert_eq!(summary["refine_loss"].as_array().unwrap().len(), 2);
    // The third channel is a multiple of the first two: two components keep everything.
    assert!(summary["pca_kept"].as_f64().unwrap() > 0.999, "{summary}");

    let lifted = read_gaussians(&out).unwrap();
    assert_eq!(lifted.len(), cloud.len());
    let names: Vec<&str> = lifted.extra.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["feat_0", "feat_1", "uplift_weight"]);
    assert_eq!(lifted.positions, cloud.positions);
    let basis = read_npy_f32(&dir.path().join("donut_feat.pca.npy")).unwrap();
    assert_eq!(basis.shape, vec![2, 3]);

    // Select by text in a scene file, through the basis.
    let emb = serde_json::json!({
        "icing": [1.0, 0.0, 0.1],
        "dough": [0.0, 1.0, 0.1],
        "object": [0.577, 0.577, 0.577],
        "things": [0.577, 0.577, 0.577],
    });
    std::fs::write(dir.path().join("emb.json"), emb.to_string()).unwrap();
    let scene = format!(
        r#"
[[source]]
name = "donut"
path = "{}"

[[object]]
name = "icing"
select = {{ source = "donut", query = "icing", embeddings = "emb.json", pca = "donut_feat.pca.npy", eps_m = 0.01 }}
material = {{ model = "jelly", youngs_modulus_pa = 2e4, poisson_ratio = 0.3, density_kg_m3 = 1000.0 }}
"#,
        out.display()
    );
    let scene = load_scene_str(&scene, dir.path()).unwrap();
    let icing = &scene.objects[0].gaussians;
    let mid_z = 0.5 * (lo.z + hi.z);
    let above = icing.positions.iter().filter(|p| p[2] > mid_z).count();
    println!(
        "{} of {} Gaussians selected as icing, {} above mid-height; {summary}",
        icing.len(),
        cloud.len(),
        above
    );
    assert!(icing.len() > cloud.len() / 10, "{}", icing.len());
    assert!(above as f64 >= 0.9 * icing.len() as f64);
}

#[test]
fn bad_arguments_are_refused_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let donut = donut();
    let run = |extra: &[&str]| {
        let out = uplift()
            .args(["--ply", donut.to_str().unwrap()])
            .args(extra)
            .output()
            .unwrap();
        assert!(!out.status.success());
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let d = dir.path().to_str().unwrap();
    // Outputs inside `dir`, so the last check sees whether a refused run wrote one.
    let (x_txt, x_ply) = (format!("{d}/x.txt"), format!("{d}/x.ply"));
    let bad_out = run(&["--cameras", d, "--features", d, "--out", &x_txt]);
    assert!(bad_out.contains(".ply or .npy"), "{bad_out}");
    let no_cams = run(&["--cameras", d, "--features", d, "--out", &x_ply]);
    assert!(no_cams.contains("not a transforms.json"), "{no_cams}");
    let json = dir.path().join("transforms.json");
    let views: Vec<_> = ring_cameras(Vec3::ZERO, 1.0, &[20.0], 2, [32, 24])
        .into_iter()
        .map(|(_, v)| v)
        .collect();
    std::fs::write(&json, transforms_json(&views).to_string()).unwrap();
    let no_maps = run(&[
        "--cameras",
        json.to_str().unwrap(),
        "--features",
        d,
        "--out",
        &x_ply,
    ]);
    assert!(no_maps.contains("view_00.npy"), "{no_maps}");
    assert!(!dir.path().join("x.ply").exists());
}
