//! The 3×3 SVD and polar decomposition against nalgebra, including near-singular and inverted F.

use glam::{Mat3A, Vec3};
use proptest::prelude::*;
use splatphys_core::math::{Mat3x4, polar, polar_rotation, polar_rotation_x4, svd3};

fn mat() -> impl Strategy<Value = Mat3A> {
    prop::array::uniform9(-2.0f32..2.0).prop_map(|a| Mat3A::from_cols_array(&a))
}

/// Rotations times diagonal scales spanning 1e-6..10 with either sign: near-singular and inverted.
fn hard_mat() -> impl Strategy<Value = Mat3A> {
    (
        prop::array::uniform3(-3.2f32..3.2),
        prop::array::uniform3(-6.0f32..1.0),
        prop::array::uniform3(prop::bool::ANY),
    )
        .prop_map(|(angles, logs, neg)| {
            let r = Mat3A::from_euler(glam::EulerRot::XYZ, angles[0], angles[1], angles[2]);
            let s = Vec3::from(logs.map(|l| 10f32.powf(l)))
                * Vec3::from(neg.map(|n| if n { -1.0 } else { 1.0 }));
            r * Mat3A::from_diagonal(s)
                * Mat3A::from_euler(glam::EulerRot::ZYX, angles[2], angles[0], angles[1])
        })
}

fn check(a: Mat3A) -> Result<(), TestCaseError> {
    let s = svd3(a);
    let scale = a
        .to_cols_array()
        .iter()
        .fold(0.0f32, |m, v| m.max(v.abs()))
        .max(1e-30);
    // Reconstruction.
    let back = s.u * Mat3A::from_diagonal(s.sigma.into()) * s.v.transpose();
    let err = (back - a)
        .to_cols_array()
        .iter()
        .fold(0.0f32, |m, v| m.max(v.abs()));
    prop_assert!(
        err <= 2e-5 * scale.max(1.0),
        "reconstruction error {err} for {a:?}"
    );
    // Proper rotations.
    prop_assert!((s.u.determinant() - 1.0).abs() < 1e-4);
    prop_assert!((s.v.determinant() - 1.0).abs() < 1e-4);
    // Singular values match nalgebra's (absolute), sorted, with the sign of det A on the last.
    let n = nalgebra::Matrix3::<f64>::from_column_slice(&a.to_cols_array().map(|v| v as f64));
    let mut ref_s: Vec<f64> = n
        .svd(false, false)
        .singular_values
        .iter()
        .copied()
        .collect();
    ref_s.sort_by(|x, y| y.partial_cmp(x).unwrap());
    let ours = [
        s.sigma.x.abs() as f64,
        s.sigma.y.abs() as f64,
        s.sigma.z.abs() as f64,
    ];
    for k in 0..3 {
        prop_assert!(
            (ours[k] - ref_s[k]).abs() <= 1e-4 * (scale as f64).max(1.0),
            "sigma {ours:?} vs {ref_s:?}"
        );
    }
    prop_assert!(s.sigma.x >= 0.0 && s.sigma.y >= 0.0);
    if n.determinant().abs() > 1e-6 {
        prop_assert_eq!(s.sigma.z < 0.0, n.determinant() < 0.0);
    }
    let p = polar(a);
    prop_assert!((p.r.determinant() - 1.0).abs() < 1e-4);
    prop_assert!(p.r.is_finite() && p.s.is_finite());
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]
    #[test]
    fn svd_matches_nalgebra_on_random_matrices(a in mat()) { check(a)?; }

    #[test]
    fn svd_is_robust_near_singular_and_inverted(a in hard_mat()) { check(a)?; }

    #[test]
    fn newton_polar_rotation_matches_svd_polar(a in mat()) { check_rotation(a)?; }

    #[test]
    fn newton_polar_rotation_is_robust_near_singular_and_inverted(a in hard_mat()) {
        check_rotation(a)?;
    }

    #[test]
    fn newton_polar_rotation_of_elastic_f_matches_svd_polar(
        angles in prop::array::uniform3(-3.2f32..3.2),
        strain in prop::array::uniform9(-0.3f32..0.3),
    ) {
        // F = R (I + E): the deformation gradients of an elastic body, where Newton is used.
        let r = Mat3A::from_euler(glam::EulerRot::XYZ, angles[0], angles[1], angles[2]);
        check_rotation(r * (Mat3A::IDENTITY + Mat3A::from_cols_array(&strain)))?;
    }

    #[test]
    fn four_lane_polar_rotation_equals_the_scalar_bit_for_bit(
        easy in prop::array::uniform2(mat()),
        hard in prop::array::uniform2(hard_mat()),
        order in 0usize..4,
    ) {
        // Lanes that converge at different steps, and lanes that fall back to the SVD, side by
        // side; `order` rotates which lane gets which.
        let mut lanes = [easy[0], hard[0], easy[1], hard[1]];
        lanes.rotate_left(order);
        let r = polar_rotation_x4(&Mat3x4::from_lanes(&lanes));
        for (l, a) in lanes.iter().enumerate() {
            let scalar = polar_rotation(*a).to_cols_array().map(f32::to_bits);
            prop_assert_eq!(r.lane(l).to_cols_array().map(f32::to_bits), scalar, "lane {}", l);
        }
    }
}

/// [`polar_rotation`] is a proper rotation and agrees with the SVD's R = U Vᵀ.
fn check_rotation(a: Mat3A) -> Result<(), TestCaseError> {
    let r = polar_rotation(a);
    let reference = polar(a).r;
    prop_assert!(r.is_finite());
    prop_assert!(
        (r.determinant() - 1.0).abs() < 1e-4,
        "det {}",
        r.determinant()
    );
    let orthogonality = (r.transpose() * r - Mat3A::IDENTITY)
        .to_cols_array()
        .iter()
        .fold(0.0f32, |m, v| m.max(v.abs()));
    prop_assert!(orthogonality < 1e-5, "RᵀR - I = {orthogonality} for {a:?}");
    // A perturbation δ of A moves R by up to 2 |δ| / (σ1 + σ2) (Higham 1986, theorem 2.3, σ1, σ2
    // the two smallest): both methods' f32 rounding, about 1e-6 σ0, amplified by that. Where
    // σ1 + σ2 vanishes R is not determined and only the checks above apply.
    let s = svd3(a).sigma;
    let gap = s.y + s.z;
    if gap > 1e-3 * s.x {
        let err = (r - reference)
            .to_cols_array()
            .iter()
            .fold(0.0f32, |m, v| m.max(v.abs()));
        let tol = 2e-5 * (s.x / gap).max(1.0);
        prop_assert!(err <= tol, "R differs by {err} (tol {tol}) for {a:?}");
    }
    Ok(())
}

#[test]
fn newton_polar_rotation_of_identity_is_exact() {
    assert_eq!(polar_rotation(Mat3A::IDENTITY), Mat3A::IDENTITY);
}

#[test]
fn exactly_singular_and_rank_one_matrices_stay_finite() {
    for a in [
        Mat3A::ZERO,
        Mat3A::from_cols(Vec3::X.into(), Vec3::X.into(), Vec3::X.into()),
        Mat3A::from_diagonal(Vec3::new(1.0, 0.0, 0.0)),
        Mat3A::from_diagonal(Vec3::new(0.0, 0.0, -1.0)),
    ] {
        let s = svd3(a);
        assert!(s.u.is_finite() && s.v.is_finite() && s.sigma.is_finite());
        let back = s.u * Mat3A::from_diagonal(s.sigma.into()) * s.v.transpose();
        assert!(
            (back - a).to_cols_array().iter().all(|d| d.abs() < 1e-5),
            "{a:?}"
        );
    }
}
