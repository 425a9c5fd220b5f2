//! A real capture (issue: stage 1 from images): the V3DG donut rendered from 24 views by our
//! rasterizer, a feature map painted from a colour rule (pink icing vs tan dough by hue), uplift,
//! then selecting "icing" must return the top of the donut: at least 90 % of the selected
//! Gaussians above the donut's mid-height (the file is z-up), and no fewer above the median
//! height than the Gaussians whose own colour is icing (the measured figures below say why the
//! median is not the line to hold the selection to).

mod common;

use common::{colour_rule, ring_cameras};
use glam::Vec3;
use splatphys_core::formats::read_gaussians;
use splatphys_core::selection::semantic::{
    QueryEmbeddings, SemanticParams, positive_probability, select,
};
use splatphys_render::{RenderSettings, Splats, render};
use splatphys_stage1::{Accumulator, FeatureMap, ProjectedView, UpliftSettings};

const DONUT: &str = "../../shared/data/v3dg_donut.ply";

#[test]
fn icing_selected_by_colour_rule_is_the_top_of_the_donut() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(DONUT);
    let cloud = read_gaussians(&path).expect("the donut from ../shared/data");
    let splats = Splats::from_cloud(&cloud);
    let view = splats.view().unwrap();
    let n = splats.positions.len();
    let mut zs: Vec<f32> = splats.positions.iter().map(|p| p[2]).collect();
    zs.sort_by(f32::total_cmp);
    let median_z = zs[n / 2];
    let (lo, hi) = splats.positions.iter().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(lo, hi), p| (lo.min(Vec3::from(*p)), hi.max(Vec3::from(*p))),
    );
    let centre = 0.5 * (lo + hi);

    let settings = UpliftSettings::default();
    let mut acc = Accumulator::new(n, 2);
    for (camera, tv) in ring_cameras(centre, 0.45, &[10.0, 40.0, 70.0], 8, [160, 120]) {
        let image = render(&view, &camera, &RenderSettings::default()).unwrap();
        let mut data = Vec::with_capacity(image.pixels.len() * 2);
        for &px in &image.pixels {
            data.extend(colour_rule(px));
        }
        let map = FeatureMap {
            height: image.height as usize,
            width: image.width as usize,
            dim: 2,
            data,
        };
        let projected = ProjectedView::new(&view, &tv.view, settings.near_m).unwrap();
        acc.add_view(&tv.name, &projected, &map, &settings).unwrap();
    }
    let up = acc.finish(settings.min_weight);

    let icing = vec![1.0, 0.0];
    let dough = vec![0.0, 1.0];
    let neutral = vec![std::f32::consts::FRAC_1_SQRT_2; 2];
    let q = QueryEmbeddings {
        positive: icing,
        canonical: vec![neutral.clone(), neutral],
        negatives: vec![dough],
    };
    let prob = positive_probability(&up.features, 2, &q, 0.05).unwrap();
    let params = SemanticParams {
        eps_m: 0.01,
        ..SemanticParams::default()
    };
    let selected = select(&splats.positions, &prob, &params).unwrap();
    // The Gaussians' own colours (SH DC) through the same rule: the "true" icing.
    let truth: Vec<usize> = (0..n)
        .filter(|&i| {
            let c = cloud.sh_dc[i].map(|v| (0.5 + 0.282_094_8 * v).clamp(0.0, 1.0));
            colour_rule(c)[0] > 0.0 && cloud.opacity(i) > 0.3
        })
        .collect();
    let share_above = |set: &[usize], z: f32| {
        set.iter().filter(|&&i| splats.positions[i][2] > z).count() as f64 / set.len() as f64
    };
    let mid_z = 0.5 * (lo.z + hi.z);
    let (sel_median, sel_mid) = (
        share_above(&selected, median_z),
        share_above(&selected, mid_z),
    );
    let (truth_median, truth_mid) = (share_above(&truth, median_z), share_above(&truth, mid_z));
    println!(
        "donut: {n} Gaussians, {} unseen, {} selected as icing; above the median z: {:.1} % \
         (own-colour icing {:.1} %), above mid-height: {:.1} % (own-colour {:.1} %)",
        up.unseen.len(),
        selected.len(),
        100.0 * sel_median,
        100.0 * truth_median,
        100.0 * sel_mid,
        100.0 * truth_mid
    );
    // Measured: 64.9 % above the median (own colours: 57.5 %: the Gaussians crowd the iced top,
    // so the median sits at 2/3 of the height and the icing runs down the sides below it) and
    // 98.0 % above mid-height (own colours: 96.4 %).
    assert!(
        selected.len() > n / 20,
        "too few selected: {}",
        selected.len()
    );
    assert!(
        sel_mid >= 0.9,
        "only {:.1} % of the icing is above mid-height",
        100.0 * sel_mid
    );
    assert!(
        sel_median >= truth_median,
        "the selection is lower than the Gaussians' own icing colours: {sel_median} < {truth_median}"
    );
}
