//! Semantic selection on synthetic features whose answer is known: a "vase" blob of Gaussians
//! whose features point at the vase embedding, next to a "table" whose features point at the
//! table embedding, plus mislabelled outliers far away (DBSCAN drops them) and holes inside the
//! vase (kNN infill restores them).

use std::collections::BTreeMap;

use splatphys_core::selection::semantic::{
    QueryEmbeddings, SemanticParams, positive_probability, select,
};

const D: usize = 8;

fn axis(k: usize) -> Vec<f32> {
    let mut v = vec![0.0; D];
    v[k] = 1.0;
    v
}

#[test]
fn synthetic_vase_is_selected_exactly() {
    let mut map = BTreeMap::new();
    map.insert("object".to_string(), axis(0));
    map.insert("things".to_string(), axis(1));
    map.insert("vase".to_string(), axis(2));
    map.insert("table".to_string(), axis(3));
    let q = QueryEmbeddings::from_map("q.json", &map, "vase", None).unwrap();
    assert_eq!(q.negatives.len(), 1);

    let mut points = Vec::new();
    let mut feats = Vec::new();
    let mut truth = Vec::new();
    let mut holes = 0;
    // Vase: 10 x 10 x 10 lattice, 5 mm spacing, around x = 0; a tenth of its Gaussians (on
    // scattered diagonal planes) carry a table-like feature: holes for the infill to restore.
    for i in 0..1000 {
        let (a, b, c) = (i % 10, (i / 10) % 10, i / 100);
        points.push([a as f32 * 0.005, b as f32 * 0.005, c as f32 * 0.005]);
        let hole = (a + 2 * b + 3 * c) % 10 == 3;
        holes += usize::from(hole);
        let mut f = axis(if hole { 3 } else { 2 });
        f[0] = 0.3; // a bit of "object" in everything
        feats.extend(f);
        truth.push(true);
    }
    // Table: a slab 0.2 m away.
    for i in 0..1000 {
        let (a, b) = (i % 40, i / 40);
        points.push([0.2 + a as f32 * 0.005, b as f32 * 0.005, 0.0]);
        feats.extend(axis(3));
        truth.push(false);
    }
    // Vase-like outliers far away (floaters).
    for i in 0..5 {
        points.push([1.0 + i as f32 * 0.2, 1.0, 1.0]);
        feats.extend(axis(2));
        truth.push(false);
    }
    let prob = positive_probability(&feats, D, &q, 0.05).unwrap();
    assert!(
        prob[0] > 0.99 && prob[1000] < 0.01,
        "{} {}",
        prob[0],
        prob[1000]
    );
    let sel = select(
        &points,
        &prob,
        &SemanticParams {
            eps_m: 0.008,
            min_samples: 4,
            knn: 8,
            ..SemanticParams::default()
        },
    )
    .unwrap();
    let expected: Vec<usize> = (0..truth.len()).filter(|&i| truth[i]).collect();
    println!(
        "selected {} of {} (expected {})",
        sel.len(),
        points.len(),
        expected.len()
    );
    assert_eq!(sel, expected);
    // Without infill the holes stay out.
    let no_infill = select(
        &points,
        &prob,
        &SemanticParams {
            eps_m: 0.008,
            min_samples: 4,
            knn: 0,
            ..SemanticParams::default()
        },
    )
    .unwrap();
    assert_eq!(no_infill.len(), 1000 - holes);
    assert!(holes > 50);
}

#[test]
fn missing_phrase_and_bad_shapes_are_errors() {
    let mut map = BTreeMap::new();
    map.insert("object".to_string(), axis(0));
    assert!(QueryEmbeddings::from_map("q.json", &map, "vase", None).is_err());
    map.insert("things".to_string(), axis(1));
    map.insert("vase".to_string(), vec![1.0; 3]);
    let q = QueryEmbeddings::from_map("q.json", &map, "vase", None).unwrap();
    assert!(positive_probability(&[0.0; 16], D, &q, 0.05).is_err());
}
