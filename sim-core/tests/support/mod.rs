//! What several integration tests share: a flat captured surface.

use splatphys_core::gaussians::GaussianCloud;

/// A flat capture: two layers of opaque Gaussians `spacing_m` apart (each `spacing_m` across),
/// `counts` = [nx, ny] of them per layer from the corner `corner_m` = [x, y] (m), the top
/// layer's centres half a spacing below `top_m` (m), so that a level set on cells of the
/// spacing, or of a multiple of it aligned with `top_m`, has its top face at `top_m`; then
/// `extra` Gaussians at the given centres (m), the same size.
pub fn flat_capture(
    corner_m: [f32; 2],
    counts: [usize; 2],
    spacing_m: f32,
    top_m: f32,
    extra: &[[f32; 3]],
) -> GaussianCloud {
    let layers = (0..counts[0]).flat_map(|i| {
        (0..counts[1]).flat_map(move |j| {
            (0..2).map(move |k| {
                [
                    corner_m[0] + (i as f32 + 0.5) * spacing_m,
                    corner_m[1] + (j as f32 + 0.5) * spacing_m,
                    top_m - (k as f32 + 0.5) * spacing_m,
                ]
            })
        })
    });
    let mut cloud = GaussianCloud::with_capacity(0, 0);
    for p in layers.chain(extra.iter().copied()) {
        cloud.positions.push(p);
        cloud.sh_dc.push([0.5; 3]);
        cloud.opacity_logit.push(5.0);
        cloud.log_scales.push([(0.5 * spacing_m).ln(); 3]);
        cloud.rotations_wxyz.push([1.0, 0.0, 0.0, 0.0]);
    }
    cloud
}
