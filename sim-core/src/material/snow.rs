//! Snow, Stomakhin et al. 2013 ("A material point method for snow simulation").
//!
//! Multiplicative plasticity F = Fe Fp. After each G2P the singular values σ of the trial Fe are
//! returned to the box [1 - θc, 1 + θs]³ (eq. 11: θc = 2.5e-2, θs = 4.5e-3), the removed part goes
//! to Jp = det Fp, and the Lamé parameters harden as mu = mu0 e^{ξ(1 - Jp)}, lambda likewise
//! (eq. 8, ξ = 10). Stress is fixed-corotated on Fe. The hardening factor is clamped to [0.1, 5],
//! as in Taichi's reference implementation, so a fully crushed or stretched particle stays stable.
//!
//! The return is the closest point of the box in the elastic energy norm
//! ‖d‖² = 2μ Σ dᵢ² + λ (Σ dᵢ)² of the principal strains d = σ - 1, the metric of the linearised
//! fixed-corotated energy (the closest-point return mapping of Simo & Hughes 1998, "Computational
//! Inelasticity"), not eq. 11's clamp of each σᵢ on its own. Both agree when lambda = 0 (nu = 0).
//! The paper's clamp turns part of a volume-preserving shear into a volume change, which at
//! nu -> 0.5 (lambda ≫ mu) raises the stored energy at every projection: `splatphys bench
//! stability` measured 19–437 % energy growth for nu ≥ 0.45 with it. A projection in the energy
//! norm onto a convex set that holds the rest state never lengthens the strain in that norm, so
//! the return itself never adds elastic energy (to first order in the strain).

use glam::{Mat3A, Vec3A};

use super::jelly::{corotated_energy, corotated_stress, corotated_stress_x4};
use super::{ConstitutiveModel, ElasticParams, MaterialError, check_range};
use crate::math::{Svd3, svd3};

/// Critical compression θc (Stomakhin et al. 2013, table 2).
pub const THETA_C: f32 = 2.5e-2;
/// Critical stretch θs. Stomakhin et al. 2013's reference value is 7.5e-3 (table 2); splatphys
/// uses 4.5e-3, the value of Hu et al. 2018's MLS-MPM reference code (the 88-line snow demo),
/// which the Taichi side-by-side benchmarks run, so that both sides run the same material and
/// the published snow figures stay comparable. Set `critical_stretch = 7.5e-3` for the paper's.
pub const THETA_S: f32 = 4.5e-3;
/// Smallest Jp kept (a fully crushed trial F must not zero it for good).
const MIN_JP: f32 = 1e-6;
/// How far Jp may still fall within one substep in the state-dependent CFL bound
/// ([`ConstitutiveModel::wave_speed_for_m_s`]): the moduli are taken at the smallest Jp of the
/// particles minus this (a factor e^{0.02 ξ} on them, 1.22 at ξ = 10).
const CFL_JP_MARGIN: f32 = 0.02;

/// Bounds of the hardening factor e^{ξ(1 - Jp)}.
const HARDENING_RANGE: (f32, f32) = (0.1, 5.0);

/// Snow: fixed-corotated elasticity with clamped singular values and hardening.
#[derive(Debug, Clone, PartialEq)]
pub struct Snow {
    /// E, nu, density and Lamé parameters (mu0, lambda0).
    pub params: ElasticParams,
    /// Hardening coefficient ξ (dimensionless, default 10).
    pub hardening: f32,
    /// Critical compression θc (default 2.5e-2).
    pub theta_c: f32,
    /// Critical stretch θs (default 4.5e-3).
    pub theta_s: f32,
}

impl Snow {
    /// Snow with hardening ξ in [0, 100].
    ///
    /// # Errors
    /// [`MaterialError::OutOfRange`] for ξ outside [0, 100].
    pub fn new(params: ElasticParams, hardening: f64) -> Result<Self, MaterialError> {
        let hardening = check_range("snow", "hardening", hardening, 0.0, 100.0, "[0, 100]")?;
        Ok(Self {
            params,
            hardening,
            theta_c: THETA_C,
            theta_s: THETA_S,
        })
    }

    /// Overrides the critical compression θc and stretch θs, each in (0, 0.5].
    ///
    /// # Errors
    /// [`MaterialError::OutOfRange`] for a value outside (0, 0.5].
    pub fn with_thresholds(mut self, theta_c: f64, theta_s: f64) -> Result<Self, MaterialError> {
        self.theta_c = check_range(
            "snow",
            "critical_compression",
            theta_c,
            1e-9,
            0.5,
            "(0, 0.5]",
        )?;
        self.theta_s = check_range("snow", "critical_stretch", theta_s, 1e-9, 0.5, "(0, 0.5]")?;
        Ok(self)
    }

    #[inline]
    fn hardening_factor(&self, jp: f32) -> f32 {
        (self.hardening * (1.0 - jp))
            .exp()
            .clamp(HARDENING_RANGE.0, HARDENING_RANGE.1)
    }
}

impl ConstitutiveModel for Snow {
    fn name(&self) -> &'static str {
        "snow"
    }
    fn elastic(&self) -> &ElasticParams {
        &self.params
    }
    #[inline]
    fn kirchhoff_stress(&self, f: Mat3A, jp: f32) -> Mat3A {
        let h = self.hardening_factor(jp);
        corotated_stress(f, self.params.mu_pa * h, self.params.lambda_pa * h)
    }
    #[inline]
    fn kirchhoff_stress_x4(&self, f: &[Mat3A; 4], jp: &[f32; 4]) -> [Mat3A; 4] {
        let h = jp.map(|jp| self.hardening_factor(jp));
        let tau = corotated_stress_x4(
            &crate::math::Mat3x4::from_lanes(f),
            wide::f32x4::new(h.map(|h| self.params.mu_pa * h)),
            wide::f32x4::new(h.map(|h| self.params.lambda_pa * h)),
        );
        std::array::from_fn(|l| tau.lane(l))
    }
    fn energy_density(&self, f: Mat3A, jp: f32) -> f32 {
        let h = self.hardening_factor(jp);
        corotated_energy(f, self.params.mu_pa * h, self.params.lambda_pa * h)
    }
    fn project(&self, f: &mut Mat3A, jp: &mut f32, _dt_s: f32) {
        if inside_box(f, 1.0 - self.theta_c, 1.0 + self.theta_s) {
            // Elastic: the return mapping would give F and Jp back unchanged.
            return;
        }
        let Svd3 { u, sigma, v } = svd3(*f);
        let p = &self.params;
        let clamped = return_to_box(
            sigma,
            1.0 - self.theta_c,
            1.0 + self.theta_s,
            p.lambda_pa / (2.0 * p.mu_pa),
        );
        // An inverted trial F (det < 0, one negative singular value) is returned into the box,
        // i.e. un-inverted: Jp = det Fp takes |det F| so it stays positive.
        let old_j = (sigma.x * sigma.y * sigma.z).abs();
        let new_j = clamped.x * clamped.y * clamped.z;
        *jp = (*jp * old_j / new_j).max(MIN_JP);
        *f = u * Mat3A::from_diagonal(clamped.into()) * v.transpose();
    }
    fn initial_plastic_state(&self) -> f32 {
        1.0
    }
    fn max_wave_speed_m_s(&self) -> f32 {
        self.params.dilational_wave_speed_m_s() * HARDENING_RANGE.1.sqrt()
    }
    /// c_p of the hardest particle: the moduli harden by h(Jp) = e^{ξ(1 - Jp)}, so the bound is
    /// c_p0 √h at the smallest Jp (less `CFL_JP_MARGIN`), not at the hardening cap: snow that
    /// is not compressed to the cap steps at up to √5 ≈ 2.2× the capped dt.
    fn wave_speed_for_m_s(&self, plastic: &[f32]) -> f32 {
        use rayon::prelude::*;
        let jp_min = plastic
            .par_iter()
            .copied()
            .reduce(|| f32::INFINITY, f32::min);
        self.params.dilational_wave_speed_m_s()
            * self.hardening_factor(jp_min - CFL_JP_MARGIN).sqrt()
    }
}

/// Whether every singular value of `f` is surely in [lo, hi] (0 < lo < 1 < hi), without an SVD:
/// det F > 0, and every Gershgorin disc of C = FᵀF (whose eigenvalues are the σᵢ²) lies inside
/// [lo², hi²], with a margin for the rounding of C. False means "maybe not": the caller does the
/// SVD. Most snow is elastic most of the time, and the SVD was 40 % of a snow substep.
#[inline]
fn inside_box(f: &Mat3A, lo: f32, hi: f32) -> bool {
    if f.determinant() <= 0.0 {
        return false;
    }
    let c = f.transpose() * *f;
    let (a, b, d) = (c.x_axis, c.y_axis, c.z_axis);
    let discs = [
        (a.x, b.x.abs() + d.x.abs()),
        (b.y, a.y.abs() + d.y.abs()),
        (d.z, a.z.abs() + b.z.abs()),
    ];
    let margin = 1e-5;
    let (lo2, hi2) = (lo * lo + margin, hi * hi - margin);
    discs
        .iter()
        .all(|&(centre, radius)| centre - radius >= lo2 && centre + radius <= hi2)
}

/// The closest point of the box [lo, hi]³ to the singular values `sigma` in the norm
/// ‖d‖² = Σ dᵢ² + r (Σ dᵢ)², r = lambda / (2 mu) ≥ 0 (the fixed-corotated energy norm divided by
/// 2 mu). `sigma` inside the box comes back unchanged; r = 0 is the per-component clamp.
///
/// A convex quadratic programme in three variables: its minimiser is the stationary point of one
/// of the 27 faces, edges, corners or the interior (each coordinate free, at lo or at hi). On a
/// face with free set F and fixed displacements d_a, every free coordinate moves by the same
/// c = -r Σ d_a / (1 + r |F|); the answer is the feasible candidate with the smallest norm.
fn return_to_box(sigma: Vec3A, lo: f32, hi: f32, r: f32) -> Vec3A {
    if sigma.cmpge(Vec3A::splat(lo)).all() && sigma.cmple(Vec3A::splat(hi)).all() {
        return sigma;
    }
    let s = sigma.to_array();
    let mut best = sigma.clamp(Vec3A::splat(lo), Vec3A::splat(hi));
    let mut best_norm = f32::INFINITY;
    // State of coordinate i: 0 free, 1 at lo, 2 at hi.
    for code in 0..27u32 {
        let state = [code % 3, (code / 3) % 3, code / 9];
        let mut fixed_sum = 0.0;
        let mut free = 0.0;
        for (st, si) in state.iter().zip(s) {
            match st {
                1 => fixed_sum += lo - si,
                2 => fixed_sum += hi - si,
                _ => free += 1.0,
            }
        }
        let c = -r * fixed_sum / (1.0 + r * free);
        let mut y = [0.0f32; 3];
        let mut feasible = true;
        for ((yi, st), si) in y.iter_mut().zip(state).zip(s) {
            *yi = match st {
                1 => lo,
                2 => hi,
                _ => si + c,
            };
            feasible &= (lo..=hi).contains(yi);
        }
        if !feasible {
            continue;
        }
        let d = Vec3A::from_array(y) - sigma;
        let sum = d.x + d.y + d.z;
        let norm = d.length_squared() + r * sum * sum;
        if norm < best_norm {
            best_norm = norm;
            best = Vec3A::from_array(y);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    const LO: f32 = 1.0 - THETA_C;
    const HI: f32 = 1.0 + THETA_S;

    #[test]
    fn the_cfl_wave_speed_follows_the_hardest_particle_up_to_the_cap() {
        let snow = Snow::new(ElasticParams::new("snow", 1.4e5, 0.2, 400.0).unwrap(), 10.0).unwrap();
        let cp0 = snow.params.dilational_wave_speed_m_s();
        let close = |a: f32, b: f32| (a - b).abs() <= 1e-5 * b;
        // Uncompressed: the moduli hardened by the margin only, e^{10 · 0.02}.
        assert!(close(
            snow.wave_speed_for_m_s(&[1.0; 4]),
            cp0 * 0.2f32.exp().sqrt()
        ));
        // One particle at Jp = 0.9 sets it: e^{10 · 0.12}, below the cap of 5.
        let c = snow.wave_speed_for_m_s(&[1.0, 0.9, 1.0]);
        assert!(
            close(c, cp0 * 1.2f32.exp().sqrt()),
            "{c} vs {}",
            cp0 * 1.2f32.exp().sqrt()
        );
        // Crushed: the cap, as the state-free bound.
        assert!(close(
            snow.wave_speed_for_m_s(&[0.5]),
            snow.max_wave_speed_m_s()
        ));
        // Stretched snow softens (down to 0.1 of its moduli).
        assert!(snow.wave_speed_for_m_s(&[1.5]) < cp0);
    }

    #[test]
    fn the_quick_elastic_test_never_passes_a_singular_value_outside_the_box() {
        // Rotated stretches U diag(σ) Vᵀ on and around the box: whenever the test says
        // "inside", every σ is inside; and an F well inside (σ near 1) does pass it.
        let mut passed = 0;
        for (i, t) in trials().enumerate() {
            for sign in [1.0f32, -1.0] {
                let u = Mat3A::from_quat(glam::Quat::from_euler(
                    glam::EulerRot::XYZ,
                    0.3 * i as f32,
                    1.1,
                    -0.7 * i as f32,
                ));
                let v = Mat3A::from_quat(glam::Quat::from_axis_angle(
                    Vec3A::ONE.normalize().into(),
                    0.4 * i as f32,
                ));
                let f = u
                    * Mat3A::from_diagonal((t * Vec3A::new(1.0, 1.0, sign)).into())
                    * v.transpose();
                let truly = sign > 0.0
                    && t.cmpge(Vec3A::splat(LO)).all()
                    && t.cmple(Vec3A::splat(HI)).all();
                if inside_box(&f, LO, HI) {
                    assert!(truly, "σ = {t} (sign {sign}) passed");
                    passed += 1;
                }
            }
        }
        assert!(passed > 0);
        assert!(inside_box(
            &Mat3A::from_quat(glam::Quat::from_rotation_z(2.0)),
            LO,
            HI
        ));
    }

    /// Squared energy norm of `d` (divided by 2 mu).
    fn norm(d: Vec3A, r: f32) -> f32 {
        let s = d.x + d.y + d.z;
        d.length_squared() + r * s * s
    }

    fn trials() -> impl Iterator<Item = Vec3A> {
        let v = [0.9f32, 0.96, 0.975, 0.99, 1.0, 1.003, 1.0045, 1.01, 1.1];
        v.into_iter().flat_map(move |a| {
            v.into_iter()
                .flat_map(move |b| v.into_iter().map(move |c| Vec3A::new(a, b, c)))
        })
    }

    #[test]
    fn inside_the_box_is_unchanged_and_nu_zero_is_the_clamp() {
        let inside = Vec3A::new(0.98, 1.0, 1.004);
        assert_eq!(return_to_box(inside, LO, HI, 24.5), inside);
        for t in trials() {
            let clamp = t.clamp(Vec3A::splat(LO), Vec3A::splat(HI));
            assert_eq!(return_to_box(t, LO, HI, 0.0), clamp, "trial {t}");
        }
    }

    #[test]
    fn return_is_the_closest_box_point_in_the_energy_norm() {
        // Brute force over a 61³ lattice of the box: nothing is closer than the returned point.
        let n = 60;
        let at = |i: usize| LO + (HI - LO) * i as f32 / n as f32;
        for r in [0.25f32, 1.0, 24.5] {
            for t in trials() {
                let y = return_to_box(t, LO, HI, r);
                assert!(y.cmpge(Vec3A::splat(LO)).all() && y.cmple(Vec3A::splat(HI)).all());
                let best = norm(y - t, r);
                let mut lattice = f32::INFINITY;
                for i in 0..=n {
                    for j in 0..=n {
                        for k in 0..=n {
                            lattice = lattice.min(norm(Vec3A::new(at(i), at(j), at(k)) - t, r));
                        }
                    }
                }
                assert!(
                    best <= lattice * (1.0 + 1e-5) + 1e-12,
                    "r {r} trial {t}: {best} > {lattice}"
                );
                // Never farther from rest than the trial: the return adds no elastic energy.
                let one = Vec3A::ONE;
                assert!(
                    norm(y - one, r) <= norm(t - one, r) * (1.0 + 1e-6),
                    "r {r} trial {t}"
                );
            }
        }
    }

    #[test]
    fn an_inverted_f_keeps_jp_positive() {
        let snow = Snow::new(
            crate::material::elastic::ElasticParams::new("snow", 1.4e5, 0.2, 400.0).unwrap(),
            10.0,
        )
        .unwrap();
        // A reflection with a stretch: det F < 0.
        let mut f = Mat3A::from_diagonal(glam::Vec3::new(-1.2, 1.0, 0.9));
        let mut jp = 1.0f32;
        snow.project(&mut f, &mut jp, 1e-4);
        assert!(jp > 0.0 && jp.is_finite(), "Jp = {jp}");
        assert!(f.determinant() > 0.0, "F stays inverted: {f}");
    }

    #[test]
    fn isochoric_shear_at_high_nu_keeps_its_volume_where_the_box_allows() {
        // σ = (1.05, 1/1.05, 1): J = 1. The per-component clamp gives J = 1.0045 · 0.975 < 1 (a
        // 2 % volume loss, stored at lambda ≫ mu); the energy-norm return keeps J near 1.
        let t = Vec3A::new(1.05, 1.0 / 1.05, 1.0);
        let y = return_to_box(t, LO, HI, 24.5);
        let clamp = t.clamp(Vec3A::splat(LO), Vec3A::splat(HI));
        let j = |v: Vec3A| v.x * v.y * v.z;
        assert!((j(clamp) - 1.0).abs() > 0.02);
        assert!((j(y) - 1.0).abs() < 0.002, "J = {}", j(y));
    }
}
