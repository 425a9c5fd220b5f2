//! Particle volumes (`world::carry::volume`): an object's total particle volume is the volume of
//! the solid its particles fill, whatever the grid's dx: closed-form volumes for procedural
//! shapes, the same total for a captured donut at dx and 2 dx, the enclosed volume for a closed
//! shell, equal shares inside a lattice, and the same bits for any thread count.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use glam::Vec3A;
use splatphys_core::procedural::{Shape, fill_points};
use splatphys_core::scene::load_scene_str;
use splatphys_core::world::carry::particle_volumes;
use splatphys_core::world::carry::volume::{cell_volumes, local_spacing, solid_volume};

fn points(shape: &Shape, spacing_m: f32) -> Vec<Vec3A> {
    fill_points(shape, spacing_m, 7)
        .expect("shape")
        .into_iter()
        .map(Vec3A::from)
        .collect()
}

fn total(v: &[f32]) -> f64 {
    v.iter().map(|v| *v as f64).sum()
}

fn sphere(r: f32) -> Shape {
    Shape::Sphere {
        center_m: [0.013, -0.021, 0.3],
        radius_m: r,
    }
}

/// A box of 10 × 7 × 5 lattice spacings `h` (sides that are not multiples of h would be sampled
/// as the larger box of whole lattice rows).
fn cuboid(h: f32) -> Shape {
    let min_m = [0.0, 0.0, 0.1];
    Shape::Box {
        min_m,
        max_m: [10.0 * h, 7.0 * h, 0.1 + 5.0 * h],
    }
}

/// A cylinder of radius 4 cm and height 10 cm on a tilted axis.
fn cylinder() -> Shape {
    Shape::Cylinder {
        base_m: [0.0, 0.0, 0.1],
        axis: [0.3, 0.2, 1.0],
        radius_m: 0.04,
        height_m: 0.1,
    }
}

fn closed_form(shape: &Shape) -> f64 {
    match *shape {
        Shape::Sphere { radius_m, .. } => 4.0 / 3.0 * PI * (radius_m as f64).powi(3),
        Shape::Box { min_m, max_m } => (0..3).map(|k| (max_m[k] - min_m[k]) as f64).product(),
        Shape::Cylinder {
            radius_m, height_m, ..
        } => PI * (radius_m as f64).powi(2) * height_m as f64,
    }
}

/// Relative error of the total particle volume of `shape` filled at spacing `h`, grid `dx`.
fn error(shape: &Shape, h: f32, dx: f32) -> f64 {
    total(&particle_volumes(&points(shape, h), dx)) / closed_form(shape) - 1.0
}

#[test]
#[ignore = "prints the accuracy table of the module docs"]
fn report_volume_errors() {
    let r = 0.05f32;
    println!("shape     h/r     N      N h³ err   estimate err");
    for h in [r / 2.0, r / 4.0, r / 5.0, r / 8.0, r / 10.0] {
        for (name, s) in [
            ("sphere", sphere(r)),
            ("box", cuboid(h)),
            ("cylinder", cylinder()),
        ] {
            let x = points(&s, h);
            let lattice = x.len() as f64 * (h as f64).powi(3) / closed_form(&s) - 1.0;
            println!(
                "{name:9} {:.3}  {:6} {:+7.2} %  {:+7.2} %",
                h / r,
                x.len(),
                100.0 * lattice,
                100.0 * error(&s, h, r / 4.0)
            );
        }
    }
}

#[test]
fn procedural_sphere_weighs_its_closed_form_volume() {
    // Radius r = 5 cm, grid dx = r/4, lattice h = dx/2 (8 particles per cell). The lattice's own
    // N h³ is 0.54 % under 4/3 π r³ here and the estimate 0.10 % over (module docs' table); 2 %
    // (the bound) leaves room for another jitter seed.
    let r = 0.05f32;
    let (dx, h) = (r / 4.0, r / 8.0);
    let e = error(&sphere(r), h, dx);
    assert!(e.abs() <= 0.02, "sphere: {:+.2} %", 100.0 * e);
    // The grid's dx does not enter: r/2 and r/8 give the same bits.
    let x = points(&sphere(r), h);
    let v = particle_volumes(&x, dx);
    assert_eq!(v, particle_volumes(&x, r / 2.0));
    assert_eq!(v, particle_volumes(&x, r / 8.0));
}

#[test]
fn procedural_box_and_cylinder_weigh_their_closed_form_volumes() {
    // As the sphere (h = r/8 of a 5 cm sphere): the box 10 × 7 × 5 h is sampled exactly
    // (N h³ = its volume; estimate +0.28 %), the cylinder's N h³ is 0.20 % over (estimate
    // +0.91 %); 2 % as for the sphere.
    let h = 0.05f32 / 8.0;
    for (name, s) in [("box", cuboid(h)), ("cylinder", cylinder())] {
        let e = error(&s, h, 2.0 * h);
        assert!(e.abs() <= 0.02, "{name}: {:+.2} %", 100.0 * e);
    }
}

#[test]
fn default_spacing_sphere_is_within_two_and_a_half_percent() {
    // The scenes' default lattice (1 cm) in a 5 cm sphere: 5 spacings across the radius, 527
    // particles, two thirds of them at the surface. N h³ is 0.65 % over, the estimate 1.87 %;
    // 2.5 % is the bound the module docs give for 5 spacings.
    let e = error(&sphere(0.05), 0.01, 0.01);
    assert!(e.abs() <= 0.025, "{:+.2} %", 100.0 * e);
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The donut of scenes/donut_drop.toml (min_opacity 0.1, voxel_m 0.004) with interior fill of
/// spacing `fill_m` and grid `dx_m`: its particles' volumes (m³), one per Gaussian in scene order.
fn donut(fill_m: Option<f32>, dx_m: f32) -> Vec<f32> {
    let base = repo().join("scenes");
    let mut text = std::fs::read_to_string(base.join("donut_drop.toml")).expect("scene");
    text = text.replace("grid_dx_m = 0.005", &format!("grid_dx_m = {dx_m}"));
    if let Some(f) = fill_m {
        text = text.replace(
            "friction = 0.3\n\n[[collider]]",
            &format!("friction = 0.3\nfill = {{ spacing_m = {f} }}\n\n[[collider]]"),
        );
        assert!(
            text.contains("fill = "),
            "donut_drop.toml changed: no place for `fill`"
        );
    }
    let scene = load_scene_str(&text, &base).expect("donut scene");
    assert_eq!(scene.simulation.grid_dx_m as f32, dx_m);
    let world = splatphys_core::world::World::from_scene(&scene).expect("world");
    // In the scene's Gaussian order: particles are stored in block order, which depends on dx.
    let b = &world.bodies()[0];
    b.gaussian_particle()
        .iter()
        .map(|&j| b.particles().volume0_m3[j as usize])
        .collect()
}

#[test]
fn captured_donut_has_one_volume_at_dx_and_twice_dx() {
    if !repo().join("../shared/data/v3dg_donut.ply").exists() {
        println!("skipping the donut: ../shared/data not found");
        return;
    }
    // The same particles at dx and 2 dx: the grid does not enter at all (the 2 % bound on a
    // captured object's mass at dx and 2 dx holds exactly).
    let fine = donut(Some(0.005), 0.005);
    let same = donut(Some(0.005), 0.01);
    assert_eq!(fine, same);
    // Fill at the grid's spacing, as a user coarsening the scene would set it: different fill
    // particles (the 5 mm fill seals gaps of the surface that the 10 mm one does not see), and a
    // different grid. The capture fixes its surface only to its sampling (median spacing
    // 4.2 mm): fills at other spacings put their outer particles up to about a quarter of that
    // elsewhere over the donut's ~0.1 m² of surface, 0.1 L or 5 % of its volume.
    let coarse = donut(Some(0.01), 0.01);
    let (a, b) = (total(&fine), total(&coarse));
    println!(
        "donut: {:.4} L at dx 5 mm, {:.4} L at dx 10 mm",
        a * 1e3,
        b * 1e3
    );
    assert!((a - b).abs() <= 0.05 * a, "{a} vs {b} m³");
    // Without fill the surface-only capture encloses the same solid, within the same 5 %.
    let shell = donut(None, 0.005);
    let c = total(&shell);
    println!("donut without fill: {:.4} L", c * 1e3);
    assert!((a - c).abs() <= 0.05 * a, "{a} vs {c} m³ without fill");
}

/// `n` points on a sphere of radius `r_m` (Fibonacci lattice), keeping those with z < `z_max`.
fn fibonacci_shell(n: usize, r_m: f32, z_max: f32) -> Vec<Vec3A> {
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let rho = (1.0 - z * z).sqrt();
            let phi = i as f32 * 2.399_963;
            Vec3A::new(rho * phi.cos(), rho * phi.sin(), z) * r_m
        })
        .filter(|p| p.z < z_max)
        .collect()
}

#[test]
#[ignore = "prints shell volumes and timings"]
fn report_shells_and_timing() {
    let r = 0.1f32;
    for n in [5_000usize, 20_000, 80_000] {
        let x = fibonacci_shell(n, r, 1.0);
        let s = local_spacing(&x).unwrap();
        let t = std::time::Instant::now();
        let v = total(&particle_volumes(&x, 0.01));
        let med = {
            let mut m = s.clone();
            m.sort_by(f64::total_cmp);
            m[m.len() / 2]
        };
        let enclosed = 4.0 / 3.0 * PI * (r as f64).powi(3);
        let skin = (v - enclosed) / (4.0 * PI * (r as f64).powi(2));
        println!(
            "closed shell n {n}: spacing {:.2} mm, volume/enclosed {:.4}, skin {:.2} mm = {:.2} spacings ({:?})",
            med * 1e3,
            v / enclosed,
            skin * 1e3,
            skin / med,
            t.elapsed()
        );
        let bowl = fibonacci_shell(n, r, 0.0);
        let vb = total(&particle_volumes(&bowl, 0.01));
        let area = 2.0 * PI * (r as f64).powi(2);
        println!(
            "  open bowl: volume / (area × spacing) {:.2}, volume / hemisphere {:.3}",
            vb / (area * med),
            vb / (enclosed / 2.0)
        );
    }
    // Uniform random points in a ball of radius 5 cm, 8000 per litre (a 5 mm lattice's density).
    let mut state = 7u64;
    let mut unit = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut random = Vec::new();
    let r = 0.05f64;
    let n = (4.0 / 3.0 * PI * r.powi(3) / 0.005f64.powi(3)).round() as usize;
    while random.len() < n {
        let p = [unit(), unit(), unit()].map(|u| (2.0 * u - 1.0) * r);
        if p.iter().map(|c| c * c).sum::<f64>() <= r * r {
            random.push(Vec3A::new(p[0] as f32, p[1] as f32, p[2] as f32));
        }
    }
    let v = total(&particle_volumes(&random, 0.01));
    println!(
        "random ball: {n} points, volume / closed form {:.3}",
        v / (4.0 / 3.0 * PI * r.powi(3))
    );
    for h in [0.005f32, 0.0025] {
        let x = points(&sphere(0.05), h);
        let t = std::time::Instant::now();
        let s = local_spacing(&x).unwrap();
        let t1 = t.elapsed();
        let sv = solid_volume(&x, &s).unwrap();
        println!(
            "sphere h {h}: {} particles, spacing {:?}, solid {:?} (voxel {:.2} mm)",
            x.len(),
            t1,
            t.elapsed() - t1,
            sv.voxel_m * 1e3
        );
    }
}

/// Median of `local_spacing` (m).
fn median_spacing(x: &[Vec3A]) -> f64 {
    let mut s = local_spacing(x).expect("spacing");
    s.sort_by(f64::total_cmp);
    s[s.len() / 2]
}

#[test]
fn closed_shell_gets_what_it_encloses_and_an_open_one_its_skin() {
    // A surface-only "capture" of a 10 cm ball, 20 000 points about 2.8 mm apart.
    let r = 0.1f64;
    let shell = fibonacci_shell(20_000, r as f32, 1.0);
    let s = median_spacing(&shell);
    let v = total(&particle_volumes(&shell, 0.01));
    let enclosed = 4.0 / 3.0 * PI * r.powi(3);
    // The enclosed ball plus a skin of at most one spacing: (1 + s/r)³ ≈ 1.08 (measured 1.03).
    assert!(
        v >= enclosed && v <= enclosed * (1.0 + s / r).powi(3),
        "closed shell: {:.4} of the enclosed volume (spacing {:.2} mm)",
        v / enclosed,
        s * 1e3
    );
    // The lower half alone is a bowl: nothing is enclosed, it keeps its skin, about area ×
    // spacing (measured 0.96 of it); half to twice that.
    let bowl = fibonacci_shell(20_000, r as f32, 0.0);
    let vb = total(&particle_volumes(&bowl, 0.01));
    let skin = 2.0 * PI * r * r * s;
    assert!(
        (0.5..=2.0).contains(&(vb / skin)),
        "bowl: {:.2} of area × spacing",
        vb / skin
    );
}

#[test]
fn interior_of_a_regular_lattice_gets_equal_volumes() {
    // A 12³ block of a 5 mm cubic lattice, no jitter. Particles two layers or more inside see
    // only interior neighbours: equal spacings, so equal volumes, up to the rounding of f32
    // positions near 0.3 m in the distances (~1e-7 relative; 1e-5 allowed).
    let h = 0.005f32;
    let n = 12usize;
    let mut x = Vec::new();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                x.push(Vec3A::new(0.1, -0.2, 0.3) + Vec3A::new(i as f32, j as f32, k as f32) * h);
            }
        }
    }
    let v = particle_volumes(&x, 0.01);
    let inner: Vec<f32> = (0..x.len())
        .filter(|&p| {
            let c = [p % n, (p / n) % n, p / (n * n)];
            c.iter().all(|&c| (2..n - 2).contains(&c))
        })
        .map(|p| v[p])
        .collect();
    let (lo, hi) = inner
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), v| (a.min(*v), b.max(*v)));
    assert!(hi - lo <= 1e-5 * hi, "interior volumes {lo} to {hi}");
    // The block's volume is (12 h)³ (measured: +0.03 %); 1 %, the bound for lattices of this
    // size in the module docs.
    let block = (n as f64 * h as f64).powi(3);
    println!("regular block: {:.5} of (12 h)³", total(&v) / block);
    assert!(
        (total(&v) / block - 1.0).abs() <= 0.01,
        "{}",
        total(&v) / block
    );
}

fn volume_bits(threads: usize, clouds: &[Vec<Vec3A>]) -> Vec<Vec<u32>> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        clouds
            .iter()
            .map(|x| {
                particle_volumes(x, 0.01)
                    .iter()
                    .map(|v| v.to_bits())
                    .collect()
            })
            .collect()
    })
}

#[test]
fn volumes_are_bit_identical_for_1_and_2_threads() {
    // A jittered solid and a shell (the enclosed-space path).
    let clouds = [
        points(&sphere(0.05), 0.005),
        fibonacci_shell(5_000, 0.1, 1.0),
    ];
    assert_eq!(volume_bits(1, &clouds), volume_bits(2, &clouds));
}

#[test]
fn tiny_or_coincident_objects_keep_the_occupied_cell_rule() {
    let few = vec![
        Vec3A::ZERO,
        Vec3A::new(0.001, 0.0, 0.0),
        Vec3A::new(0.5, 0.0, 0.0),
    ];
    assert_eq!(particle_volumes(&few, 0.01), cell_volumes(&few, 0.01));
    let same = vec![Vec3A::new(0.1, 0.2, 0.3); 20];
    assert_eq!(particle_volumes(&same, 0.01), cell_volumes(&same, 0.01));
    // The cell rule: one 1 cm cell shared by 20 particles.
    assert_eq!(total(&particle_volumes(&same, 0.01)) as f32, 1e-6);
    // A stray particle 100 m away: voxels fine enough for the ball would not fit in the grid,
    // so the cell rule again, not a measurement on voxels wider than the spacing.
    let mut stray = points(&sphere(0.05), 0.01);
    stray.push(Vec3A::new(100.0, 0.0, 0.0));
    assert_eq!(particle_volumes(&stray, 0.01), cell_volumes(&stray, 0.01));
}
