//! Particle to grid (MLS-MPM P2G, Hu et al. 2018 eq. 29 with the APIC affine term): each particle
//! adds mass m w and momentum w (m v + (m C - dt V0 (4/dx²) τ) (xi - xp)) to its 27 nodes, with τ
//! the Kirchhoff stress of its material plus its Kelvin–Voigt damping J η_d (C + Cᵀ). Work is
//! per particle block into a private 6³ scratch region (no atomics); [`super::grid_update`] sums
//! the regions in a fixed order.

use glam::{Mat3A, Vec4};
use rayon::prelude::*;

use super::binning::{BLOCK, Binning, REGION, REGION_NODES, STENCIL_SPAN};
use super::bspline::Stencil;
use super::particles::Particles;
use super::prefetch::prefetch;
use crate::material::{ConstitutiveModel, Material};

/// One particle block's scattered contributions: xyz = momentum (kg m/s), w = mass (kg).
pub type Region = [Vec4; REGION_NODES];

/// Scatters every particle block into its region of `scratch` (resized to the block count).
/// Momentum is taken relative to `v_ref` (m/s), the frame the grid works in (see
/// [`super::solver`]).
pub fn scatter(
    particles: &Particles,
    bins: &Binning,
    materials: &[Material],
    dx_m: f32,
    dt_s: f32,
    v_ref: glam::Vec3A,
    scratch: &mut Vec<Region>,
) {
    let inv_dx = 1.0 / dx_m;
    let d_inv = 4.0 * inv_dx * inv_dx;
    scratch.resize(bins.blocks.len(), [Vec4::ZERO; REGION_NODES]);
    // Every array cut to the same length N, so one bounds check per particle covers them all.
    let n = particles.len();
    let Particles {
        x,
        v,
        c,
        f,
        plastic,
        mass_kg,
        volume0_m3,
        material,
        ..
    } = particles;
    let (x, v, c, f, plastic, mass_kg, volume0_m3, material) = (
        &x[..n],
        &v[..n],
        &c[..n],
        &f[..n],
        &plastic[..n],
        &mass_kg[..n],
        &volume0_m3[..n],
        &material[..n],
    );
    scratch
        .par_iter_mut()
        .zip(bins.blocks.par_iter())
        .for_each(|(region, pb)| {
            region.fill(Vec4::ZERO);
            let origin = pb.key * BLOCK;
            // Stresses four particles at a time (one SIMD lane each) where the four share a
            // material; a lane's stress is bit-identical to the one-particle call either way.
            let (start, end) = (pb.start as usize, pb.end as usize);
            for (gi, group) in bins.order[start..end].chunks(4).enumerate() {
                // The order is by block, so particle data is read at scattered addresses (F and
                // C span two cache lines): ask for the group two ahead, in this block or the
                // next, while this one computes.
                let ahead = (start + gi * 4 + 8).min(bins.order.len());
                for &p in bins.order[ahead..].iter().take(4) {
                    let p = p as usize;
                    prefetch(&f[p]);
                    prefetch(&f[p].z_axis);
                    prefetch(&c[p]);
                    prefetch(&c[p].z_axis);
                    prefetch(&x[p]);
                    prefetch(&v[p]);
                    prefetch(&mass_kg[p]);
                    prefetch(&volume0_m3[p]);
                    prefetch(&plastic[p]);
                    prefetch(&material[p]);
                }
                let lane = |l: usize| group[l] as usize;
                let m0 = material[lane(0)];
                let tau = if group.len() == 4 && group.iter().all(|&p| material[p as usize] == m0) {
                    materials[m0 as usize].kirchhoff_stress_x4(
                        &std::array::from_fn(|l| f[lane(l)]),
                        &std::array::from_fn(|l| plastic[lane(l)]),
                    )
                } else {
                    std::array::from_fn(|l| {
                        group.get(l).map_or(Mat3A::ZERO, |&p| {
                            let p = p as usize;
                            materials[material[p] as usize].kirchhoff_stress(f[p], plastic[p])
                        })
                    })
                };
                for (l, &p) in group.iter().enumerate() {
                    let p = p as usize;
                    let m = mass_kg[p];
                    // Kelvin–Voigt damping: J η_d (C + Cᵀ) in parallel with the model's stress.
                    let eta = materials[material[p] as usize]
                        .elastic()
                        .damping_viscosity_pa_s;
                    let tau = if eta > 0.0 {
                        tau[l] + (c[p] + c[p].transpose()) * (eta * f[p].determinant())
                    } else {
                        tau[l]
                    };
                    let affine: Mat3A = tau * (-dt_s * volume0_m3[p] * d_inv) + c[p] * m;
                    scatter_particle(region, origin, x[p], v[p] - v_ref, m, affine, dx_m, inv_dx);
                }
            }
        });
}

/// Adds one particle's mass and APIC momentum, relative velocity `v_rel` (m/s), mass `m` (kg)
/// and affine matrix `affine` (kg/s), to its 3³ nodes in `region` (whose first node is `origin`).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn scatter_particle(
    region: &mut Region,
    origin: glam::IVec3,
    x_m: glam::Vec3A,
    v_rel: glam::Vec3A,
    m: f32,
    affine: Mat3A,
    dx_m: f32,
    inv_dx: f32,
) {
    // Momentum at offset o: w (m v + affine (o - fx) dx) = w (q + A o) with A = affine dx.
    // Carried as Vec4 with the mass in w (the A columns have w = 0), so one product per node
    // gives (momentum, mass) · weight.
    let s = Stencil::new(x_m, inv_dx);
    let a = affine * dx_m;
    let q = v_rel * m - a * s.fx;
    let q4 = Vec4::from((q, m));
    let (ax, ay, az) = (
        Vec4::from((a.x_axis, 0.0)),
        Vec4::from((a.y_axis, 0.0)),
        Vec4::from((a.z_axis, 0.0)),
    );
    let local = (s.base - origin).as_uvec3();
    let first = region_index(local.x as usize, local.y as usize, local.z as usize);
    // The particle's 3³ nodes as one fixed-size window: one bounds check, not 27.
    let nodes: &mut [Vec4; STENCIL_SPAN] = (&mut region[first..first + STENCIL_SPAN])
        .try_into()
        .expect("window length is STENCIL_SPAN");
    for k in 0..3 {
        for j in 0..3 {
            let wjk = s.w[j].y * s.w[k].z;
            let qjk = q4 + ay * j as f32 + az * k as f32;
            let row = region_index(0, j, k);
            nodes[row] += qjk * (s.w[0].x * wjk);
            nodes[row + 1] += (qjk + ax) * (s.w[1].x * wjk);
            nodes[row + 2] += (qjk + ax * 2.0) * (s.w[2].x * wjk);
        }
    }
}

/// Region-local index of node (x, y, z), each in 0..REGION.
#[inline]
pub fn region_index(x: usize, y: usize, z: usize) -> usize {
    x + REGION * y + REGION * REGION * z
}
