//! Per-step conservation diagnostics: total mass, linear and angular momentum (including APIC's
//! affine contribution m (dx²/4) ε:Cᵀ, Jiang et al. 2015 section 5.3), kinetic (with APIC's
//! affine part), elastic and gravitational energy. Sums are f64 over fixed chunks in a fixed
//! order: bit-identical for any thread count.

use glam::{DVec3, Vec3A};
use rayon::prelude::*;

use super::particles::Particles;
use crate::material::{ConstitutiveModel, Material};

/// Particles per reduction chunk (fixed, so the summation order never depends on threads).
const CHUNK: usize = 4096;

/// Totals over a particle set.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Diagnostics {
    /// Σ m (kg).
    pub mass_kg: f64,
    /// Σ m v (kg m/s).
    pub momentum_kg_m_s: [f64; 3],
    /// Σ x × m v + m (dx²/4) ε:Cᵀ about the origin (kg m²/s).
    pub angular_momentum_kg_m2_s: [f64; 3],
    /// Σ ½ m |v|² (J).
    pub kinetic_j: f64,
    /// APIC's affine kinetic energy Σ ½ m (dx²/4) |C|² (J; |C| the Frobenius norm): with
    /// `kinetic_j`, the bound on what a P2G transfer puts on the grid, Σ_i ½ m_i |v_i|², for the
    /// quadratic B-spline's inertia D = dx²/4 I (Jiang et al. 2015). A spinning or vibrating
    /// object keeps part of its motion here, and it passes to and from `kinetic_j` and
    /// `elastic_j` from step to step.
    #[serde(default)]
    pub affine_kinetic_j: f64,
    /// Σ V0 ψ(F) (J).
    pub elastic_j: f64,
    /// Σ -m g·x (J), zero at the origin.
    pub potential_j: f64,
    /// Largest |v| (m/s).
    pub max_speed_m_s: f64,
}

impl Diagnostics {
    /// kinetic (with the affine part) + elastic + potential (J).
    pub fn total_energy_j(&self) -> f64 {
        self.kinetic_j + self.affine_kinetic_j + self.elastic_j + self.potential_j
    }

    /// Sums two sets of totals (max for the speed).
    pub fn combine(mut self, o: &Self) -> Self {
        self.mass_kg += o.mass_kg;
        for k in 0..3 {
            self.momentum_kg_m_s[k] += o.momentum_kg_m_s[k];
            self.angular_momentum_kg_m2_s[k] += o.angular_momentum_kg_m2_s[k];
        }
        self.kinetic_j += o.kinetic_j;
        self.affine_kinetic_j += o.affine_kinetic_j;
        self.elastic_j += o.elastic_j;
        self.potential_j += o.potential_j;
        self.max_speed_m_s = self.max_speed_m_s.max(o.max_speed_m_s);
        self
    }

    /// Measures `particles` with their `materials`, gravity (m/s²) and cell size `dx_m`.
    pub fn measure(
        particles: &Particles,
        materials: &[Material],
        gravity_m_s2: Vec3A,
        dx_m: f32,
    ) -> Self {
        let n = particles.len();
        let d = (dx_m as f64) * (dx_m as f64) / 4.0;
        let g = gravity_m_s2.as_dvec3();
        let chunks: Vec<Diagnostics> = (0..n.div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| {
                let mut t = Diagnostics::default();
                for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                    let m = particles.mass_kg[i] as f64;
                    let x = particles.x[i].as_dvec3();
                    let v = particles.v[i].as_dvec3();
                    let cm = particles.c[i];
                    let mv = v * m;
                    let spin = DVec3::new(
                        (cm.y_axis.z - cm.z_axis.y) as f64,
                        (cm.z_axis.x - cm.x_axis.z) as f64,
                        (cm.x_axis.y - cm.y_axis.x) as f64,
                    );
                    let l = x.cross(mv) + spin * (m * d);
                    t.mass_kg += m;
                    for k in 0..3 {
                        t.momentum_kg_m_s[k] += mv[k];
                        t.angular_momentum_kg_m2_s[k] += l[k];
                    }
                    t.kinetic_j += 0.5 * m * v.length_squared();
                    let c2: f32 = cm.to_cols_array().iter().map(|c| c * c).sum();
                    t.affine_kinetic_j += 0.5 * m * d * c2 as f64;
                    let mat = &materials[particles.material[i] as usize];
                    t.elastic_j += particles.volume0_m3[i] as f64
                        * mat.energy_density(particles.f[i], particles.plastic[i]) as f64;
                    t.potential_j -= m * g.dot(x);
                    t.max_speed_m_s = t.max_speed_m_s.max(v.length());
                }
                t
            })
            .collect();
        chunks
            .iter()
            .fold(Diagnostics::default(), |a, b| a.combine(b))
    }
}
