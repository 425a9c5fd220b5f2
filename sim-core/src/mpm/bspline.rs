//! Quadratic B-spline weights of MLS-MPM (Hu et al. 2018, section 5; Stomakhin et al. 2013 eq.
//! 123). A particle at grid coordinate xp (in cells) touches the 3×3×3 nodes base + {0,1,2}³ with
//! base = floor(xp - 0.5); with fx = xp - base in [0.5, 1.5) the weights per axis are
//! 0.5 (1.5 - fx)², 0.75 - (fx - 1)², 0.5 (fx - 0.5)². They sum to 1 and reproduce linear
//! functions, and D = Σ w (xi - xp)(xi - xp)ᵀ = dx²/4 I, hence D⁻¹ = 4 / dx².

use glam::{IVec3, Vec3A};

/// Base node and per-axis weights of a particle at position `x_m` for cell size 1 / `inv_dx`.
#[derive(Debug, Clone, Copy)]
pub struct Stencil {
    /// Grid index of the stencil's first node.
    pub base: IVec3,
    /// Particle position relative to `base`, in cells (each component in [0.5, 1.5)).
    pub fx: Vec3A,
    /// Weights per axis for offsets 0, 1, 2.
    pub w: [Vec3A; 3],
}

impl Stencil {
    /// The stencil of a particle at `x_m`.
    #[inline]
    pub fn new(x_m: Vec3A, inv_dx: f32) -> Self {
        let xp = x_m * inv_dx;
        let base_f = (xp - Vec3A::splat(0.5)).floor();
        let fx = xp - base_f;
        let w = [
            0.5 * (Vec3A::splat(1.5) - fx) * (Vec3A::splat(1.5) - fx),
            Vec3A::splat(0.75) - (fx - Vec3A::ONE) * (fx - Vec3A::ONE),
            0.5 * (fx - Vec3A::splat(0.5)) * (fx - Vec3A::splat(0.5)),
        ];
        Self {
            base: base_f.as_ivec3(),
            fx,
            w,
        }
    }

    /// Weight of node offset (i, j, k), each in 0..3.
    #[inline]
    pub fn weight(&self, i: usize, j: usize, k: usize) -> f32 {
        self.w[i].x * self.w[j].y * self.w[k].z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_sum_to_one_and_reproduce_position() {
        let s = Stencil::new(Vec3A::new(0.123, -0.456, 0.789), 64.0);
        let mut sum = 0.0;
        let mut first = Vec3A::ZERO;
        for i in 0..3 {
            for j in 0..3 {
                for k in 0..3 {
                    let w = s.weight(i, j, k);
                    sum += w;
                    first += w * (Vec3A::new(i as f32, j as f32, k as f32) - s.fx);
                }
            }
        }
        assert!((sum - 1.0).abs() < 1e-6);
        assert!(first.length() < 1e-6);
    }
}
