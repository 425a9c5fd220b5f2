//! The capture formats people publish (SOG, SPZ, glTF KHR_gaussian_splatting) against a
//! reference: PlayCanvas splat-transform 3.7.0 wrote every fixture from `source.ply` (a seeded
//! random cloud, SH degree 3) and decoded its own SOG files (`*_reference.ply`);
//! `fixtures/formats/make.sh` remakes them.

use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};
use splatphys_formats::gaussians::GaussianCloud;
use splatphys_formats::spz::{SpzFrame, parse_spz, to_spz_bytes};
use splatphys_formats::{
    FileFormat, FormatError, ReadOptions, read_gaussians, read_gaussians_with,
};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/formats")
        .join(name)
}

fn source() -> GaussianCloud {
    read_gaussians(fixture("source.ply")).expect("source.ply")
}

/// Largest difference between two clouds' fields, Gaussian by Gaussian, each quantity compared
/// as what a renderer uses: centres, covariances (relative to their largest entry), opacity after
/// the sigmoid, SH DC and rest values.
#[derive(Debug, Default)]
struct Diff {
    position: f32,
    covariance_rel: f32,
    opacity: f32,
    dc: f32,
    rest: f32,
}

fn diff(a: &GaussianCloud, b: &GaussianCloud) -> Diff {
    assert_eq!(a.len(), b.len(), "Gaussian counts");
    assert_eq!(a.sh_rest_len, b.sh_rest_len, "SH values per Gaussian");
    let mut d = Diff::default();
    let max = |m: &mut f32, v: f32| *m = m.max(v);
    for i in 0..a.len() {
        max(
            &mut d.position,
            (a.position(i) - b.position(i)).abs().max_element(),
        );
        let (ca, cb) = (a.covariance(i), b.covariance(i));
        let scale = ca.to_cols_array().iter().fold(0f32, |m, v| m.max(v.abs()));
        let worst = (ca - cb)
            .to_cols_array()
            .iter()
            .fold(0f32, |m, v| m.max(v.abs()));
        max(&mut d.covariance_rel, worst / scale);
        max(&mut d.opacity, (a.opacity(i) - b.opacity(i)).abs());
        for c in 0..3 {
            max(&mut d.dc, (a.sh_dc[i][c] - b.sh_dc[i][c]).abs());
        }
    }
    for (x, y) in a.sh_rest.iter().zip(&b.sh_rest) {
        max(&mut d.rest, (x - y).abs());
    }
    d
}

#[test]
fn sog_folder_meta_and_bundle_decode_as_splat_transform_does() {
    let reference = read_gaussians(fixture("sog_reference.ply")).unwrap();
    for (path, format) in [
        (fixture("sog"), FileFormat::Sog),
        (fixture("sog/meta.json"), FileFormat::Sog),
        (fixture("source.sog"), FileFormat::SogBundle),
    ] {
        let (cloud, found) = read_gaussians_with(&path, &ReadOptions::default()).unwrap();
        assert_eq!(found, format, "{}", path.display());
        assert_eq!(cloud.sh_degree, 3);
        let d = diff(&cloud, &reference);
        // The same arithmetic in f64 here and in JavaScript; only the f32 rounding of the
        // reference PLY differs. splat-transform clamps alpha to [1e-6, 1 - 1e-6].
        assert!(d.position < 1e-5, "{}: {d:?}", path.display());
        assert!(d.covariance_rel < 1e-5, "{}: {d:?}", path.display());
        assert!(
            d.opacity < 1e-5 && d.dc < 1e-6 && d.rest < 1e-6,
            "{}: {d:?}",
            path.display()
        );
    }
}

#[test]
fn sog_is_the_source_within_its_quantisation() {
    let cloud = read_gaussians(fixture("source.sog")).unwrap();
    let src = source();
    // Splats come out in Morton order: match each to its source by position.
    let tree: Vec<(usize, Vec3)> = (0..src.len()).map(|i| (i, src.position(i))).collect();
    let mut worst_rel = 0f32;
    for i in 0..cloud.len() {
        let p = cloud.position(i);
        let (j, q) = tree
            .iter()
            .min_by(|a, b| (a.1 - p).length().total_cmp(&(b.1 - p).length()))
            .copied()
            .unwrap();
        // 16 bits over ln(1 + |x|) in [−1.5, 1.5]: a step of 5e-5 in the log.
        worst_rel = worst_rel.max((p - q).abs().max_element() / (1.0 + q.abs().max_element()));
        assert!(
            (cloud.opacity(i) - src.opacity(j)).abs() < 1.0 / 255.0 + 1e-6,
            "splat {i}"
        );
    }
    assert!(
        worst_rel < 1e-4,
        "position error relative to 1 + |x|: {worst_rel}"
    );
}

#[test]
fn streamed_sog_reads_the_level_asked_for() {
    let lod = fixture("lod");
    let finest = read_gaussians(&lod).unwrap();
    assert_eq!(finest.len(), 400);
    let (coarse, format) = read_gaussians_with(
        fixture("lod/lod-meta.json"),
        &ReadOptions {
            lod: Some(1),
            ..ReadOptions::default()
        },
    )
    .unwrap();
    assert_eq!(format, FileFormat::SogLod);
    let reference = read_gaussians(fixture("lod1_reference.ply")).unwrap();
    let d = diff(&coarse, &reference);
    assert!(
        d.position < 1e-5 && d.covariance_rel < 1e-5 && d.rest < 1e-6,
        "{d:?}"
    );
    let err = splatphys_formats::sog::read_sog(&lod, Some(2)).unwrap_err();
    assert!(err.to_string().contains("levels 0 to 1"), "{err}");
}

/// Bounds of SPZ's quantisation: centres 1/4096 (12 fractional bits), log scales 1/32, DC
/// (1/255)/0.15/2, alpha 1/510, SH half a bucket of 16 steps of 1/128 (the reference's 4 bits)
/// plus the rounding to 1/128 before it.
fn assert_within_spz_quantisation(cloud: &GaussianCloud, src: &GaussianCloud, what: &str) {
    let d = diff(cloud, src);
    assert!(d.position <= 0.5 / 4096.0 + 1e-6, "{what}: {d:?}");
    assert!(d.opacity <= 0.5 / 255.0 + 1e-6, "{what}: {d:?}");
    assert!(d.dc <= 0.5 / 255.0 / 0.15 + 1e-5, "{what}: {d:?}");
    assert!(d.rest <= 8.5 / 128.0 + 1e-5, "{what}: {d:?}");
    for i in 0..cloud.len() {
        for c in 0..3 {
            let e = (cloud.log_scales[i][c] - src.log_scales[i][c]).abs();
            assert!(e <= 1.0 / 32.0 + 1e-5, "{what} splat {i} scale: {e}");
        }
        let angle = cloud.rotation(i).angle_between(src.rotation(i));
        assert!(
            angle < 0.01,
            "{what} splat {i}: rotation off by {angle} rad"
        );
    }
}

#[test]
fn spz_versions_3_and_4_hold_the_source_within_their_quantisation() {
    let src = source();
    let mut versions = Vec::new();
    for name in ["source_v3.spz", "source_v4.spz"] {
        let bytes = std::fs::read(fixture(name)).unwrap();
        // splat-transform stores the PLY's values without the RUB turn.
        let cloud = parse_spz(&fixture(name), &bytes, SpzFrame::AsStored).unwrap();
        assert_eq!(cloud.sh_degree, 3);
        assert_within_spz_quantisation(&cloud, &src, name);
        versions.push(cloud);
    }
    assert_eq!(
        versions[0], versions[1],
        "v3 and v4 carry the same quantised values"
    );
    // The default reads the convention, RUB: a half turn about x.
    let (rub, format) =
        read_gaussians_with(fixture("source_v4.spz"), &ReadOptions::default()).unwrap();
    assert_eq!(format, FileFormat::Spz);
    let turn = Quat::from_rotation_x(std::f32::consts::PI);
    for i in 0..rub.len() {
        let p = versions[0].position(i);
        assert_eq!(rub.position(i), Vec3::new(p.x, -p.y, -p.z));
        let want = turn * versions[0].rotation(i);
        // The same rotation up to the quaternion's sign (acos near 1 is too coarse in f32).
        assert!(rub.rotation(i).dot(want).abs() > 1.0 - 1e-6, "splat {i}");
    }
}

#[test]
fn glb_from_splat_transform_is_the_source_back_in_the_ply_frame() {
    let (cloud, format) =
        read_gaussians_with(fixture("source.glb"), &ReadOptions::default()).unwrap();
    assert_eq!(format, FileFormat::Gltf);
    let d = diff(&cloud, &source());
    // splat-transform turned the PLY into glTF's frame; reading turns it back. Float data:
    // only rounding (SH through a fitted band matrix, scales through exp and ln).
    assert!(d.position < 1e-5 && d.covariance_rel < 1e-4, "{d:?}");
    assert!(d.opacity < 1e-6 && d.dc < 1e-6 && d.rest < 1e-5, "{d:?}");
}

#[test]
fn spz_written_here_reads_back_turned_to_y_up() {
    let src = source();
    let bytes = to_spz_bytes(Path::new("out.spz"), &src).unwrap();
    let stored = parse_spz(Path::new("out.spz"), &bytes, SpzFrame::AsStored).unwrap();
    // World z up is stored as RUB y up: (x, y, z) → (x, z, −y), a quarter turn about x.
    let mut turned = src.clone();
    let q = Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    for i in 0..turned.len() {
        turned.positions[i] = (q * src.position(i)).to_array();
        let r = q * src.rotation(i);
        turned.rotations_wxyz[i] = [r.w, r.x, r.y, r.z];
    }
    splatphys_formats::gaussians::sh_rotation::rotate_cloud_sh(&mut turned, q);
    turned.normals = None;
    assert_within_spz_quantisation(&stored, &turned, "written SPZ");
}

#[test]
fn damaged_captures_give_errors_that_name_the_part() {
    let v3 = std::fs::read(fixture("source_v3.spz")).unwrap();
    let cut =
        splatphys_formats::parse_gaussians(Path::new("cut.spz"), &v3[..v3.len() / 2]).unwrap_err();
    assert!(
        matches!(
            cut,
            FormatError::Layout { .. } | FormatError::Truncated { .. }
        ),
        "{cut}"
    );
    let v4 = std::fs::read(fixture("source_v4.spz")).unwrap();
    let cut =
        splatphys_formats::parse_gaussians(Path::new("cut.spz"), &v4[..v4.len() - 10]).unwrap_err();
    assert!(cut.to_string().contains("cut.spz"), "{cut}");
    let glb = std::fs::read(fixture("source.glb")).unwrap();
    let cut = splatphys_formats::parse_gaussians(Path::new("cut.glb"), &glb[..glb.len() / 2])
        .unwrap_err();
    assert!(cut.to_string().contains("cut.glb"), "{cut}");
    let sog = std::fs::read(fixture("source.sog")).unwrap();
    let cut = splatphys_formats::parse_gaussians(Path::new("cut.sog"), &sog[..sog.len() / 2])
        .unwrap_err();
    assert!(cut.to_string().contains("cut.sog"), "{cut}");
    // Every prefix of every fixture is an error or a cloud, never a panic.
    for bytes in [&v3, &v4, &glb, &sog] {
        for len in (0..bytes.len()).step_by(997) {
            let _ = splatphys_formats::parse_gaussians(Path::new("prefix"), &bytes[..len]);
        }
    }
}
