//! St. Venant-Kirchhoff elasticity on Hencky (logarithmic) strain, shared by the plastic models
//! that return-map in principal log-strain space (sand, metal, plasticine, foam).
//!
//! With F = U Σ Vᵀ and ε = ln Σ: ψ = mu tr(ε²) + lambda/2 (tr ε)²;
//! τ = U (2 mu ε + lambda tr(ε) I) Uᵀ (Klár et al. 2016, eq. 26 and its Kirchhoff form).

use glam::{Mat3A, Vec3A};

use crate::math::{Svd3, svd3};

/// Smallest singular value the log is taken of (keeps inverted or crushed particles finite).
pub(crate) const MIN_SIGMA: f32 = 1e-4;

/// Principal Hencky strain ε = ln(max(σ, MIN_SIGMA)).
#[inline]
pub(crate) fn log_strain(sigma: Vec3A) -> Vec3A {
    let s = sigma.max(Vec3A::splat(MIN_SIGMA));
    Vec3A::new(s.x.ln(), s.y.ln(), s.z.ln())
}

/// Kirchhoff stress from the Hencky strain of `f`.
#[inline]
pub(crate) fn hencky_stress(f: Mat3A, mu: f32, lambda: f32) -> Mat3A {
    let Svd3 { u, sigma, .. } = svd3(f);
    let eps = log_strain(sigma);
    let tau = eps * (2.0 * mu) + Vec3A::splat(lambda * (eps.x + eps.y + eps.z));
    u * Mat3A::from_diagonal(tau.into()) * u.transpose()
}

/// √(2/3): the norm of the deviatoric stress of a uniaxial stress σ, over σ.
pub(crate) const UNIAXIAL_TO_DEVIATORIC_NORM: f32 = 0.816_496_6;

/// Hencky energy density.
pub(crate) fn hencky_energy(f: Mat3A, mu: f32, lambda: f32) -> f32 {
    let eps = log_strain(svd3(f).sigma);
    let tr = eps.x + eps.y + eps.z;
    mu * eps.length_squared() + 0.5 * lambda * tr * tr
}

/// Von Mises return mapping in principal log-strain space, yield stress `yield_stress_pa` σ_y
/// in the uniaxial convention: a bar in tension yields at σ_y, which on the norm of the
/// deviatoric Kirchhoff stress is |dev τ| = 2μ |dev ε| = √(2/3) σ_y (Simo and Hughes 1998,
/// section 2.3; the convention of every engineering table of yield stresses). Removes the part
/// of the deviatoric strain beyond √(2/3) σ_y / (2μ) (times `fraction` in (0, 1] for
/// viscoplastic flow), rebuilds F = U exp(ε) Vᵀ and returns the plastic strain increment
/// |Δε_dev|.
pub(crate) fn von_mises_project(
    f: &mut Mat3A,
    mu: f32,
    yield_stress_pa: f32,
    fraction: f32,
) -> f32 {
    let Svd3 { u, sigma, v } = svd3(*f);
    let eps = log_strain(sigma);
    let mean = (eps.x + eps.y + eps.z) / 3.0;
    let dev = eps - Vec3A::splat(mean);
    let norm = dev.length();
    let excess = norm - UNIAXIAL_TO_DEVIATORIC_NORM * yield_stress_pa / (2.0 * mu);
    if excess <= 0.0 || norm <= 0.0 {
        return 0.0;
    }
    let dgamma = excess * fraction;
    let eps_new = eps - dev * (dgamma / norm);
    let s = Vec3A::new(eps_new.x.exp(), eps_new.y.exp(), eps_new.z.exp());
    *f = u * Mat3A::from_diagonal(s.into()) * v.transpose();
    dgamma
}
