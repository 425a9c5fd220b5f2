//! Stability: a stiff block hitting a plane at 20 m/s with automatic dt survives; a fixed dt
//! above the CFL bound is refused, and forcing one 4× the bound fails cleanly (no NaN in state).

use glam::Vec3A;
use splatphys_core::collider::{Collider, Plane, Shape, Surface};
use splatphys_core::material::Material;
use splatphys_core::mpm::{
    MpmError, MpmSystem, Particles, SimError, TimeStepError, TimeStepPolicy, cfl_dt_s,
};

fn stiff_block() -> MpmSystem {
    let steel_like = Material::jelly(1e9, 0.3, 1000.0).unwrap();
    let mut p = Particles::lattice_box(
        Vec3A::new(0.0, 0.0, 0.02),
        Vec3A::new(0.05, 0.05, 0.07),
        0.005,
        1000.0,
        0,
        0,
    );
    p.v.iter_mut()
        .for_each(|v| *v = Vec3A::new(0.0, 0.0, -20.0));
    let mut sys = MpmSystem::new(p, vec![steel_like], 0.01);
    sys.colliders.push(Collider::fixed(
        Shape::Plane(Plane::new(Vec3A::ZERO, Vec3A::Z).unwrap()),
        Surface::Separate,
        0.0,
    ));
    sys
}

#[test]
fn stiff_block_at_20_m_s_with_automatic_dt_finishes() {
    let mut sys = stiff_block();
    sys.advance(0.004).unwrap();
    assert!(sys.particles.first_non_finite().is_none());
    // It reached the plane and was stopped or turned back, never passing through.
    let lowest = sys
        .particles
        .x
        .iter()
        .map(|x| x.z)
        .fold(f32::INFINITY, f32::min);
    assert!(lowest > -0.01, "passed through the plane: {lowest}");
    assert!(
        sys.particles.v.iter().map(|v| v.z).sum::<f32>() / (sys.particles.len() as f32)
            > -20.0 * 0.5
    );
}

#[test]
fn fixed_dt_above_the_cfl_bound_is_refused_with_the_bound() {
    let mut sys = stiff_block();
    let bound = cfl_dt_s(1.0, 0.01, sys.max_wave_speed_m_s(), 20.0);
    sys.policy = TimeStepPolicy::Fixed {
        dt_s: 4.0 * bound,
        force: false,
    };
    let err = sys.substep(1.0).unwrap_err();
    let SimError::TimeStep {
        source: TimeStepError::FixedAboveBound { bound_s, .. },
        ..
    } = err
    else {
        panic!("unexpected {err}");
    };
    assert!((bound_s - bound).abs() <= 1e-3 * bound);
    assert!(err.to_string().contains("CFL bound"), "{err}");
}

#[test]
fn forced_dt_4x_the_bound_fails_cleanly() {
    let mut sys = stiff_block();
    let bound = cfl_dt_s(1.0, 0.01, sys.max_wave_speed_m_s(), 20.0);
    sys.policy = TimeStepPolicy::Fixed {
        dt_s: 4.0 * bound,
        force: true,
    };
    let err = sys.advance(0.004).unwrap_err();
    assert!(
        matches!(
            err,
            SimError::Solver {
                source: MpmError::NonFiniteParticle { .. }
                    | MpmError::NonFiniteGrid { .. }
                    | MpmError::OutOfGrid { .. },
                ..
            }
        ),
        "unexpected {err}"
    );
    assert!(
        sys.particles.first_non_finite().is_none(),
        "a NaN entered the state"
    );
}
