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

/// Lossless WebP of `w × h` RGBA texels.
fn webp(dir: &Path, name: &str, w: u32, h: u32, rgba: &[u8]) {
    let mut bytes = Vec::new();
    image::codecs::webp::WebPEncoder::new_lossless(&mut bytes)
        .encode(rgba, w, h, image::ExtendedColorType::Rgba8)
        .unwrap();
    std::fs::write(dir.join(name), bytes).unwrap();
}

#[test]
fn sog_version_1_lerps_its_ranges_and_stores_opacity_as_a_logit() {
    // Version 1 (the first SuperSplat exporter and PlayCanvas's Python tool): no codebooks,
    // per-channel mins/maxs, opacity a lerped logit, SH bands from the centroid width.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Two splats in a 2 × 1 image: bytes chosen, expected values from the format's formulas.
    webp(d, "means_l.webp", 2, 1, &[0, 0, 0, 255, 255, 255, 255, 255]);
    webp(d, "means_u.webp", 2, 1, &[0, 0, 0, 255, 255, 255, 255, 255]);
    // Splat 0: w largest (tag 252) and a = b = c = 0 (byte 127.5 is not a byte: use 128).
    // Splat 1: z largest (tag 255), x = (200/255 − 0.5)√2.
    webp(
        d,
        "quats.webp",
        2,
        1,
        &[128, 128, 128, 252, 200, 128, 128, 255],
    );
    webp(d, "scales.webp", 2, 1, &[0, 255, 51, 255, 255, 0, 102, 255]);
    webp(d, "sh0.webp", 2, 1, &[0, 255, 0, 0, 255, 0, 255, 255]);
    // One band: 64 entries × 3 texels a row; splat 0 uses entry 0, splat 1 entry 1.
    let mut centroids = vec![0u8; 192 * 4];
    for (k, px) in centroids.chunks_exact_mut(4).enumerate() {
        px.copy_from_slice(&[k as u8, 255 - k as u8, 0, 255]);
    }
    webp(d, "shN_centroids.webp", 192, 1, &centroids);
    webp(d, "shN_labels.webp", 2, 1, &[0, 0, 0, 255, 1, 0, 0, 255]);
    let meta = serde_json::json!({
        "means": {"shape": [2, 3], "dtype": "float32", "mins": [-1.0, 0.0, 2.0], "maxs": [1.0, 0.5, 3.0],
                  "files": ["means_l.webp", "means_u.webp"]},
        "scales": {"shape": [2, 3], "dtype": "float32", "mins": [-6.0, -6.0, -6.0], "maxs": [-1.0, -1.0, -1.0],
                   "files": ["scales.webp"]},
        "quats": {"shape": [2, 4], "dtype": "uint8", "encoding": "quaternion_packed", "files": ["quats.webp"]},
        "sh0": {"shape": [2, 1, 4], "dtype": "float32", "mins": [-2.0, -2.0, -2.0, -5.0], "maxs": [2.0, 2.0, 2.0, 5.0],
                "files": ["sh0.webp"]},
        "shN": {"shape": [2, 9], "dtype": "float32", "mins": -1.0, "maxs": 1.0, "quantization": 8,
                "files": ["shN_centroids.webp", "shN_labels.webp"]}
    });
    std::fs::write(d.join("meta.json"), meta.to_string()).unwrap();
    let (cloud, format) = read_gaussians_with(d, &ReadOptions::default()).unwrap();
    assert_eq!(format, FileFormat::Sog);
    assert_eq!((cloud.len(), cloud.sh_degree, cloud.sh_rest_len), (2, 1, 9));
    let unlog = |n: f64| (n.signum() * (n.abs().exp() - 1.0)) as f32;
    assert_eq!(cloud.positions[0], [unlog(-1.0), unlog(0.0), unlog(2.0)]);
    assert_eq!(cloud.positions[1], [unlog(1.0), unlog(0.5), unlog(3.0)]);
    assert_eq!(cloud.log_scales[0], [-6.0, -1.0, -5.0]);
    assert_eq!(cloud.log_scales[1], [-1.0, -6.0, -4.0]);
    assert_eq!(cloud.sh_dc[0], [-2.0, 2.0, -2.0]);
    assert_eq!(cloud.opacity_logit, [-5.0, 5.0]);
    let q1 = cloud.rotations_wxyz[1];
    let x = ((200.0 / 255.0 - 0.5) * std::f64::consts::SQRT_2) as f32;
    assert!(
        (q1[0] - x).abs() < 1e-6 && (q1[3] - (1.0 - x * x).sqrt()).abs() < 2e-2,
        "{q1:?}"
    );
    assert!((cloud.rotations_wxyz[0][0] - 1.0).abs() < 1e-3);
    // Entry 1's texels are 3, 4, 5 (R) and 252, 251, 250 (G): channel-major f_rest.
    let lerp = |b: f32| -1.0 + 2.0 * b / 255.0;
    assert_eq!(cloud.sh_rest[9..12], [lerp(3.0), lerp(4.0), lerp(5.0)]);
    assert_eq!(
        cloud.sh_rest[12..15],
        [lerp(252.0), lerp(251.0), lerp(250.0)]
    );
    assert_eq!(cloud.sh_rest[15..18], [lerp(0.0); 3]);
}

/// An SPZ body of versions 1–3 (before gzip) by hand from nianticlabs/spz's description: two
/// Gaussians, SH degree 1.
fn spz_legacy(version: u32) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(&0x5053_474e_u32.to_le_bytes());
    b.extend_from_slice(&version.to_le_bytes());
    b.extend_from_slice(&2u32.to_le_bytes());
    b.extend_from_slice(&[1, 12, 0, 0]);
    let centres = [[1.0f32, -2.0, 0.5], [-0.25, 0.0, 3.0]];
    for c in centres.iter().flatten() {
        if version == 1 {
            b.extend_from_slice(&half::f16::from_f32(*c).to_le_bytes());
        } else {
            let fixed = (c * 4096.0).round() as i32;
            b.extend_from_slice(&fixed.to_le_bytes()[..3]);
        }
    }
    b.extend_from_slice(&[255, 0]); // alpha
    b.extend_from_slice(&[128, 166, 90, 0, 255, 128]); // colour
    b.extend_from_slice(&[80, 96, 112, 160, 0, 255]); // scales
    if version >= 3 {
        b.extend_from_slice(&0xC000_0000_u32.to_le_bytes()); // identity
        // x largest (index 0), the others 0 with their sign bits clear.
        b.extend_from_slice(&0x0000_0000_u32.to_le_bytes());
    } else {
        b.extend_from_slice(&[128, 128, 128]); // ≈ identity
        b.extend_from_slice(&[255, 128, 128]); // x = 1
    }
    for i in 0..2u8 {
        for k in 0..3u8 {
            for c in 0..3u8 {
                b.push(64 + 32 * c + 8 * k + i); // distinct per Gaussian, coefficient, channel
            }
        }
    }
    b
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    use std::io::Write;
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    gz.write_all(bytes).unwrap();
    gz.finish().unwrap()
}

#[test]
fn spz_versions_1_and_2_by_hand_decode_as_specified() {
    for version in [1, 2, 3] {
        let bytes = gzip(&spz_legacy(version));
        let c = parse_spz(Path::new("hand.spz"), &bytes, SpzFrame::AsStored).unwrap();
        let what = format!("version {version}");
        assert_eq!(c.len(), 2, "{what}");
        assert_eq!(c.positions[0], [1.0, -2.0, 0.5], "{what}");
        assert_eq!(c.positions[1], [-0.25, 0.0, 3.0], "{what}");
        assert_eq!(
            (c.opacity_logit[0], c.opacity_logit[1]),
            (40.0, -40.0),
            "{what}"
        );
        let dc = |b: f64| ((b / 255.0 - 0.5) / 0.15) as f32;
        assert_eq!(c.sh_dc[0], [dc(128.0), dc(166.0), dc(90.0)], "{what}");
        assert_eq!(c.log_scales[1], [0.0, -10.0, 255.0 / 16.0 - 10.0], "{what}");
        assert!(c.rotation(0).dot(Quat::IDENTITY).abs() > 0.9999, "{what}");
        assert!(
            c.rotation(1).dot(Quat::from_xyzw(1.0, 0.0, 0.0, 0.0)).abs() > 0.9999,
            "{what}"
        );
        // SPZ's SH are coefficient-major with RGB inner; f_rest is channel-major.
        for i in 0..2 {
            for k in 0..3 {
                for ch in 0..3 {
                    let b = f32::from(64 + 32 * ch as u8 + 8 * k as u8 + i as u8);
                    assert_eq!(c.sh_rest[i * 9 + ch * 3 + k], (b - 128.0) / 128.0, "{what}");
                }
            }
        }
    }
    // A body one byte short is refused, naming the shortfall.
    let mut short = spz_legacy(2);
    short.pop();
    let err = parse_spz(Path::new("short.spz"), &gzip(&short), SpzFrame::AsStored).unwrap_err();
    assert!(matches!(err, FormatError::Truncated { .. }), "{err}");
}

#[test]
fn spz_compressed_gltf_by_hand_reads_as_its_spz_turned_into_the_ply_frame() {
    // KHR_gaussian_splatting_compression_spz_2 (draft): the SPZ in buffer view 0, stored in
    // glTF's frame; placeholder accessors without buffer views.
    let spz = std::fs::read(fixture("source_v3.spz")).unwrap();
    let json = serde_json::json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_gaussian_splatting", "KHR_gaussian_splatting_compression_spz_2"],
        "extensionsRequired": ["KHR_gaussian_splatting_compression_spz_2"],
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"mode": 0,
            "attributes": {"POSITION": 0},
            "extensions": {"KHR_gaussian_splatting": {"kernel": "ellipse", "colorSpace": "srgb_rec709_display",
                "extensions": {"KHR_gaussian_splatting_compression_spz_2": {"bufferView": 0}}}}}]}],
        "accessors": [{"componentType": 5126, "type": "VEC3", "count": 400}],
        "buffers": [{"byteLength": spz.len()}],
        "bufferViews": [{"buffer": 0, "byteLength": spz.len()}]
    });
    let mut text = json.to_string().into_bytes();
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let mut bin = spz.clone();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + text.len() + 8 + bin.len();
    let mut glb = Vec::new();
    glb.extend_from_slice(b"glTF");
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&(total as u32).to_le_bytes());
    glb.extend_from_slice(&(text.len() as u32).to_le_bytes());
    glb.extend_from_slice(&0x4E4F_534A_u32.to_le_bytes());
    glb.extend_from_slice(&text);
    glb.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    glb.extend_from_slice(&0x004E_4942_u32.to_le_bytes());
    glb.extend_from_slice(&bin);
    let (cloud, format) = splatphys_formats::parse_gaussians(Path::new("spz.glb"), &glb).unwrap();
    assert_eq!(format, FileFormat::Gltf);
    let stored = parse_spz(Path::new("s.spz"), &spz, SpzFrame::AsStored).unwrap();
    let turn = Quat::from_rotation_z(std::f32::consts::PI);
    for i in 0..cloud.len() {
        let want = turn * stored.position(i);
        assert!(
            (cloud.position(i) - want).abs().max_element() < 1e-6,
            "Gaussian {i}"
        );
        assert!(cloud.rotation(i).dot(turn * stored.rotation(i)).abs() > 1.0 - 1e-6);
    }
}

#[test]
fn spz_sh_degree_4_is_cut_to_3_with_a_note() {
    // One Gaussian, version 2, degree 4: 24 coefficients a channel, byte = coefficient index.
    let mut b = Vec::new();
    b.extend_from_slice(&0x5053_474e_u32.to_le_bytes());
    b.extend_from_slice(&2u32.to_le_bytes());
    b.extend_from_slice(&1u32.to_le_bytes());
    b.extend_from_slice(&[4, 12, 0, 0]);
    b.extend_from_slice(&[0; 9]); // centre
    b.push(200); // alpha
    b.extend_from_slice(&[128; 3]); // colour
    b.extend_from_slice(&[100; 3]); // scales
    b.extend_from_slice(&[128; 3]); // rotation
    for k in 0..24u8 {
        b.extend_from_slice(&[k, k, k]);
    }
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("degree4.spz");
    std::fs::write(&file, gzip(&b)).unwrap();
    let options = ReadOptions {
        spz_frame: SpzFrame::AsStored,
        ..ReadOptions::default()
    };
    let (cloud, _, notes) = splatphys_formats::read_gaussians_noted(&file, &options).unwrap();
    assert_eq!((cloud.sh_degree, cloud.sh_rest_len), (3, 45));
    for k in 0..15 {
        assert_eq!(
            cloud.sh_rest[k],
            (k as f32 - 128.0) / 128.0,
            "coefficient {k}"
        );
    }
    assert_eq!(notes.len(), 1);
    assert!(notes[0].contains("SH degree 4 cut to 3"), "{notes:?}");
}

#[test]
fn inspect_reports_each_format_with_its_version() {
    for (name, format, version) in [
        ("sog", FileFormat::Sog, Some("version 2")),
        ("source.sog", FileFormat::SogBundle, Some("version 2")),
        ("lod", FileFormat::SogLod, Some("version 1")),
        ("source_v3.spz", FileFormat::Spz, Some("version 3")),
        ("source_v4.spz", FileFormat::Spz, Some("version 4")),
        ("source.glb", FileFormat::Gltf, Some("version 2.0")),
        ("source.ply", FileFormat::InriaPly, None),
    ] {
        let r = splatphys_formats::inspect::inspect(fixture(name)).unwrap();
        assert_eq!(
            (r.format, r.version.as_deref()),
            (format, version),
            "{name}"
        );
        assert_eq!((r.count, r.sh_degree), (400, 3), "{name}");
        assert!(r.file_bytes > 10_000, "{name}: {} bytes", r.file_bytes);
    }
}
