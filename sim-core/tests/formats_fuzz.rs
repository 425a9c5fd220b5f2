//! Mutation fuzzing of the readers (proptest): real headers and bodies (the first rows of the
//! donut, a compressed PLY, a .splat) with bytes flipped, spans deleted or duplicated, header
//! lines edited, and truncation. Every input must give Ok or a FormatError, never a panic.
//! Prints how many inputs were tried.

use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

use proptest::prelude::*;
use splatphys_core::formats::{self, ply};
use splatphys_core::procedural::isotropic_gaussians;

static TRIED: AtomicUsize = AtomicUsize::new(0);

fn seeds() -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    let donut = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/v3dg_donut_fused_original.ply");
    let cloud = match ply::read_ply(&donut) {
        Ok(f) => splatphys_core::scene::transform::subset(&f.cloud, &(0..40).collect::<Vec<_>>()),
        Err(_) => isotropic_gaussians(
            (0..40).map(|i| [i as f32, 0.0, 1.0]).collect(),
            0.01,
            [0.3, 0.5, 0.7],
        ),
    };
    out.push(ply::to_ply_bytes(&cloud, &["fuzz seed".into()]).unwrap());
    // A compressed PLY: 1 chunk, 3 vertices.
    let mut h = String::from("ply\nformat binary_little_endian 1.0\nelement chunk 1\n");
    for n in [
        "min_x",
        "min_y",
        "min_z",
        "max_x",
        "max_y",
        "max_z",
        "min_scale_x",
        "min_scale_y",
        "min_scale_z",
        "max_scale_x",
        "max_scale_y",
        "max_scale_z",
    ] {
        h.push_str(&format!("property float {n}\n"));
    }
    h.push_str("element vertex 3\nproperty uint packed_position\nproperty uint packed_rotation\nproperty uint packed_scale\nproperty uint packed_color\nend_header\n");
    let mut b = h.into_bytes();
    for v in [
        0.0f32, 0.0, 0.0, 1.0, 1.0, 1.0, -5.0, -5.0, -5.0, -1.0, -1.0, -1.0,
    ] {
        b.extend(v.to_le_bytes());
    }
    for v in 0..12u32 {
        b.extend((v.wrapping_mul(0x9e37_79b9)).to_le_bytes());
    }
    out.push(b);
    // A .splat of 4 records.
    out.push((0..128u8).map(|i| i.wrapping_mul(37)).collect());
    // The capture formats: an SPZ written here (gzip, version 3), and splat-transform's SPZ
    // version 4 (plain header, a table of zstd streams), GLB and bundled SOG fixtures.
    out.push(formats::spz::to_spz_bytes(Path::new("seed.spz"), &cloud).unwrap());
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("../formats/tests/fixtures/formats");
    for name in ["source_v4.spz", "source.glb", "source.sog"] {
        out.push(std::fs::read(fixtures.join(name)).unwrap());
    }
    out
}

#[derive(Debug, Clone)]
enum Mutation {
    Flip(usize, u8),
    Delete(usize, usize),
    Duplicate(usize, usize),
    Truncate(usize),
    HeaderLine(usize, String),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(a, b)| Mutation::Flip(a, b)),
        (any::<usize>(), 1usize..64).prop_map(|(a, b)| Mutation::Delete(a, b)),
        (any::<usize>(), 1usize..64).prop_map(|(a, b)| Mutation::Duplicate(a, b)),
        any::<usize>().prop_map(Mutation::Truncate),
        (
            any::<usize>(),
            prop_oneof![
                Just("element vertex 4294967295".to_string()),
                Just("element vertex 0".to_string()),
                Just("property list uchar int x".to_string()),
                Just("property double opacity".to_string()),
                Just("format ascii 1.0".to_string()),
                Just("format binary_big_endian 1.0".to_string()),
                Just("element chunk 99999999".to_string()),
                Just("property float f_rest_0".to_string()),
                Just("end_header".to_string()),
                "[a-z_ 0-9]{0,30}",
            ]
        )
            .prop_map(|(a, s)| Mutation::HeaderLine(a, s)),
    ]
}

fn apply(mut b: Vec<u8>, muts: &[Mutation]) -> Vec<u8> {
    for m in muts {
        if b.is_empty() {
            break;
        }
        let n = b.len();
        match m {
            Mutation::Flip(a, v) => b[a % n] ^= v | 1,
            Mutation::Delete(a, len) => {
                let s = a % n;
                b.drain(s..(s + len).min(n));
            }
            Mutation::Duplicate(a, len) => {
                let s = a % n;
                let span = b[s..(s + len).min(n)].to_vec();
                b.splice(s..s, span);
            }
            Mutation::Truncate(a) => b.truncate(a % n),
            Mutation::HeaderLine(a, line) => {
                let end = b
                    .windows(10)
                    .position(|w| w == b"end_header")
                    .unwrap_or(n.min(200));
                let starts: Vec<usize> = std::iter::once(0)
                    .chain((0..end).filter(|&i| b[i] == b'\n').map(|i| i + 1))
                    .collect();
                let s = starts[a % starts.len()];
                let e = b[s..].iter().position(|&c| c == b'\n').map_or(n, |p| s + p);
                b.splice(s..e, line.bytes());
            }
        }
    }
    b
}

/// Mutated inputs tried by [`readers_never_panic`].
const CASES: u32 = 6000;

#[test]
fn readers_never_panic() {
    use proptest::test_runner::{Config, TestRunner};
    let seeds = seeds();
    let mut runner = TestRunner::new(Config {
        cases: CASES,
        failure_persistence: None,
        ..Config::default()
    });
    let strategy = (0usize..seeds.len(), prop::collection::vec(mutation(), 1..5));
    runner
        .run(&strategy, |(seed, muts)| {
            let bytes = apply(seeds[seed].clone(), &muts);
            TRIED.fetch_add(1, Ordering::Relaxed);
            let p = Path::new("fuzz.ply");
            let _ = formats::parse_gaussians(p, &bytes);
            let _ = ply::parse_ply(p, &bytes);
            let _ = formats::compressed::parse_compressed_ply(p, &bytes);
            let _ = formats::splat::parse_splat(p, &bytes);
            Ok(())
        })
        .unwrap();
    // Every prefix of the PLY seed: each possible truncation point.
    let seed = &seeds[0];
    for len in 0..seed.len() {
        let _ = formats::parse_gaussians(Path::new("t.ply"), &seed[..len]);
        TRIED.fetch_add(1, Ordering::Relaxed);
    }
    println!(
        "fuzz: {} inputs tried ({CASES} mutated x 4 readers + {} truncations), no panic",
        TRIED.load(Ordering::Relaxed),
        seed.len()
    );
}
