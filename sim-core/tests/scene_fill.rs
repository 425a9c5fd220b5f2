//! Interior filling is bounded and fills a closed shell.

use splatphys_core::fill::{FillParams, fill_interior};
use splatphys_core::procedural::isotropic_gaussians;

/// Gaussians on a sphere surface of radius 0.1 m (a captured object's shell), ~2 mm apart.
fn shell() -> splatphys_core::gaussians::GaussianCloud {
    let mut pts = Vec::new();
    let n = 20_000;
    for i in 0..n {
        // Fibonacci sphere.
        let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
        let r = (1.0 - z * z).sqrt();
        let phi = i as f32 * 2.399_963;
        pts.push([0.1 * r * phi.cos(), 0.1 * r * phi.sin(), 0.1 * z]);
    }
    isotropic_gaussians(pts, 0.002, [0.5; 3])
}

#[test]
fn closed_shell_is_filled_inside_only() {
    let p = FillParams {
        spacing_m: 0.01,
        ..FillParams::default()
    };
    let pts = fill_interior(&shell(), &p);
    // Interior cells of a 0.1 m ball at 1 cm: about 4/3 π 0.09³ / 1e-6 ≈ 3000 (the surface
    // band of cells is excluded), so expect 1500..4200.
    println!("filled {} interior particles", pts.len());
    assert!((1500..4200).contains(&pts.len()), "{}", pts.len());
    assert!(
        pts.iter()
            .all(|p| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() < 0.1)
    );
}

#[test]
fn filling_respects_particle_and_grid_bounds() {
    let p = FillParams {
        spacing_m: 0.002,
        max_particles: 500,
        max_grid_cells: 100_000,
        ..FillParams::default()
    };
    let pts = fill_interior(&shell(), &p);
    assert!(pts.len() <= 500);
    assert!(fill_interior(&Default::default(), &p).is_empty());
    assert!(
        fill_interior(
            &shell(),
            &FillParams {
                spacing_m: f32::NAN,
                ..p
            }
        )
        .is_empty()
    );
}
