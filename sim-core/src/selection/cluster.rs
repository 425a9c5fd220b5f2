//! Density clustering on a kd-tree (kiddo's `ImmutableKdTree`): DBSCAN (Ester et al. 1996) and
//! Euclidean clustering (PCL's `EuclideanClusterExtraction`, which is DBSCAN with min_samples = 1).
//! Deterministic: points are visited in index order and cluster ids follow first visits.

use kiddo::SquaredEuclidean;
use kiddo::immutable::float::kdtree::ImmutableKdTree;

/// A kd-tree over `[N][3]` points whose items are point indices.
pub type Tree = ImmutableKdTree<f32, u32, 3, 32>;

/// Builds the tree for `points`.
pub fn build_tree(points: &[[f32; 3]]) -> Tree {
    ImmutableKdTree::new_from_slice(points)
}

/// Label of a point DBSCAN finds no dense neighbourhood for.
pub const NOISE: i32 = -1;

/// DBSCAN labels `[N]`: cluster ids 0.. (in order of first core point) or [`NOISE`].
/// A point is core when at least `min_samples` points (itself included) lie within `eps_m`.
pub fn dbscan(points: &[[f32; 3]], eps_m: f32, min_samples: usize) -> Vec<i32> {
    let n = points.len();
    let mut labels = vec![NOISE; n];
    if n == 0 {
        return labels;
    }
    let tree = build_tree(points);
    let eps2 = eps_m * eps_m;
    let neighbours = |i: usize| -> Vec<usize> {
        let mut v: Vec<usize> = tree
            .within_unsorted::<SquaredEuclidean>(&points[i], eps2)
            .into_iter()
            .map(|nb| nb.item as usize)
            .collect();
        v.sort_unstable();
        v
    };
    let mut visited = vec![false; n];
    let mut next = 0i32;
    let mut stack = Vec::new();
    for i in 0..n {
        if visited[i] {
            continue;
        }
        visited[i] = true;
        let nb = neighbours(i);
        if nb.len() < min_samples.max(1) {
            continue;
        }
        let id = next;
        next += 1;
        labels[i] = id;
        stack.clear();
        stack.extend(nb);
        while let Some(j) = stack.pop() {
            if labels[j] == NOISE {
                labels[j] = id;
            }
            if visited[j] {
                continue;
            }
            visited[j] = true;
            let nbj = neighbours(j);
            if nbj.len() >= min_samples.max(1) {
                stack.extend(
                    nbj.into_iter()
                        .filter(|&k| !visited[k] || labels[k] == NOISE),
                );
            }
        }
    }
    labels
}

/// Euclidean clusters of `points` linked at distance `eps_m`, largest first (ties by lowest
/// index), each with at least `min_size` points; every list ascending.
pub fn euclidean_clusters(points: &[[f32; 3]], eps_m: f32, min_size: usize) -> Vec<Vec<usize>> {
    clusters_from_labels(&dbscan(points, eps_m, 1), min_size)
}

/// Groups labels into index lists, largest first, dropping noise and groups below `min_size`.
pub fn clusters_from_labels(labels: &[i32], min_size: usize) -> Vec<Vec<usize>> {
    let count = labels
        .iter()
        .copied()
        .max()
        .map_or(0, |m| (m + 1).max(0) as usize);
    let mut groups = vec![Vec::new(); count];
    for (i, &l) in labels.iter().enumerate() {
        if l >= 0 {
            groups[l as usize].push(i);
        }
    }
    groups.retain(|g| g.len() >= min_size.max(1));
    groups.sort_by(|a, b| b.len().cmp(&a.len()).then(a[0].cmp(&b[0])));
    groups
}
