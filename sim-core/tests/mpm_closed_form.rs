//! MLS-MPM against closed-form answers: free fall, the fixed-free bar's period, Coulomb sliding.

use glam::{Mat3A, Vec3A};
use splatphys_core::collider::{BoxShape, Collider, Plane, Shape, Surface};
use splatphys_core::material::Material;
use splatphys_core::mpm::{MpmSystem, Particles};

fn com(p: &Particles) -> Vec3A {
    let m: f32 = p.mass_kg.iter().sum();
    p.x.iter()
        .zip(&p.mass_kg)
        .map(|(x, m)| *x * *m)
        .sum::<Vec3A>()
        / m
}

#[test]
fn free_fall_matches_closed_form() {
    let jelly = Material::jelly(1e5, 0.3, 1000.0).unwrap();
    // Dropped from 3 m so that 0.1 % of the final height (~1.8 mm) is a meaningful bound.
    let p = Particles::lattice_box(
        Vec3A::new(0.0, 0.0, 3.0),
        Vec3A::splat(0.1) + 3.0 * Vec3A::Z,
        0.005,
        1000.0,
        0,
        0,
    );
    let z0 = com(&p).z as f64;
    let mut sys = MpmSystem::new(p, vec![jelly], 0.01);
    sys.advance(0.5).unwrap();
    let g = 9.81f64;
    let exact = z0 - 0.5 * g * 0.25;
    let z = com(&sys.particles).z as f64;
    // Symplectic Euler lags the closed form by g t dt / 2 (~0.9 mm with CFL dt ~3.5e-4 s).
    assert!(
        (z - exact).abs() <= 1e-3 * exact.abs(),
        "z = {z}, closed form {exact}"
    );
    let worst = sys
        .particles
        .f
        .iter()
        .map(|f| {
            (*f - Mat3A::IDENTITY)
                .abs()
                .to_cols_array()
                .into_iter()
                .fold(0.0f32, f32::max)
        })
        .fold(0.0, f32::max);
    eprintln!("free fall: F off the identity by at most {worst:e}");
    assert!(worst <= 1e-5, "F drifted from the identity by {worst}");
}

/// Fixed-free bar, nu = 0 so c = sqrt(E / rho): the fundamental mode's period is 4 L / c.
#[test]
fn fixed_free_bar_period_matches_4l_over_c() {
    let (e, rho, length, dx) = (1e5f32, 1000.0f32, 0.32f32, 0.01f32); // 32 cells along the bar
    let jelly = Material::jelly(e as f64, 0.0, rho as f64).unwrap();
    let mut p = Particles::lattice_box(
        Vec3A::new(0.0, 0.3, 0.3),
        Vec3A::new(length, 0.34, 0.34),
        dx / 2.0,
        rho,
        0,
        0,
    );
    let v0 = 0.05;
    for (x, v) in p.x.iter().zip(p.v.iter_mut()) {
        v.x = v0 * (std::f32::consts::FRAC_PI_2 * x.x / length).sin();
    }
    let tip: Vec<usize> = (0..p.len())
        .filter(|&i| p.x[i].x > length - dx / 2.0)
        .collect();
    let tip_x0: f32 = tip.iter().map(|&i| p.x[i].x).sum::<f32>() / tip.len() as f32;
    let mut sys = MpmSystem::new(p, vec![jelly], dx);
    sys.gravity_m_s2 = Vec3A::ZERO;
    // A clamp: every node at x <= 0 is held, so the bar is clamped at x = 0.
    sys.colliders.push(Collider::fixed(
        Shape::Plane(Plane::new(Vec3A::ZERO, Vec3A::X).unwrap()),
        Surface::Clamp,
        0.0,
    ));
    let c = (e / rho).sqrt();
    let period = 4.0 * length / c;
    let mut crossings = Vec::new();
    let mut last = 0.0f32;
    let mut last_t = 0.0;
    while sys.time_s < 1.6 * period as f64 {
        sys.substep(1e-3).unwrap();
        let u = tip.iter().map(|&i| sys.particles.x[i].x).sum::<f32>() / tip.len() as f32 - tip_x0;
        let t = sys.time_s;
        if last > 0.0 && u <= 0.0 || last < 0.0 && u >= 0.0 {
            crossings.push(last_t + (t - last_t) * (last / (last - u)) as f64);
        }
        last = u;
        last_t = t;
    }
    // Crossings at T/2 and T (displacement starts at 0 going positive).
    assert!(crossings.len() >= 2, "{crossings:?}");
    let measured = crossings[1];
    let err = (measured - period as f64).abs() / period as f64;
    assert!(
        err <= 0.02,
        "period {measured:.5} s vs 4L/c = {period:.5} s ({:.2} %)",
        err * 100.0
    );
}

fn sliding_distance(surface: Surface) -> (f64, f64) {
    let mu = 0.3f32;
    let v0 = 1.0f32;
    let dx = 0.01;
    let jelly = Material::jelly(2e5, 0.3, 1000.0).unwrap();
    let mut p = Particles::lattice_box(
        Vec3A::new(0.0, 0.0, 0.0),
        Vec3A::new(0.1, 0.1, 0.05),
        dx / 2.0,
        1000.0,
        0,
        0,
    );
    // Let it settle on the plane first, then launch it.
    let mut sys = MpmSystem::new(std::mem::take(&mut p), vec![jelly], dx);
    sys.colliders.push(Collider::fixed(
        Shape::Plane(Plane::new(Vec3A::ZERO, Vec3A::Z).unwrap()),
        surface,
        mu,
    ));
    sys.advance(0.1).unwrap();
    for v in &mut sys.particles.v {
        v.x += v0;
    }
    sys.max_speed_m_s = v0;
    let x0 = com(&sys.particles).x as f64;
    let expected = (v0 * v0) as f64 / (2.0 * mu as f64 * 9.81);
    let mut t = 0.0;
    while t < 1.0 {
        sys.advance(0.01).unwrap();
        t += 0.01;
        let vx = sys
            .particles
            .v
            .iter()
            .zip(&sys.particles.mass_kg)
            .map(|(v, m)| v.x * m)
            .sum::<f32>()
            / sys.particles.mass_kg.iter().sum::<f32>();
        if vx.abs() < 1e-3 {
            break;
        }
    }
    (com(&sys.particles).x as f64 - x0, expected)
}

#[test]
fn coulomb_sliding_on_separate_plane_stops_at_v0_squared_over_2_mu_g() {
    let (d, expected) = sliding_distance(Surface::Separate);
    println!("separate: slid {d:.5} m, v0²/(2μg) = {expected:.5} m");
    assert!(
        (d - expected).abs() <= 0.03 * expected,
        "slid {d:.4} m, v0²/(2μg) = {expected:.4} m"
    );
}

/// A slip surface also removes outgoing normal velocity, so the trailing edge of a sliding block
/// is held down and the leading edge pressed harder: per-node Coulomb friction then brakes more
/// than the block's weight alone would. Charging friction only for approaching velocity (see
/// `collider::surface`) keeps the excess near 10 % (a naive rule measured 36 %); this test pins it.
#[test]
fn slip_plane_friction_overbrakes_by_at_most_15_percent() {
    let (d, expected) = sliding_distance(Surface::Slip);
    println!("slip: slid {d:.5} m, v0²/(2μg) = {expected:.5} m");
    assert!(
        d <= expected * 1.01 && d >= 0.85 * expected,
        "slid {d:.4} m, v0²/(2μg) = {expected:.4} m"
    );
}

#[test]
fn sticky_box_holds_what_touches_it() {
    let jelly = Material::jelly(1e5, 0.3, 1000.0).unwrap();
    let p = Particles::lattice_box(
        Vec3A::new(0.0, 0.0, 0.1),
        Vec3A::new(0.05, 0.05, 0.15),
        0.005,
        1000.0,
        0,
        0,
    );
    let mut sys = MpmSystem::new(p, vec![jelly], 0.01);
    let table = BoxShape::new(Vec3A::new(-1.0, -1.0, -0.5), Vec3A::new(1.0, 1.0, 0.0)).unwrap();
    sys.colliders
        .push(Collider::fixed(Shape::Box(table), Surface::Sticky, 0.0));
    let mut deepest = f32::INFINITY;
    for _ in 0..150 {
        sys.advance(0.01).unwrap();
        deepest = deepest.min(
            sys.particles
                .x
                .iter()
                .map(|x| x.z)
                .fold(f32::INFINITY, f32::min),
        );
    }
    // It fell 0.1 m onto the table top, never sank more than one cell into it, and stays on it
    // (lowest layer within the 1.5-cell stencil reach plus a cell; an undamped jelly keeps
    // wobbling, so its speed is not asserted).
    let lowest = sys
        .particles
        .x
        .iter()
        .map(|x| x.z)
        .fold(f32::INFINITY, f32::min);
    assert!(deepest > -0.01, "sank to z = {deepest}");
    assert!(lowest < 0.03, "lowest particle at z = {lowest}");
}
