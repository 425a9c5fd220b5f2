//! What the world publishes: per-Gaussian state (kinematics; carried along a particle subset
//! when an object has one, [`super::carry`]), per-object summaries and conservation diagnostics.

use glam::{DVec3, Mat3A, Quat};
use rayon::prelude::*;

use super::{Body, ObjectSummary, World};
use crate::gaussians::GaussianCloud;
use crate::kinematics::{GaussianState, gaussian_state};
use crate::math::polar;
use crate::mpm::Diagnostics;
use crate::scene::ObjectKind;

impl World {
    /// Published Gaussians: the visible ones of every object, then the background.
    pub fn published_count(&self) -> usize {
        self.bodies
            .iter()
            .map(|b| b.visible.iter().filter(|v| **v).count())
            .sum::<usize>()
            + self.background.cloud.len()
    }

    /// Calls `f(object id or None for background, cloud, index)` for every published Gaussian in
    /// publishing order (the static part a renderer needs: SH, opacity, scales).
    pub fn for_each_published(&self, mut f: impl FnMut(Option<u32>, &GaussianCloud, usize)) {
        for (k, b) in self.bodies.iter().enumerate() {
            for i in (0..b.gaussian_count()).filter(|&i| b.visible[i]) {
                f(Some(k as u32), &b.gaussians, i);
            }
        }
        for i in 0..self.background.cloud.len() {
            f(None, &self.background.cloud, i);
        }
    }

    /// Writes every published Gaussian's state into `out` (length [`World::published_count`];
    /// extra entries are left untouched), in parallel, in place.
    pub fn write_gaussians(&self, out: &mut [GaussianState]) {
        let mut rest = out;
        for b in &self.bodies {
            let n = b.visible.iter().filter(|v| **v).count().min(rest.len());
            let (mine, tail) = rest.split_at_mut(n);
            rest = tail;
            let idx: Vec<usize> = (0..b.gaussian_count()).filter(|&i| b.visible[i]).collect();
            if b.is_frozen() {
                // A solid: μ = x + R μ_b, Σ = R Σ_b Rᵀ, with R formed once.
                let r = Mat3A::from_quat(b.rigid.orientation);
                let com = b.rigid.com_m.as_vec3a();
                mine.par_iter_mut().zip(idx.par_iter()).for_each(|(o, &i)| {
                    *o = gaussian_state(com + r * b.gaussian_offsets[i], r, b.sigma0[i]);
                });
                continue;
            }
            mine.par_iter_mut().zip(idx.par_iter()).for_each(|(o, &i)| {
                let (x, f) = b.gaussian_pose(i);
                *o = gaussian_state(x, f, b.sigma0[i]);
            });
        }
        let n = self.background.state.len().min(rest.len());
        rest[..n].copy_from_slice(&self.background.state[..n]);
    }

    /// The elastic energy the particle barrier at "separate" surfaces holds in deformable
    /// object `id` now (J; `contact::barrier::energy_j`): part of its mechanical energy, like
    /// its strain energy; the explicit step's modified energy, for the substep the world would
    /// take next. Zero for other kinds and unknown ids.
    pub fn barrier_energy_j(&self, id: usize) -> f64 {
        if id >= self.bodies.len() {
            return 0.0;
        }
        let dt_s = self.time_step(f64::INFINITY).unwrap_or(0.0);
        super::mpm_step::barrier_energy_j(&self.env(), &self.bodies, id, dt_s)
    }

    /// Per-object summaries (COM, velocity, orientation, spin, mass, contacts).
    pub fn objects(&self) -> Vec<ObjectSummary> {
        let per_s = 1.0 / self.frame_dt_s();
        self.bodies
            .iter()
            .enumerate()
            .map(|(k, b)| {
                let s = b.state();
                let (q, w) = if b.kind != ObjectKind::Deformable {
                    (b.rigid.orientation, b.rigid.omega_rad_s)
                } else {
                    (best_fit_rotation(b, s.com_m), s.angular_velocity())
                };
                ObjectSummary {
                    id: k as u32,
                    name: b.name.clone(),
                    com_m: s.com_m.to_array(),
                    velocity_m_s: s.velocity_m_s.to_array(),
                    orientation_wxyz: [q.w, q.x, q.y, q.z],
                    angular_velocity_rad_s: w.to_array(),
                    mass_kg: s.mass_kg,
                    contacts: b.stats.contacts,
                    sleeping: b.sleeping,
                    contact_force_n: (b.stats.frame_impulse_n_s * per_s).to_array(),
                    contact_torque_n_m: (b.stats.frame_angular_impulse_n_m_s * per_s).to_array(),
                }
            })
            .collect()
    }

    /// Conservation diagnostics summed over every object.
    pub fn diagnostics(&self) -> Diagnostics {
        self.bodies
            .iter()
            .map(|b| match b.is_frozen() {
                true => rigid_diagnostics(b, self.gravity_m_s2.as_dvec3()),
                false => {
                    Diagnostics::measure(&b.particles, &b.materials, self.gravity_m_s2, b.dx_m())
                }
            })
            .fold(Diagnostics::default(), |a, b| a.combine(&b))
    }
}

/// A solid's diagnostics from its pose: momentum M v, angular momentum about the origin
/// x × M v + I ω, kinetic energy ½ M |v|² + ½ ω·I ω, potential −M g·x, no elastic energy.
fn rigid_diagnostics(b: &Body, gravity_m_s2: DVec3) -> Diagnostics {
    let s = b.state();
    let p = s.velocity_m_s * s.mass_kg;
    let w = b.rigid.omega_rad_s;
    Diagnostics {
        mass_kg: s.mass_kg,
        momentum_kg_m_s: p.to_array(),
        angular_momentum_kg_m2_s: (s.com_m.cross(p) + s.angular_momentum).to_array(),
        kinetic_j: 0.5 * (s.mass_kg * s.velocity_m_s.length_squared() + w.dot(s.inertia * w)),
        affine_kinetic_j: 0.0,
        elastic_j: 0.0,
        potential_j: -s.mass_kg * gravity_m_s2.dot(s.com_m),
        max_speed_m_s: s.velocity_m_s.length() + w.length() * b.arm_m(),
    }
}

/// The rotation that best maps an object's rest offsets onto its current ones (shape matching,
/// Müller et al. 2005): R from the polar decomposition of Σ m (x - c)(r0)ᵀ.
fn best_fit_rotation(b: &Body, com: DVec3) -> Quat {
    let c = com.as_vec3a();
    let mut a = Mat3A::ZERO;
    for i in 0..b.particles.len() {
        let d = (b.particles.x[i] - c) * b.particles.mass_kg[i];
        let r0 = b.rest_offsets[i];
        a += Mat3A::from_cols(d * r0.x, d * r0.y, d * r0.z);
    }
    if !a.is_finite() || a.abs().to_cols_array().iter().all(|v| *v == 0.0) {
        return Quat::IDENTITY;
    }
    Quat::from_mat3a(&polar(a).r).normalize()
}
