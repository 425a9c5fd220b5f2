//! Automatic selection: RANSAC support plane + Euclidean clustering. Two donut clones standing
//! apart on a procedural table top are found as two objects with the plane; what it finds on
//! the guitar scene is reported.

use std::path::Path;

use glam::Vec3;
use splatphys_core::formats::{inspect::bounds, ply};
use splatphys_core::procedural::{Shape, shape_gaussians};
use splatphys_core::scene::transform::{
    apply_similarity, concat, euler_xyz_deg, subset, voxel_subsample,
};
use splatphys_core::selection::auto::{AutoParams, detect_objects};
use splatphys_core::selection::cluster::{dbscan, euclidean_clusters};
use splatphys_core::selection::geometric::opacity_at_least;

fn donut() -> Option<splatphys_core::gaussians::GaussianCloud> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/v3dg_donut.ply");
    match ply::read_ply(&p) {
        Ok(f) => {
            let all: Vec<usize> = (0..f.cloud.len()).collect();
            Some(subset(&f.cloud, &opacity_at_least(&f.cloud, &all, 0.1)))
        }
        Err(e) => {
            println!("skipping: {e}");
            None
        }
    }
}

#[test]
fn two_donut_clones_on_a_table_are_two_objects_and_a_plane() {
    let Some(d) = donut() else { return };
    // Table top: a 1 m x 0.6 m slab whose top face is z = 0.
    let table = shape_gaussians(
        &Shape::Box {
            min_m: [-0.5, -0.3, -0.012],
            max_m: [0.5, 0.3, 0.0],
        },
        0.006,
        [0.5, 0.4, 0.3],
        7,
    )
    .unwrap();
    // Donut base is at file z = -0.009: lift by 0.01 so it stands on the table.
    let mut left = d.clone();
    apply_similarity(
        &mut left,
        1.0,
        euler_xyz_deg([0.0; 3]),
        Vec3::new(-0.2, 0.0, 0.01),
    );
    let mut right = d.clone();
    apply_similarity(
        &mut right,
        1.0,
        euler_xyz_deg([0.0, 0.0, 90.0]),
        Vec3::new(0.2, 0.05, 0.01),
    );
    let scene = concat(&concat(&table, &left), &right);
    let n_table = table.len();
    let n_donut = d.len();
    let params = AutoParams {
        plane_tolerance_m: 0.004,
        ..AutoParams::default()
    };
    let t = std::time::Instant::now();
    let found = detect_objects(&scene.positions, &params);
    println!(
        "auto selection on {} points took {:.2} s",
        scene.len(),
        t.elapsed().as_secs_f64()
    );
    let plane = found.plane.as_ref().expect("support plane");
    println!(
        "plane normal {:?} offset {:.4} m, {} inliers (table top has about {} points)",
        plane.normal,
        plane.offset_m,
        plane.inliers.len(),
        n_table / 3
    );
    assert!(
        Vec3::from(plane.normal).dot(Vec3::Z) > 0.99,
        "{:?}",
        plane.normal
    );
    assert!(plane.offset_m.abs() < 0.01);
    for (k, o) in found.objects.iter().enumerate() {
        let [lo, hi] = bounds(&subset(&scene, o));
        println!("object {k}: {} Gaussians, bounds {lo:?} .. {hi:?}", o.len());
    }
    assert_eq!(found.objects.len(), 2, "expected exactly the two donuts");
    let mut centres = Vec::new();
    for o in &found.objects {
        // Each object is one donut: no table Gaussians, most of the donut.
        assert!(
            o.iter().all(|&i| i >= n_table),
            "table Gaussians in an object"
        );
        assert!(
            o.len() as f32 > 0.85 * n_donut as f32 && o.len() <= n_donut,
            "{} of {n_donut}",
            o.len()
        );
        let [lo, hi] = bounds(&subset(&scene, o));
        assert!(
            hi[0] - lo[0] < 0.25 && hi[1] - lo[1] < 0.25 && hi[2] < 0.11,
            "{lo:?} {hi:?}"
        );
        centres.push((lo[0] + hi[0]) / 2.0);
        // All from one clone.
        let from_left = o.iter().filter(|&&i| i < n_table + n_donut).count();
        assert!(from_left == 0 || from_left == o.len());
    }
    centres.sort_by(f32::total_cmp);
    assert!(
        (centres[0] + 0.2).abs() < 0.03 && (centres[1] - 0.2).abs() < 0.03,
        "{centres:?}"
    );
}

#[test]
fn report_auto_selection_on_guitar() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/playcanvas_guitar.ply");
    let Ok(f) = ply::read_ply(&p) else {
        println!("skipping: guitar not found");
        return;
    };
    // As in scenes/guitar_topple.toml: upright, ~1 m, opacity >= 0.1, 1 cm voxels.
    let all: Vec<usize> = (0..f.cloud.len()).collect();
    let mut g = subset(&f.cloud, &opacity_at_least(&f.cloud, &all, 0.1));
    apply_similarity(
        &mut g,
        0.23,
        euler_xyz_deg([-90.0, 0.0, 0.0]),
        Vec3::new(0.0, 0.0, 0.03),
    );
    let idx: Vec<usize> = (0..g.len()).collect();
    let g = subset(&g, &voxel_subsample(&g, &idx, 0.01));
    for eps in [0.01f32, 0.02, 0.05] {
        let found = detect_objects(
            &g.positions,
            &AutoParams {
                cluster_eps_m: eps,
                ..AutoParams::default()
            },
        );
        let plane = found.plane.as_ref().map(|p| (p.normal, p.inliers.len()));
        let sizes: Vec<usize> = found.objects.iter().take(5).map(Vec::len).collect();
        println!(
            "guitar ({} Gaussians), eps {eps} m: plane {plane:?}; {} clusters, largest {sizes:?}",
            g.len(),
            found.objects.len()
        );
    }
    // No plane at all: plain clustering of the whole guitar + stand.
    let clusters = euclidean_clusters(&g.positions, 0.05, 50);
    println!(
        "guitar, clustering only at 5 cm: {} clusters, sizes {:?}",
        clusters.len(),
        clusters.iter().take(5).map(Vec::len).collect::<Vec<_>>()
    );
    assert!(!clusters.is_empty());
    assert!(
        clusters[0].len() as f32 > 0.9 * g.len() as f32,
        "guitar and stand are connected at 5 cm"
    );
}

#[test]
fn dbscan_separates_two_blobs_and_marks_noise() {
    let mut pts = Vec::new();
    for i in 0..100 {
        let t = i as f32 * 0.001;
        pts.push([t, 0.0, 0.0]);
        pts.push([1.0 + t, 0.0, 0.0]);
    }
    pts.push([0.5, 0.5, 0.5]);
    let labels = dbscan(&pts, 0.0015, 3);
    assert_eq!(labels[200], -1);
    assert_ne!(labels[0], labels[1]);
    assert!(labels.iter().step_by(2).take(100).all(|&l| l == labels[0]));
}
