//! Solids are rigid bodies: a rigid object keeps no live particles (they wait in a body-frame
//! template) and publishes its Gaussians from its pose, μ = x + R μ_b and Σ = R Σ_b Rᵀ; `set-kind`
//! to deformable places the template by the pose with the rigid motion as its velocity field, and
//! back to rigid freezes it again, with no published Gaussian jumping either way; a jelly made
//! rigid where it lies on a box stays there.

use glam::{DMat3, DVec3, Mat3A, Quat, Vec3A};
use splatphys_core::kinematics::GaussianState;
use splatphys_core::material::MaterialSpec;
use splatphys_core::scene::{ObjectBuilder, ObjectKind, Scene, SceneObject};
use splatphys_core::world::{World, measure};

fn world(object: ObjectBuilder, duration_s: f64) -> World {
    let scene = Scene::builder()
        .grid_dx_m(0.01)
        .frame_rate_hz(60.0)
        .duration_s(duration_s)
        .gravity_m_s2([0.0; 3])
        .object(object)
        .build()
        .expect("scene");
    World::from_scene(&scene).expect("world")
}

fn published(w: &World) -> Vec<GaussianState> {
    let mut out = vec![GaussianState::default(); w.published_count()];
    w.write_gaussians(&mut out);
    out
}

fn run_for(w: &mut World, frames: u64) {
    for _ in 0..frames {
        w.advance_frame().expect("step");
    }
}

/// The largest |Δμ| (m) and the largest |ΔΣ| relative to the largest |Σ| entry between two
/// publications of the same Gaussians.
fn largest_change(a: &[GaussianState], b: &[GaussianState]) -> (f32, f32) {
    assert_eq!(a.len(), b.len());
    let mut dx = 0.0f32;
    let mut ds = 0.0f32;
    for (a, b) in a.iter().zip(b) {
        dx = dx.max((Vec3A::from(a.position_m) - Vec3A::from(b.position_m)).length());
        let scale = a.covariance_m2.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        for (x, y) in a.covariance_m2.iter().zip(&b.covariance_m2) {
            ds = ds.max((x - y).abs() / scale);
        }
    }
    (dx, ds)
}

#[test]
fn a_rigid_object_keeps_no_particles_and_publishes_its_gaussians_from_its_pose() {
    // A 10 × 6 × 4 cm box spinning at 3 rad/s about its principal axis nearest z (the sampled
    // lattice is not exactly symmetric) while it drifts at 0.2 m/s: a steady rotation, so after t
    // every Gaussian sits at c0 + v t + R(ω t)(μ0 − c0) and its covariance is R Σ0 Rᵀ.
    let mut w = world(
        SceneObject::cuboid("box", [-0.05, -0.03, -0.02], [0.05, 0.03, 0.02])
            .spacing_m(0.005)
            .kind(ObjectKind::Rigid),
        1.0,
    );
    let b = &w.bodies()[0];
    assert!(
        b.particles().is_empty(),
        "a rigid body holds live particles"
    );
    assert_eq!(b.template().len(), b.gaussian_count());
    assert_eq!(w.particle_count(), 0);
    let axis = principal_axis_nearest(b.rigid_world_inertia(), DVec3::Z);
    let (v, omega) = (DVec3::new(0.2, 0.0, 0.0), axis * 3.0);
    w.set_velocity(0, v.as_vec3a(), Some(omega.as_vec3a()))
        .expect("set-velocity");
    let c0 = w.bodies()[0].rigid().com_m;
    let start = published(&w);
    run_for(&mut w, 30);
    let t = w.time_s();
    let r = Mat3A::from_quat(Quat::from_axis_angle(
        axis.as_vec3(),
        (omega.length() * t) as f32,
    ));
    let expected: Vec<GaussianState> = start
        .iter()
        .map(|g| {
            let mu0 = Vec3A::from(g.position_m) - c0.as_vec3a();
            let mut e = *g;
            e.position_m = (c0 + v * t).as_vec3a().to_array();
            e.position_m = (Vec3A::from(e.position_m) + r * mu0).to_array();
            let s0 = unpack(g.covariance_m2);
            e.covariance_m2 = splatphys_core::kinematics::pack_symmetric(r * s0 * r.transpose());
            e
        })
        .collect();
    let (dx, ds) = largest_change(&expected, &published(&w));
    // f32 positions near 10 cm after 30 frames of integration in f64: ~1e-7 m.
    assert!(dx < 2e-6, "a Gaussian is {dx} m from the closed form");
    assert!(ds < 1e-4, "a covariance is off by {ds} of its size");
    // Diagnostics come from the pose: p = M v, E = ½ M |v|² + ½ ω·I ω.
    let d = w.diagnostics();
    let b = &w.bodies()[0];
    let (m, v, omega) = (
        b.rigid().mass_kg,
        b.rigid().velocity_m_s,
        b.rigid().omega_rad_s,
    );
    let p = DVec3::from(d.momentum_kg_m_s);
    assert!(
        (p - v * m).length() < 1e-12 * m,
        "momentum {p} vs {}",
        v * m
    );
    let e = 0.5 * (m * v.length_squared() + omega.dot(b.rigid_world_inertia() * omega));
    assert!(
        (d.kinetic_j - e).abs() < 1e-6 * e,
        "{} J vs {e} J",
        d.kinetic_j
    );
}

/// The unit eigenvector of the inertia `i` closest in direction to `near`.
fn principal_axis_nearest(i: DMat3, near: DVec3) -> DVec3 {
    let m = nalgebra::Matrix3::from_column_slice(&i.to_cols_array());
    let eigen = m.symmetric_eigen();
    let axes = (0..3).map(|k| {
        let e = eigen.eigenvectors.column(k);
        DVec3::new(e[0], e[1], e[2]).normalize()
    });
    let best = axes
        .max_by(|a, b| a.dot(near).abs().total_cmp(&b.dot(near).abs()))
        .expect("three axes");
    best * best.dot(near).signum()
}

fn unpack(c: [f32; 6]) -> Mat3A {
    Mat3A::from_cols_array(&[c[0], c[1], c[2], c[1], c[3], c[4], c[2], c[4], c[5]])
}

#[test]
fn set_kind_round_trip_places_the_template_by_the_pose_and_moves_no_gaussian() {
    // A jelly ball made rigid, spun about a tilted axis while it drifts, made deformable again,
    // then rigid again; with one particle per Gaussian and with a 1 cm carried subset.
    for subset in [None, Some(0.01f32)] {
        let mut ball = SceneObject::sphere("ball", [0.0, 0.0, 0.2], 0.04)
            .spacing_m(0.005)
            .material(MaterialSpec::jelly(1e5, 0.3, 1000.0));
        if let Some(h) = subset {
            ball = ball.physics_spacing_m(h);
        }
        let mut w = world(ball, 1.0);
        let n = w.bodies()[0].particles().len();
        assert!(n > 100, "{subset:?}: {n} particles");
        w.set_kind(0, ObjectKind::Rigid).expect("rigid");
        assert!(w.bodies()[0].particles().is_empty() && w.bodies()[0].template().len() == n);
        let (v, omega) = (DVec3::new(0.1, -0.05, 0.02), DVec3::new(1.0, 2.0, -4.0));
        w.set_velocity(0, v.as_vec3a(), Some(omega.as_vec3a()))
            .expect("set-velocity");
        run_for(&mut w, 15);
        let before = published(&w);
        let rigid = *w.bodies()[0].rigid();
        w.set_kind(0, ObjectKind::Deformable).expect("deformable");
        let (dx, ds) = largest_change(&before, &published(&w));
        assert!(dx < 1e-6, "{subset:?}: a Gaussian moved {dx} m on thawing");
        assert!(
            ds < 1e-4,
            "{subset:?}: a covariance changed by {ds} on thawing"
        );
        // The particles are back, moving with the rigid motion: v_i = v + ω × (x_i − c).
        let b = &w.bodies()[0];
        assert_eq!(b.particles().len(), n);
        assert!(b.template().is_empty() && b.gaussian_offsets().is_empty());
        let c = rigid.com_m;
        for (x, vi) in b.particles().x.iter().zip(&b.particles().v) {
            let want = rigid.velocity_m_s + rigid.omega_rad_s.cross(x.as_dvec3() - c);
            assert!(
                (vi.as_dvec3() - want).length() < 1e-5,
                "{subset:?}: {vi} vs {want}"
            );
        }
        let s = measure(b.particles(), b.dx_m());
        assert!(
            (s.com_m - c).length() < 1e-6,
            "{subset:?}: COM {} vs {c}",
            s.com_m
        );
        assert!((s.velocity_m_s - rigid.velocity_m_s).length() < 1e-6);
        let w_measured = s.angular_velocity();
        assert!(
            (w_measured - rigid.omega_rad_s).length() < 1e-4 * rigid.omega_rad_s.length(),
            "{subset:?}: ω {w_measured} vs {}",
            rigid.omega_rad_s
        );
        // A deformable frame, then rigid again: the template comes back whole, nothing jumps.
        run_for(&mut w, 1);
        let before = published(&w);
        w.set_kind(0, ObjectKind::Rigid).expect("rigid again");
        assert!(w.bodies()[0].particles().is_empty() && w.bodies()[0].template().len() == n);
        let (dx, ds) = largest_change(&before, &published(&w));
        assert!(dx < 1e-6, "{subset:?}: a Gaussian moved {dx} m on freezing");
        assert!(
            ds < 1e-4,
            "{subset:?}: a covariance changed by {ds} on freezing"
        );
    }
}

#[test]
fn a_jelly_made_rigid_where_it_rests_on_a_box_stays_there() {
    // A 6 cm jelly cube laid on a light 5 cm rigid box on a sticky floor (1 cm cells) slumps
    // over the box's edge; made rigid after 1 s, its frozen shape's collision surface starts
    // up to a cell inside the box (the surface of a sampled shape lies on cell faces), and
    // pushing that overlap out lifted it (3.3 mm over the next second, 3.6 % more energy in a
    // frame). The pair keeps the overlap it starts with.
    let scene = Scene::builder()
        .grid_dx_m(0.01)
        .frame_rate_hz(60.0)
        .duration_s(2.0)
        .sleep(false)
        .collider(
            splatphys_core::scene::ColliderSpec::plane("floor", [0.0; 3], [0.0, 0.0, 1.0])
                .surface(splatphys_core::scene::Surface::Sticky),
        )
        .object(
            SceneObject::cuboid("box", [-0.025, -0.025, 0.0], [0.025, 0.025, 0.05])
                .kind(ObjectKind::Rigid)
                .material(MaterialSpec::jelly(1e6, 0.3, 300.0))
                .friction(0.5),
        )
        .object(
            SceneObject::cuboid("jelly", [-0.03, -0.03, 0.052], [0.03, 0.03, 0.112])
                .spacing_m(0.005)
                .material(MaterialSpec {
                    damping_viscosity_pa_s: Some(20.0),
                    ..MaterialSpec::jelly(1e5, 0.3, 1500.0)
                })
                .friction(0.5),
        )
        .build()
        .expect("scene");
    let mut w = World::from_scene(&scene).expect("world");
    run_for(&mut w, 60);
    w.set_kind(1, ObjectKind::Rigid).expect("rigid");
    let energy = |w: &World| -> f64 {
        w.bodies()
            .iter()
            .map(|b| {
                let r = b.rigid();
                0.5 * r.mass_kg * r.velocity_m_s.length_squared()
                    + 0.5 * r.omega_rad_s.dot(b.rigid_world_inertia() * r.omega_rad_s)
                    + r.mass_kg * 9.81 * r.com_m.z
            })
            .sum()
    };
    run_for(&mut w, 1);
    let (z0, e0) = (w.bodies()[1].rigid().com_m.z, energy(&w));
    let mut highest = z0;
    let mut gain = 0.0f64;
    let mut last = e0;
    for _ in 0..60 {
        run_for(&mut w, 1);
        let e = energy(&w);
        gain = gain.max(e / last - 1.0);
        last = e;
        highest = highest.max(w.bodies()[1].rigid().com_m.z);
    }
    println!(
        "made rigid: COM {z0:.5} m, highest over 1 s {highest:.5} m; largest gain in a frame {:.3} %",
        gain * 100.0
    );
    assert!(highest - z0 < 1e-3, "lifted from {z0} to {highest} m");
    assert!(gain < 1e-3, "gained {:.3} % in a frame", gain * 100.0);
}
