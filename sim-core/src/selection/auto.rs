//! Automatic object selection (`auto = k`): find the dominant support plane with RANSAC
//! (Fischler & Bolles 1981) and split what stands on it into objects by Euclidean clustering on
//! a kd-tree (PCL-style, see [`super::cluster`]); object `k` is the k-th largest cluster.
//!
//! The plane's normal is oriented towards the side holding more off-plane points (objects stand
//! on top of a support). Only points more than `plane_tolerance_m` above the plane are clustered.
//! When no plane holds at least `min_plane_fraction` of the points, everything is clustered.
//! The plane is then raised to the top of its inlier band (a support is a slab of Gaussians),
//! and clusters thinner than the tolerance along the normal (leftover support layers) are dropped.

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::cluster::euclidean_clusters;

/// Parameters of [`detect_objects`]. Distances in the points' units (m in a scene).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AutoParams {
    /// RANSAC hypotheses tried. Default 400.
    pub ransac_iterations: usize,
    /// Points closer than this to the plane are plane inliers, m. Default 0.005.
    pub plane_tolerance_m: f32,
    /// Smallest inlier fraction for the plane to count as a support. Default 0.05.
    pub min_plane_fraction: f32,
    /// Euclidean clustering link distance, m. Default 0.01.
    pub cluster_eps_m: f32,
    /// Clusters smaller than this are ignored. Default 50.
    pub min_cluster: usize,
    /// RANSAC random seed. Default 0.
    pub seed: u64,
}

impl Default for AutoParams {
    fn default() -> Self {
        Self {
            ransac_iterations: 400,
            plane_tolerance_m: 0.005,
            min_plane_fraction: 0.05,
            cluster_eps_m: 0.01,
            min_cluster: 50,
            seed: 0,
        }
    }
}

/// A plane `normal · p = offset_m` with its inliers.
#[derive(Debug, Clone, PartialEq)]
pub struct PlaneFit {
    /// Unit normal, pointing to the side objects stand on.
    pub normal: [f32; 3],
    /// Signed offset along the normal, m.
    pub offset_m: f32,
    /// Indices of the points within the tolerance, ascending.
    pub inliers: Vec<usize>,
}

impl PlaneFit {
    /// Signed distance of `p` above the plane, m.
    pub fn height(&self, p: [f32; 3]) -> f32 {
        Vec3::from(self.normal).dot(Vec3::from(p)) - self.offset_m
    }
}

/// What [`detect_objects`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct AutoResult {
    /// The support plane, if one was found.
    pub plane: Option<PlaneFit>,
    /// Objects standing on it: index lists into the input points, largest first.
    pub objects: Vec<Vec<usize>>,
}

/// Best plane by inlier count over `iterations` random 3-point hypotheses; `None` for fewer than
/// 3 points or only degenerate samples.
pub fn ransac_plane(
    points: &[[f32; 3]],
    iterations: usize,
    tolerance_m: f32,
    seed: u64,
) -> Option<PlaneFit> {
    let n = points.len();
    if n < 3 {
        return None;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut best: Option<(usize, Vec3, f32)> = None;
    for _ in 0..iterations {
        let a = Vec3::from(points[rng.random_range(0..n)]);
        let b = Vec3::from(points[rng.random_range(0..n)]);
        let c = Vec3::from(points[rng.random_range(0..n)]);
        let nrm = (b - a).cross(c - a);
        if nrm.length_squared() < 1e-20 {
            continue;
        }
        let nrm = nrm.normalize();
        let d = nrm.dot(a);
        let count = points
            .iter()
            .filter(|p| (nrm.dot(Vec3::from(**p)) - d).abs() <= tolerance_m)
            .count();
        if best.as_ref().is_none_or(|(bc, _, _)| count > *bc) {
            best = Some((count, nrm, d));
        }
    }
    let (_, mut nrm, mut d) = best?;
    // Orient towards the side with more off-plane points.
    let (mut above, mut below) = (0usize, 0usize);
    for p in points {
        let h = nrm.dot(Vec3::from(*p)) - d;
        if h > tolerance_m {
            above += 1;
        } else if h < -tolerance_m {
            below += 1;
        }
    }
    if below > above {
        nrm = -nrm;
        d = -d;
    }
    let inliers = (0..n)
        .filter(|&i| (nrm.dot(Vec3::from(points[i])) - d).abs() <= tolerance_m)
        .collect();
    Some(PlaneFit {
        normal: nrm.to_array(),
        offset_m: d,
        inliers,
    })
}

/// Support plane and the objects standing on it (see the module docs).
pub fn detect_objects(points: &[[f32; 3]], params: &AutoParams) -> AutoResult {
    let mut plane = ransac_plane(
        points,
        params.ransac_iterations,
        params.plane_tolerance_m,
        params.seed,
    )
    .filter(|p| p.inliers.len() as f32 >= params.min_plane_fraction * points.len() as f32);
    // A captured or sampled support is a slab, not a plane: move the plane to the top of its
    // inlier band (98th percentile height) so the slab's upper layer is not mistaken for an object.
    if let Some(pl) = plane.as_mut() {
        let mut h: Vec<f32> = pl.inliers.iter().map(|&i| pl.height(points[i])).collect();
        h.sort_unstable_by(f32::total_cmp);
        if let Some(&top) = h.get((h.len().saturating_sub(1) as f32 * 0.98) as usize) {
            pl.offset_m += top.max(0.0);
        }
    }
    let candidates: Vec<usize> = match &plane {
        Some(pl) => (0..points.len())
            .filter(|&i| pl.height(points[i]) > params.plane_tolerance_m)
            .collect(),
        None => (0..points.len()).collect(),
    };
    let sub: Vec<[f32; 3]> = candidates.iter().map(|&i| points[i]).collect();
    let objects = euclidean_clusters(&sub, params.cluster_eps_m, params.min_cluster)
        .into_iter()
        .map(|c| c.into_iter().map(|j| candidates[j]).collect::<Vec<usize>>())
        .filter(|c| match &plane {
            Some(pl) => {
                let (lo, hi) = c
                    .iter()
                    .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &i| {
                        let h = pl.height(points[i]);
                        (lo.min(h), hi.max(h))
                    });
                hi - lo > params.plane_tolerance_m
            }
            None => true,
        })
        .collect();
    AutoResult { plane, objects }
}
