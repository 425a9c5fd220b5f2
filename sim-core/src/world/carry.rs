//! Physics-particle subsets: an object simulates fewer MPM particles than it has
//! Gaussians, and every Gaussian is carried along by the particles around it.
//!
//! **Volumes** ([`volume`]). Each Gaussian of the object (fill included) gets a volume V_i, its
//! share of the volume of the solid the Gaussians fill, measured on voxels finer than their
//! spacing and independent of the grid's dx: a sphere's total is its 4/3 π r³ to about 1 %, and
//! a closed surface-only capture gets the volume it encloses. This is exactly what a
//! one-particle-per-Gaussian object uses.
//!
//! **Subset** ([`physics_particles`]). The Gaussian centres X_i are binned into world-aligned
//! cubes of side h (`physics_spacing_m`), cube key ⌊X_i / h⌋. Each occupied cube j becomes one
//! particle with
//!
//! ```text
//! V_j = Σ_{i∈j} V_i,   m_j = ρ V_j,   X_j⁰ = Σ_{i∈j} V_i X_i / V_j,
//! ```
//!
//! the volume-weighted (at one density: mass-weighted) mean of its Gaussians. So the subset has
//! the object's mass and centre of mass, to rounding, and keeps its first moment per cube; a
//! Gaussian picked from the cube would not. Particles are ordered by the first Gaussian of their
//! cube (the body then stores them in block order, `world/block_order.rs`), and a cube holding
//! one Gaussian gives back that Gaussian's own particle bit for bit (one product and one
//! quotient, both exact in f64), so when every Gaussian has a cube of its own the object is the
//! one-particle-per-Gaussian object and no carry is built.
//!
//! **Carry** ([`Carry`]): embedded deformation (Sumner, Schmid and Pauly 2007, "Embedded
//! deformation for shape manipulation", eq. 1 and its weights), with the node's rotation
//! replaced by the particle's deformation gradient. Once, in the rest configuration, each
//! Gaussian g takes its k = min(8, N) nearest particles (N the object's particle count) and
//!
//! ```text
//! w_gj ∝ (1 − |X_g − X_j⁰| / d_max)²,   Σ_j w_gj = 1,
//! ```
//!
//! d_max the distance to the (k+1)-th nearest particle (when N ≤ k: the farthest one plus h),
//! so a particle enters or leaves a Gaussian's set with zero weight and the carried field is
//! continuous in X_g. Every output then is
//!
//! ```text
//! x_g = Σ_j w_gj (x_j + F_j (X_g − X_j⁰)),   F_g = Σ_j w_gj F_j,
//! ```
//!
//! and Σ_g = F_g Σ0_g F_gᵀ as for any particle ([`crate::kinematics`]). Any affine motion of the
//! particles (x_j = A X_j⁰ + t, F_j = A: translation, rigid rotation, uniform stretch) carries
//! every Gaussian exactly, x_g = A X_g + t, because the weights sum to 1. For plastic materials
//! F is the elastic part Fe (what the particles store), so offsets do not follow plastic flow.
//!
//! **Limits.** The grid keeps its cell size, so a subset has fewer particles per cell and MPM
//! integrates stress with fewer quadrature points: a soft object sags and rebounds differently
//! from the full run (`splatphys bench subsets` measures by how much). A cube side above about
//! 3 cells leaves particles that share no grid node, which then no longer hold together.

use std::collections::HashMap;
use std::num::NonZero;

use glam::{DVec3, I64Vec3, Mat3A, Vec3A};
use kiddo::SquaredEuclidean;
use kiddo::immutable::float::kdtree::ImmutableKdTree;
use rayon::prelude::*;

use super::Body;
use crate::mpm::Particles;

pub mod volume;
pub use volume::particle_volumes;

/// Most particles a Gaussian is carried by (k).
pub const CARRY_NEIGHBOURS: usize = 8;

/// Cube key of `x` for side `h_m` (i64: a tiny h cannot wrap; a key past i64 saturates).
fn cube(x: Vec3A, h_m: f32) -> I64Vec3 {
    let k = (x.as_dvec3() / h_m as f64).floor();
    I64Vec3::new(k.x as i64, k.y as i64, k.z as i64)
}

/// For each point of `x`, the index of its cube of side `h_m` in order of first occupation, and
/// the number of occupied cubes.
fn cube_index(x: &[Vec3A], h_m: f32) -> (Vec<u32>, usize) {
    let mut ids: HashMap<I64Vec3, u32> = HashMap::with_capacity(x.len());
    let of: Vec<u32> = x
        .iter()
        .map(|p| {
            let n = ids.len() as u32;
            *ids.entry(cube(*p, h_m)).or_insert(n)
        })
        .collect();
    (of, ids.len())
}

/// How many particles an object with Gaussian centres `x` simulates at spacing `h_m`: its
/// occupied cubes of side `h_m`.
pub fn subset_count(x: &[Vec3A], h_m: f32) -> usize {
    cube_index(x, h_m).1
}

/// An object's physics particles in the rest configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct PhysicsParticles {
    /// `[N]` rest positions X_j⁰ (m, world).
    pub x: Vec<Vec3A>,
    /// `[N]` volumes V_j (m³); masses are ρ V_j.
    pub volume_m3: Vec<f32>,
    /// How the Gaussians follow the particles; `None`: particle i is Gaussian i.
    pub carry: Option<Carry>,
}

/// The particles of an object whose Gaussians sit at `x` (m, world), grid cell `dx_m`, physics
/// spacing `spacing_m` (see the module docs). `None`, or a spacing that gives every Gaussian its
/// own cube: one particle per Gaussian, exactly as without subsets.
pub fn physics_particles(x: &[Vec3A], dx_m: f32, spacing_m: Option<f32>) -> PhysicsParticles {
    let volumes = particle_volumes(x, dx_m);
    let Some(h) = spacing_m.filter(|h| h.is_finite() && *h > 0.0) else {
        return PhysicsParticles {
            x: x.to_vec(),
            volume_m3: volumes,
            carry: None,
        };
    };
    let (of, n) = cube_index(x, h);
    let mut vol = vec![0.0f64; n];
    let mut moment = vec![DVec3::ZERO; n];
    for ((p, v), &j) in x.iter().zip(&volumes).zip(&of) {
        let v = *v as f64;
        vol[j as usize] += v;
        moment[j as usize] += p.as_dvec3() * v;
    }
    let rest: Vec<Vec3A> = moment
        .iter()
        .zip(&vol)
        .map(|(m, v)| (*m / *v).as_vec3a())
        .collect();
    let volume_m3: Vec<f32> = vol.iter().map(|v| *v as f32).collect();
    let carry = (n < x.len()).then(|| Carry::new(x.to_vec(), rest.clone(), h));
    PhysicsParticles {
        x: rest,
        volume_m3,
        carry,
    }
}

impl PhysicsParticles {
    /// The same particles stored in block order for a grid of cell `dx_m` (m)
    /// (`world/block_order.rs`), with the carry's neighbour lists renamed to match; and, when
    /// there is no carry, `[G]` the particle each Gaussian became (empty with a carry).
    pub fn into_block_order(self, dx_m: f32) -> (PhysicsParticles, Vec<u32>) {
        let order = super::block_order::block_order(&self.x, dx_m);
        let new_index = super::block_order::inverse(&order);
        let pick = |a: &[Vec3A]| -> Vec<Vec3A> { order.iter().map(|&i| a[i as usize]).collect() };
        let x = pick(&self.x);
        let volume_m3 = order.iter().map(|&i| self.volume_m3[i as usize]).collect();
        let (carry, gaussian_particle) = match self.carry {
            Some(mut c) => {
                c.rest_particles = pick(&c.rest_particles);
                for row in &mut c.neighbours {
                    row.iter_mut().for_each(|j| *j = new_index[*j as usize]);
                }
                (Some(c), Vec::new())
            }
            None => (None, new_index),
        };
        let sorted = PhysicsParticles {
            x,
            volume_m3,
            carry,
        };
        (sorted, gaussian_particle)
    }
}

/// How an object's Gaussians follow its particles (module docs): fixed neighbours and weights
/// from the rest configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct Carry {
    /// `[G]` rest centre X_g of each Gaussian (m, world).
    pub rest_gaussians: Vec<Vec3A>,
    /// `[N]` rest position X_j⁰ of each particle (m, world).
    pub rest_particles: Vec<Vec3A>,
    /// `[G][k]` particle indices, nearest first; unused slots hold 0 with weight 0.
    pub neighbours: Vec<[u32; CARRY_NEIGHBOURS]>,
    /// `[G][k]` weights w_gj, each row summing to 1.
    pub weights: Vec<[f32; CARRY_NEIGHBOURS]>,
}

/// The (k+1) nearest of `rest` to `q` as (squared distance, index), nearest first, ties by index.
fn nearest(
    tree: Option<&ImmutableKdTree<f32, u32, 3, 32>>,
    rest: &[Vec3A],
    q: Vec3A,
) -> Vec<(f32, u32)> {
    let want = (CARRY_NEIGHBOURS + 1).min(rest.len());
    let mut nn: Vec<(f32, u32)> = match (tree, NonZero::new(want)) {
        (Some(t), Some(k)) => t
            .nearest_n::<SquaredEuclidean>(&q.to_array(), k)
            .into_iter()
            .map(|n| (n.distance, n.item))
            .collect(),
        _ => rest
            .iter()
            .enumerate()
            .map(|(j, p)| ((*p - q).length_squared(), j as u32))
            .collect(),
    };
    nn.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    nn.truncate(want);
    nn
}

impl Carry {
    /// Neighbours and weights of Gaussians at `rest_gaussians` on particles at `rest_particles`
    /// (both m, world), spacing `h_m` (module docs). Parallel over Gaussians, the same result for
    /// any thread count.
    ///
    /// # Panics
    /// When `rest_particles` is empty or holds more than `u32::MAX` particles.
    pub fn new(rest_gaussians: Vec<Vec3A>, rest_particles: Vec<Vec3A>, h_m: f32) -> Self {
        assert!(
            !rest_particles.is_empty() && u32::try_from(rest_particles.len()).is_ok(),
            "a carry needs 1..=u32::MAX particles"
        );
        let points: Vec<[f32; 3]> = rest_particles.iter().map(|p| p.to_array()).collect();
        let tree = (points.len() > 32).then(|| ImmutableKdTree::new_from_slice(&points));
        let k = CARRY_NEIGHBOURS.min(rest_particles.len());
        let rows: Vec<([u32; CARRY_NEIGHBOURS], [f32; CARRY_NEIGHBOURS])> = rest_gaussians
            .par_iter()
            .map(|&q| {
                let nn = nearest(tree.as_ref(), &rest_particles, q);
                let dist = |j: usize| (rest_particles[nn[j].1 as usize] - q).as_dvec3().length();
                let d_max = if nn.len() > k {
                    dist(k)
                } else {
                    dist(k - 1) + h_m as f64
                };
                let mut idx = [0u32; CARRY_NEIGHBOURS];
                let mut w = [0.0f64; CARRY_NEIGHBOURS];
                for s in 0..k {
                    idx[s] = nn[s].1;
                    w[s] = if d_max > 0.0 {
                        (1.0 - dist(s) / d_max).max(0.0).powi(2)
                    } else {
                        0.0
                    };
                }
                let mut total: f64 = w.iter().sum();
                if !(total > 0.0 && total.is_finite()) {
                    // Every neighbour as far as the (k+1)-th: equal shares.
                    w[..k].iter_mut().for_each(|v| *v = 1.0);
                    total = k as f64;
                }
                (idx, w.map(|v| (v / total) as f32))
            })
            .collect();
        let (neighbours, weights) = rows.into_iter().unzip();
        Self {
            rest_gaussians,
            rest_particles,
            neighbours,
            weights,
        }
    }

    /// Gaussians carried.
    pub fn len(&self) -> usize {
        self.rest_gaussians.len()
    }

    /// Whether no Gaussian is carried.
    pub fn is_empty(&self) -> bool {
        self.rest_gaussians.is_empty()
    }

    /// Gaussian `g`'s centre x_g (m) and deformation gradient F_g from particles `p`.
    ///
    /// # Panics
    /// When `g` is out of range or `p` is not the object's particles.
    #[inline]
    pub fn pose(&self, g: usize, p: &Particles) -> (Vec3A, Mat3A) {
        let xg = self.rest_gaussians[g];
        let mut x = Vec3A::ZERO;
        let mut f = Mat3A::ZERO;
        for (&j, &w) in self.neighbours[g].iter().zip(&self.weights[g]) {
            if w == 0.0 {
                continue;
            }
            let j = j as usize;
            // The total deformation: the plastic part too (`mpm::plastic_flow`).
            let fj = p.f[j] * p.f_plastic[j];
            x += (p.x[j] + fj * (xg - self.rest_particles[j])) * w;
            f += fj * w;
        }
        (x, f)
    }

    /// Makes the current state the rest state (when an object becomes rigid): bakes each
    /// Gaussian's F_g into its rest covariance `sigma0` (`[G]`), and takes the carried centres and
    /// the particles' positions as the new X_g and X_j⁰. The caller then sets every F_j and
    /// F_p,j to the identity; neighbours and weights are kept.
    pub fn rebase(&mut self, p: &Particles, sigma0: &mut [Mat3A]) {
        let identity = |f: &[Mat3A]| f.iter().all(|f| *f == Mat3A::IDENTITY);
        if p.x == self.rest_particles && identity(&p.f) && identity(&p.f_plastic) {
            return; // at rest already: x_g = X_g exactly (the weighted sum would round)
        }
        let poses: Vec<(Vec3A, Mat3A)> = (0..self.len())
            .into_par_iter()
            .map(|g| self.pose(g, p))
            .collect();
        for ((xg, s0), (x, f)) in self.rest_gaussians.iter_mut().zip(sigma0).zip(poses) {
            let f = if f.is_finite() { f } else { Mat3A::IDENTITY };
            *s0 = f * *s0 * f.transpose();
            *xg = x;
        }
        self.rest_particles.clone_from(&p.x);
    }
}

impl Body {
    /// Gaussians of this object (fill included): `gaussians`, `sigma0`, `visible` and
    /// `gaussian_offsets` are indexed by Gaussian, `particles`, `template` and `rest_offsets` by
    /// particle.
    pub fn gaussian_count(&self) -> usize {
        self.gaussians.len()
    }

    /// Gaussian `g`'s centre (m) and deformation gradient: a solid's placed by its pose
    /// (x + R μ_b, R); a deformable object's particle's without a carry, the carried ones with it.
    ///
    /// # Panics
    /// When `g` is out of range.
    #[inline]
    pub fn gaussian_pose(&self, g: usize) -> (Vec3A, Mat3A) {
        if self.is_frozen() {
            let r = Mat3A::from_quat(self.rigid.orientation);
            return (
                self.rigid.com_m.as_vec3a() + r * self.gaussian_offsets[g],
                r,
            );
        }
        match &self.carry {
            Some(c) => c.pose(g, &self.particles),
            None => {
                let j = self.gaussian_particle[g] as usize;
                let p = &self.particles;
                (p.x[j], p.f[j] * p.f_plastic[j])
            }
        }
    }
}
