//! `splatphys select`: the objects of a scene as a PLY with object ids and one mask per
//! object, agreeing with each other and with the scene, without simulating.

use std::process::Command;

use splatphys_core::formats::read_gaussians;

#[test]
fn selection_ply_masks_and_json_agree() {
    let dir = tempfile::tempdir().unwrap();
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/validation_two_spheres.toml"
    );
    let out = Command::new(env!("CARGO_BIN_EXE_splatphys"))
        .args(["select", scene, "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let cloud = read_gaussians(dir.path().join("selection.ply")).unwrap();
    let ids = &cloud
        .extra
        .iter()
        .find(|(n, _)| n == "object_id")
        .unwrap()
        .1;
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("objects.json")).unwrap()).unwrap();
    assert_eq!(json["gaussians"].as_u64().unwrap() as usize, cloud.len());
    let objects = json["objects"].as_array().unwrap();
    assert_eq!(objects.len(), 2);
    for (k, o) in objects.iter().enumerate() {
        assert_eq!(o["name"], ["left", "right"][k]);
        let mask: Vec<bool> = npyz::NpyFile::new(
            std::fs::File::open(dir.path().join(o["mask"].as_str().unwrap())).unwrap(),
        )
        .unwrap()
        .into_vec()
        .unwrap();
        assert_eq!(mask.len(), cloud.len());
        let count = mask.iter().filter(|m| **m).count();
        assert_eq!(count as u64, o["gaussians"].as_u64().unwrap());
        for (i, m) in mask.iter().enumerate() {
            assert_eq!(*m, ids[i] == k as f32, "Gaussian {i}");
            // Each sphere (radius 5 cm at x = ∓0.15 m) holds exactly its own Gaussians.
            if *m {
                let centre = [-0.15f32, 0.15][k];
                assert!(
                    (cloud.positions[i][0] - centre).abs() < 0.06,
                    "Gaussian {i}"
                );
            }
        }
        assert!(count > 100);
    }
}
