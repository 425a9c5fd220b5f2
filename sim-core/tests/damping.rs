//! Kelvin–Voigt damping (`damping_viscosity_pa_s`) against closed forms: the energy a uniform
//! expansion loses, no loss for a rigid spin, and the decay of a bar's fundamental mode.

use glam::{Mat3A, Vec3A};
use splatphys_core::collider::{Collider, Plane, Shape, Surface};
use splatphys_core::material::{ConstitutiveModel, Material, MaterialSpec};
use splatphys_core::mpm::{MpmSystem, Particles, TimeStepPolicy};

/// Jelly with E (Pa), nu, 1000 kg/m³ and damping viscosity `eta` (Pa·s).
fn jelly(e: f64, nu: f64, eta: f64) -> Material {
    Material::from_spec(&MaterialSpec {
        damping_viscosity_pa_s: Some(eta),
        ..MaterialSpec::jelly(e, nu, 1000.0)
    })
    .expect("valid jelly")
}

/// A 10 cm cube of particles 5 mm apart on a 1 cm grid, no gravity, centred on `c`, moving with
/// the affine velocity field v = `l` (x − c) (and C = `l`, what APIC carries for it), stepped
/// at a fixed `dt_s`.
fn cube(material: Material, c: Vec3A, l: Mat3A, dt_s: f32) -> MpmSystem {
    let half = Vec3A::splat(0.05);
    let mut p = Particles::lattice_box(c - half, c + half, 0.005, 1000.0, 0, 0);
    for i in 0..p.len() {
        p.v[i] = l * (p.x[i] - c);
        p.c[i] = l;
    }
    let mut sys = MpmSystem::new(p, vec![material], 0.01);
    sys.gravity_m_s2 = Vec3A::ZERO;
    sys.policy = TimeStepPolicy::Fixed { dt_s, force: false };
    sys
}

/// Kinetic energy with APIC's affine part (J): Σ ½ m (|v|² + (dx²/4) |C|²), what the grid
/// carries (Jiang et al. 2015, the quadratic B-spline's inertia D = dx²/4 I).
fn apic_kinetic_j(sys: &MpmSystem) -> f64 {
    let d = sys.diagnostics();
    d.kinetic_j + d.affine_kinetic_j
}

/// A uniform expansion v = a (x − c) has D = a I, so Kelvin–Voigt damping dissipates
/// 2 η D:D = 6 η a² per unit volume. APIC carries an affine field exactly, with kinetic energy
/// ½ ρ a² V (⟨|r|²⟩ + 3 dx²/4) (particles plus their affine part), so while the field stays
/// affine that energy decays as exp(−k t), k = 12 η / (ρ (⟨|r|²⟩ + 3 dx²/4)). E = 1 Pa keeps
/// the elastic energy under 1e-4 of the kinetic over the window.
#[test]
fn a_uniform_expansion_loses_the_energy_kelvin_voigt_dissipates() {
    let (eta, a, t) = (1.0f64, 1.0f32, 0.01f64);
    let c = Vec3A::new(0.3, 0.3, 0.3);
    let l = Mat3A::from_diagonal(glam::Vec3::splat(a));
    let run = |eta: f64| {
        let mut sys = cube(jelly(1.0, 0.3, eta), c, l, 1e-4);
        let e0 = apic_kinetic_j(&sys);
        sys.advance(t).expect("steps");
        apic_kinetic_j(&sys) / e0
    };
    let (damped, undamped) = (run(eta), run(0.0));
    let sys = cube(jelly(1.0, 0.3, eta), c, l, 1e-4);
    let p = &sys.particles;
    let r2 =
        p.x.iter()
            .map(|x| (*x - c).length_squared() as f64)
            .sum::<f64>()
            / p.len() as f64;
    let k = 12.0 * eta / (1000.0 * (r2 + 0.75 * 0.01f64.powi(2)));
    let expected = (-k * t).exp();
    println!(
        "kinetic energy after {t} s: damped {damped:.5}, undamped {undamped:.6}, closed form {expected:.5}"
    );
    // The free faces feel the viscous traction, so the field does not stay affine exactly:
    // 3 % of the loss (1 − e^{−kt} = 4.6 %).
    assert!(
        ((1.0 - damped) / (1.0 - expected) - 1.0).abs() < 0.03,
        "lost {} of the energy, closed form {}",
        1.0 - damped,
        1.0 - expected
    );
    assert!((1.0 - undamped).abs() < 1e-3, "undamped {undamped}");
}

/// A rigid spin has D = 0: damping leaves it alone. A stiff jelly (E = 1e6 Pa) keeps the
/// centrifugal stretch, the only deformation, near 1e-5, so the energy it could dissipate is
/// 1e-5 of the spin's; both runs take the same substeps.
#[test]
fn damping_does_not_brake_a_rigid_spin() {
    let c = Vec3A::new(0.3, 0.3, 0.3);
    // ω = (0, 0, 2) rad/s: v = ω × r = (−2 y, 2 x, 0), C = skew(ω).
    let spin = Mat3A::from_cols(
        Vec3A::new(0.0, 2.0, 0.0),
        Vec3A::new(-2.0, 0.0, 0.0),
        Vec3A::ZERO,
    );
    let run = |eta: f64| {
        let mut sys = cube(jelly(1e6, 0.3, eta), c, spin, 5e-5);
        sys.advance(0.05).expect("steps");
        sys.diagnostics().kinetic_j
    };
    let (damped, undamped) = (run(50.0), run(0.0));
    println!("spin kinetic energy after 0.05 s: damped {damped:e} J, undamped {undamped:e} J");
    assert!(
        (damped / undamped - 1.0).abs() < 1e-4,
        "{damped} vs {undamped}"
    );
}

/// The damping's explicit limit is part of the time-step bound: a fixed substep that an
/// undamped jelly takes is refused once 6 η / (ρ dx) makes the bound smaller than it.
#[test]
fn a_substep_above_the_damping_limit_is_refused() {
    let c = Vec3A::new(0.3, 0.3, 0.3);
    let still = Mat3A::ZERO;
    let mut undamped = cube(jelly(1e5, 0.3, 0.0), c, still, 1e-4);
    assert!(undamped.substep(1.0).is_ok());
    // 1000 Pa·s on a 1 cm grid: a speed of 600 m/s, a bound of 1.7e-5 s.
    let mut damped = cube(jelly(1e5, 0.3, 1000.0), c, still, 1e-4);
    let c_p = damped.materials[0].elastic().dilational_wave_speed_m_s();
    assert!((damped.max_wave_speed_m_s() - (c_p + 600.0)).abs() < 1e-3);
    assert!(damped.substep(1.0).is_err());
}

/// Fixed-free bar, nu = 0, E = 1e5 Pa: with damping the axial stress is E ε + 2 η ε̇, so the
/// fundamental mode (k = π / 2L) decays as exp(−η k² t / ρ) on top of whatever MPM itself
/// dissipates. The decay rate is measured from the tip's successive velocity peaks, with and
/// without damping.
#[test]
fn a_damped_bar_decays_at_the_kelvin_voigt_rate() {
    let (e, rho, length, dx, eta) = (1e5f32, 1000.0f32, 0.32f32, 0.01f32, 40.0f64);
    let decay_rate = |eta: f64| {
        let mut p = Particles::lattice_box(
            Vec3A::new(0.0, 0.3, 0.3),
            Vec3A::new(length, 0.34, 0.34),
            dx / 2.0,
            rho,
            0,
            0,
        );
        for (x, v) in p.x.iter().zip(p.v.iter_mut()) {
            v.x = 0.05 * (std::f32::consts::FRAC_PI_2 * x.x / length).sin();
        }
        let tip: Vec<usize> = (0..p.len())
            .filter(|&i| p.x[i].x > length - dx / 2.0)
            .collect();
        let mut sys = MpmSystem::new(p, vec![jelly(e as f64, 0.0, eta)], dx);
        sys.gravity_m_s2 = Vec3A::ZERO;
        // The same substeps with and without damping, below both bounds (C dx / (c + 6 η /
        // (ρ dx)) = 2.9e-4 s damped), so that MPM's own dissipation is the same in both.
        sys.policy = TimeStepPolicy::Fixed {
            dt_s: 1e-4,
            force: false,
        };
        // A clamp: every node at x <= 0 is held, so the bar is clamped at x = 0.
        sys.colliders.push(Collider::fixed(
            Shape::Plane(Plane::new(Vec3A::ZERO, Vec3A::X).expect("plane")),
            Surface::Clamp,
            0.0,
        ));
        // The tip's mean axial speed every 1 ms over 0.5 s (about 4 periods of 4 L / c).
        let speeds: Vec<f64> = (0..500)
            .map(|_| {
                sys.advance(1e-3).expect("steps");
                tip.iter()
                    .map(|&i| sys.particles.v[i].x as f64)
                    .sum::<f64>()
                    / tip.len() as f64
            })
            .collect();
        // Peaks of |v|: the local maxima, one per half period.
        let peaks: Vec<(f64, f64)> = (1..speeds.len() - 1)
            .filter(|&i| {
                let s = speeds[i].abs();
                s > speeds[i - 1].abs() && s >= speeds[i + 1].abs() && s > 1e-3
            })
            .map(|i| (i as f64 * 1e-3, speeds[i].abs().ln()))
            .collect();
        assert!(peaks.len() >= 4, "{} peaks", peaks.len());
        // Least-squares slope of ln |v| at the peaks: −rate.
        let n = peaks.len() as f64;
        let (mt, ml) = (
            peaks.iter().map(|p| p.0).sum::<f64>() / n,
            peaks.iter().map(|p| p.1).sum::<f64>() / n,
        );
        let cov: f64 = peaks.iter().map(|p| (p.0 - mt) * (p.1 - ml)).sum();
        let var: f64 = peaks.iter().map(|p| (p.0 - mt).powi(2)).sum();
        -cov / var
    };
    let (damped, undamped) = (decay_rate(eta), decay_rate(0.0));
    let k = std::f64::consts::FRAC_PI_2 / length as f64;
    let expected = eta * k * k / rho as f64;
    println!(
        "bar decay rate: damped {damped:.3}/s, undamped {undamped:.3}/s, difference {:.3}/s, closed form {expected:.3}/s",
        damped - undamped
    );
    // The grid resolves the mode with 32 cells; the tip is a cell thick: 10 %.
    assert!(
        ((damped - undamped) / expected - 1.0).abs() < 0.10,
        "damping adds {} /s, closed form {expected} /s",
        damped - undamped
    );
}
