//! Compressible neo-Hookean elasticity (Bonet and Wood; as in Sifakis and Barbič's course notes).
//!
//! ψ(F) = mu/2 (tr(FᵀF) - 3) - mu ln J + lambda/2 (ln J)²;  τ = mu (F Fᵀ - I) + lambda ln J I.
//! J is clamped to at least 1e-4 so an inverted particle gets a large restoring stress, not a NaN.
//!
//! The energy is second order in the strain while its first two terms are first order and cancel
//! (mu/2 · 2 tr ε against mu ln J): in f32 that cancellation leaves an error of ~1e-7 mu per
//! particle, larger than ψ itself below strains of ~3e-4 (a stiff sphere's impact). ψ is
//! therefore evaluated in f64 from H = F - I: tr(FᵀF) - 3 = 2 tr H + |H|², J - 1 = tr H + the
//! second invariant of H + det H, ln J = ln_1p(J - 1).

use glam::{DMat3, Mat3A, Vec3};

use super::{ConstitutiveModel, ElasticParams};

/// Smallest J the model evaluates ln J at.
const MIN_J: f32 = 1e-4;

/// Neo-Hookean elastic material.
#[derive(Debug, Clone, PartialEq)]
pub struct NeoHookean {
    /// E, nu, density and Lamé parameters.
    pub params: ElasticParams,
}

impl NeoHookean {
    /// A neo-Hookean material with validated elastic parameters.
    pub fn new(params: ElasticParams) -> Self {
        Self { params }
    }
}

impl ConstitutiveModel for NeoHookean {
    fn name(&self) -> &'static str {
        "neo-hookean"
    }
    fn elastic(&self) -> &ElasticParams {
        &self.params
    }
    #[inline]
    fn kirchhoff_stress(&self, f: Mat3A, _plastic: f32) -> Mat3A {
        let ElasticParams {
            mu_pa: mu,
            lambda_pa: lambda,
            ..
        } = self.params;
        let log_j = f.determinant().max(MIN_J).ln();
        (f * f.transpose() - Mat3A::IDENTITY) * mu
            + Mat3A::from_diagonal(Vec3::splat(lambda * log_j))
    }
    fn energy_density(&self, f: Mat3A, _plastic: f32) -> f32 {
        let (mu, lambda) = (self.params.mu_pa as f64, self.params.lambda_pa as f64);
        let h = glam::Mat3::from(f).as_dmat3() - DMat3::IDENTITY;
        let tr = h.x_axis.x + h.y_axis.y + h.z_axis.z;
        let norm2 =
            h.x_axis.length_squared() + h.y_axis.length_squared() + h.z_axis.length_squared();
        // ½((tr H)² - tr(H H)), the second invariant of H.
        let i2 = 0.5 * (tr * tr - (h * h).to_cols_array().iter().step_by(4).sum::<f64>());
        let j_minus_1 = (tr + i2 + h.determinant()).max(MIN_J as f64 - 1.0);
        let log_j = j_minus_1.ln_1p();
        (mu * (tr - log_j) + 0.5 * mu * norm2 + 0.5 * lambda * log_j * log_j) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn steel_like() -> NeoHookean {
        NeoHookean::new(ElasticParams::new("neo-hookean", 1e9, 0.3, 1000.0).unwrap())
    }

    /// Linear elasticity's ψ = mu ε:ε + lambda/2 (tr ε)² for a small symmetric strain ε.
    fn linear_energy(m: &NeoHookean, eps: [f64; 6]) -> f64 {
        let (mu, lambda) = (m.params.mu_pa as f64, m.params.lambda_pa as f64);
        let [xx, yy, zz, xy, xz, yz] = eps;
        let tr = xx + yy + zz;
        mu * (xx * xx + yy * yy + zz * zz + 2.0 * (xy * xy + xz * xz + yz * yz))
            + 0.5 * lambda * tr * tr
    }

    #[test]
    fn small_strain_energy_matches_linear_elasticity() {
        // Regression: in f32 the first-order terms' cancellation made ψ of a stiff sphere's
        // impact (strain ~1e-4) wrong by up to 30×, so the energy of a stable run seemed to grow
        // 7-fold in `bench stability`. At these strains neo-Hookean and linear elasticity differ
        // by O(ε) relative, so 1 % is a strict bound.
        let m = steel_like();
        for eps in [
            [1e-4, 0.0, 0.0, 0.0, 0.0, 0.0],
            [-2e-4, 5e-5, 5e-5, 0.0, 0.0, 0.0],
            [3e-5, -1e-5, 2e-5, 4e-5, -2e-5, 1e-5],
        ] {
            let [xx, yy, zz, xy, xz, yz] = eps.map(|v| v as f32);
            let f = Mat3A::from_cols_array(&[1.0 + xx, xy, xz, xy, 1.0 + yy, yz, xz, yz, 1.0 + zz]);
            let want = linear_energy(&m, eps);
            let got = m.energy_density(f, 0.0) as f64;
            assert!(
                (got - want).abs() <= 0.01 * want,
                "eps {eps:?}: psi = {got} J/m3, linear elasticity {want} J/m3"
            );
        }
        assert_eq!(m.energy_density(Mat3A::IDENTITY, 0.0), 0.0);
    }

    #[test]
    fn inverted_particles_have_finite_energy() {
        let m = steel_like();
        let f = Mat3A::from_diagonal(Vec3::new(-0.5, 1.0, 1.0));
        assert!(m.energy_density(f, 0.0).is_finite());
    }
}
