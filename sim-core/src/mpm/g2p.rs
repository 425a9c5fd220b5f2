//! Grid to particle (MLS-MPM G2P with APIC, Hu et al. 2018 eqs. 17 and 29): v = Σ w vi,
//! C = (4/dx²) Σ w vi (xi - xp)ᵀ, then F ← (I + dt C) F, the material's return mapping, and
//! x ← x + dt v. A particle whose new state would not be finite is left untouched and reported,
//! so a NaN never enters the state.

use glam::{Mat3A, Vec3A};
use rayon::prelude::*;

use super::binning::{BLOCK, BLOCK_NODES, Binning, REGION, REGION_NODES, STENCIL_SPAN};
use super::bspline::Stencil;
use super::grid::SparseGrid;
use super::p2g::region_index;
use super::particles::Particles;
use super::plastic_flow;
use crate::material::{ConstitutiveModel, Material};

/// One particle block's 6³ node velocities (m/s, relative to the reference velocity).
pub type VelocityRegion = [Vec3A; REGION_NODES];

/// What a G2P pass found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GatherReport {
    /// Largest particle speed after the update (m/s).
    pub max_speed_m_s: f32,
    /// Smallest index of a particle whose update was not finite (left unchanged).
    pub first_non_finite: Option<usize>,
}

/// Gathers grid velocities (relative to `v_ref`, m/s) into every particle and advances it by
/// `dt_s`.
#[allow(clippy::too_many_arguments)]
pub fn gather(
    particles: &mut Particles,
    bins: &Binning,
    grid: &SparseGrid,
    materials: &[Material],
    dx_m: f32,
    dt_s: f32,
    v_ref: Vec3A,
    regions: &mut Vec<VelocityRegion>,
) -> GatherReport {
    // Each particle block's 6³ node velocities, gathered once from its (up to 8) grid blocks, so
    // the per-particle loop reads one contiguous array.
    regions.resize(bins.blocks.len(), [Vec3A::ZERO; REGION_NODES]);
    regions
        .par_iter_mut()
        .zip(grid.pb_grid.par_iter())
        .for_each(|(region, neighbours)| {
            for rz in 0..REGION {
                for ry in 0..REGION {
                    for rx in 0..REGION {
                        let corner =
                            (rx >= 4) as usize + 2 * (ry >= 4) as usize + 4 * (rz >= 4) as usize;
                        let gb = neighbours[corner] as usize;
                        let l = (rx & 3) + 4 * (ry & 3) + 16 * (rz & 3);
                        region[rx + REGION * ry + REGION * REGION * rz] =
                            grid.velocity_m_s[gb * BLOCK_NODES + l];
                    }
                }
            }
        });
    let regions: &[VelocityRegion] = regions;
    let inv_dx = 1.0 / dx_m;
    let d_inv = 4.0 * inv_dx * inv_dx;
    let Particles {
        x,
        v,
        c,
        f,
        f_plastic,
        plastic,
        material,
        ..
    } = particles;
    let (speed2, bad) = (x, v, c, f, f_plastic, plastic, &*material, &bins.block_of)
        .into_par_iter()
        .enumerate()
        .map(|(p, (x, v, c, f, fp, plastic, mat, &b))| {
            let s = Stencil::new(*x, inv_dx);
            let origin = bins.blocks[b as usize].key * BLOCK;
            let local = (s.base - origin).as_uvec3();
            let first = region_index(local.x as usize, local.y as usize, local.z as usize);
            // The particle's 3³ nodes as one fixed-size window: one bounds check, not 27.
            let nodes: &[Vec3A; STENCIL_SPAN] = regions[b as usize][first..first + STENCIL_SPAN]
                .try_into()
                .expect("window length is STENCIL_SPAN");
            let v_old = *v - v_ref;
            // With u = vi - v_old and d = (i, j, k) - fx (cells): v = v_old + Σ w u and
            // C ∝ Σ w u dᵀ. Σ w d = 0, so subtracting the particle's previous velocity changes
            // nothing in exact arithmetic but keeps a uniform translation from leaking rounding
            // noise into C (and F). The weights are separable, so the sums contract one axis at a
            // time: along x per row of 3 nodes (with w and with w d), then along y per (k), then
            // along z, always in the same order.
            let wd = [
                s.w[0] * (Vec3A::ZERO - s.fx),
                s.w[1] * (Vec3A::ONE - s.fx),
                s.w[2] * (Vec3A::splat(2.0) - s.fx),
            ];
            // Per k: Σ_j wy (Σ_i wx u), Σ_j wdy (Σ_i wx u), Σ_j wy (Σ_i wdx u).
            let mut plane_w = [Vec3A::ZERO; 3];
            let mut plane_dy = [Vec3A::ZERO; 3];
            let mut plane_dx = [Vec3A::ZERO; 3];
            for k in 0..3usize {
                for j in 0..3usize {
                    let row = region_index(0, j, k);
                    let u = [
                        nodes[row] - v_old,
                        nodes[row + 1] - v_old,
                        nodes[row + 2] - v_old,
                    ];
                    let row_w = u[0] * s.w[0].x + u[1] * s.w[1].x + u[2] * s.w[2].x;
                    let row_d = u[0] * wd[0].x + u[1] * wd[1].x + u[2] * wd[2].x;
                    plane_w[k] += row_w * s.w[j].y;
                    plane_dy[k] += row_w * wd[j].y;
                    plane_dx[k] += row_d * s.w[j].y;
                }
            }
            let mut sum_u = Vec3A::ZERO;
            let mut col = [Vec3A::ZERO; 3];
            for k in 0..3usize {
                sum_u += plane_w[k] * s.w[k].z;
                col[0] += plane_dx[k] * s.w[k].z;
                col[1] += plane_dy[k] * s.w[k].z;
                col[2] += plane_w[k] * wd[k].z;
            }
            let new_v = v_old + sum_u;
            let new_c = Mat3A::from_cols(col[0], col[1], col[2]);
            let new_v = new_v + v_ref;
            // d above is in cells: (4/dx²) · dx = 4/dx.
            let new_c = new_c * (d_inv * dx_m);
            let trial_f = (Mat3A::IDENTITY + new_c * dt_s) * *f;
            let mut new_f = trial_f;
            let mut new_plastic = *plastic;
            materials[*mat as usize].project(&mut new_f, &mut new_plastic, dt_s);
            let new_fp = plastic_flow::after_return_mapping(trial_f, new_f, *fp);
            let new_x = *x + new_v * dt_s;
            // x · 0 is ±0 for finite x and NaN otherwise, so a sum of such products is zero
            // exactly when every component is finite (one test instead of one per vector).
            let probe = (new_x * 0.0 + new_v * 0.0)
                + (new_c.x_axis * 0.0 + new_c.y_axis * 0.0 + new_c.z_axis * 0.0)
                + (new_f.x_axis * 0.0 + new_f.y_axis * 0.0 + new_f.z_axis * 0.0)
                + Vec3A::splat(new_plastic * 0.0);
            if probe != Vec3A::ZERO {
                return (0.0f32, p);
            }
            *x = new_x;
            *v = new_v;
            *c = new_c;
            *f = new_f;
            *fp = new_fp;
            *plastic = new_plastic;
            (new_v.length_squared(), usize::MAX)
        })
        .reduce(|| (0.0, usize::MAX), |a, b| (a.0.max(b.0), a.1.min(b.1)));
    GatherReport {
        max_speed_m_s: speed2.sqrt(),
        first_non_finite: (bad != usize::MAX).then_some(bad),
    }
}
