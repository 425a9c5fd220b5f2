//! Multi-velocity-field contact (Bardenhagen, Brackbill and Sulsky 2000, "The material-point
//! method for granular materials", CMAME 187; the `multi-field` baseline of the COM layer).
//!
//! Every object scatters onto its own field of the shared node lattice (its own [`SparseGrid`];
//! all grids share the origin and the cell size dx, so equal block keys are the same nodes). At a
//! node where two or more fields have mass, with field masses m_k and velocities v_k:
//! - centre-of-mass velocity v_cm = Σ m_k v_k / Σ m_k;
//! - outward normal of field k, n_k = normalize(∇m_others - ∇m_k), mass gradients by central
//!   differences of node masses (for two fields n_2 = -n_1 exactly);
//! - only approaching fields change: with Δv = v_k - v_cm and a = Δv·n_k > 0, the normal part is
//!   removed and Coulomb friction takes at most μ a off the tangential part t = Δv - a n_k:
//!   v_k ← v_cm when |t| <= μ a (stick), else v_k ← v_k - a n_k - μ a t/|t|.
//!
//! For two fields the corrections are equal and opposite in momentum, so the pair's total
//! momentum is unchanged; with three or more fields meeting at one node that holds only
//! approximately. Colliders are applied again at corrected nodes. Friction μ at a node is
//! sqrt(μ_k μ_j) with j the heaviest other field there (the COM layer's rule).
//!
//! Corrections are computed in parallel from read-only grids, then written in a fixed order, so
//! the result does not depend on the thread count.

use glam::{IVec3, Vec3A};
use rayon::prelude::*;

use super::binning::{BLOCK, BLOCK_NODES, pack};
use super::grid::SparseGrid;
use crate::collider::Collider;

/// One object's field for [`couple`].
#[derive(Debug)]
pub struct Field<'a> {
    /// The object's grid after P2G and the grid update (velocities relative to `v_ref_m_s`).
    pub grid: &'a mut SparseGrid,
    /// The grid's reference velocity (m/s).
    pub v_ref_m_s: Vec3A,
    /// The object's Coulomb friction coefficient μ (>= 0).
    pub friction: f32,
}

/// What [`couple`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CouplingReport {
    /// Nodes where two or more fields had mass.
    pub shared_nodes: usize,
    /// Field-node velocities corrected (approaching fields).
    pub corrected: usize,
}

/// Node mass (kg) of `grid` at global node index `node`, 0 where no block exists.
fn mass_at(grid: &SparseGrid, node: IVec3) -> f32 {
    let key = node.div_euclid(IVec3::splat(BLOCK));
    let Ok(b) = grid.keys.binary_search_by_key(&pack(key), |k| pack(*k)) else {
        return 0.0;
    };
    let l = node.rem_euclid(IVec3::splat(BLOCK));
    grid.mass_kg[b * BLOCK_NODES + (l.x + 4 * l.y + 16 * l.z) as usize]
}

/// Mass gradient (kg per cell) of `grid` at `node` by central differences.
fn mass_gradient(grid: &SparseGrid, node: IVec3) -> Vec3A {
    let d = |e: IVec3| mass_at(grid, node + e) - mass_at(grid, node - e);
    0.5 * Vec3A::new(d(IVec3::X), d(IVec3::Y), d(IVec3::Z))
}

/// A corrected velocity: field, node offset in its velocity array, new relative velocity (m/s).
type Correction = (usize, usize, Vec3A);

/// Applies multi-field contact at every node shared by two or more `fields` (cell size `dx_m`,
/// `colliders` re-applied at corrected nodes at time `time_s`).
pub fn couple(
    fields: &mut [Field<'_>],
    dx_m: f32,
    colliders: &[Collider],
    time_s: f64,
) -> CouplingReport {
    if fields.len() < 2 {
        return CouplingReport::default();
    }
    // Blocks present in two or more fields, grouped by key in key order.
    let mut entries: Vec<(u64, usize, usize)> = fields
        .iter()
        .enumerate()
        .flat_map(|(f, fl)| {
            fl.grid
                .keys
                .iter()
                .enumerate()
                .map(move |(b, k)| (pack(*k), f, b))
        })
        .collect();
    entries.sort_unstable();
    let groups: Vec<&[(u64, usize, usize)]> = entries
        .chunk_by(|a, b| a.0 == b.0)
        .filter(|g| g.len() >= 2)
        .collect();
    let view: Vec<(&SparseGrid, Vec3A, f32)> = fields
        .iter()
        .map(|f| (&*f.grid, f.v_ref_m_s, f.friction))
        .collect();
    let per_group: Vec<(usize, Vec<Correction>)> = groups
        .par_iter()
        .map(|group| {
            let (_, f0, b0) = group[0];
            let origin = view[f0].0.keys[b0] * BLOCK;
            let mut shared = 0;
            let mut out = Vec::new();
            for l in 0..BLOCK_NODES {
                let present: Vec<(usize, usize, f32)> = group
                    .iter()
                    .map(|&(_, f, b)| {
                        (
                            f,
                            b * BLOCK_NODES + l,
                            view[f].0.mass_kg[b * BLOCK_NODES + l],
                        )
                    })
                    .filter(|&(_, _, m)| m > 0.0)
                    .collect();
                if present.len() < 2 {
                    continue;
                }
                shared += 1;
                let lv = IVec3::new(l as i32 & 3, (l as i32 >> 2) & 3, l as i32 >> 4);
                let node = origin + lv;
                let grads: Vec<Vec3A> = present
                    .iter()
                    .map(|&(f, _, _)| mass_gradient(view[f].0, node))
                    .collect();
                let grad_sum: Vec3A = grads.iter().copied().sum();
                let abs_v = |f: usize, i: usize| view[f].0.velocity_m_s[i] + view[f].1;
                let total_m: f32 = present.iter().map(|p| p.2).sum();
                let v_cm = present
                    .iter()
                    .map(|&(f, i, m)| abs_v(f, i) * m)
                    .sum::<Vec3A>()
                    / total_m;
                for (k, &(f, i, _)) in present.iter().enumerate() {
                    let outward = (grad_sum - grads[k]) - grads[k];
                    let Some(n) = outward.try_normalize() else {
                        continue;
                    };
                    let v = abs_v(f, i);
                    let dv = v - v_cm;
                    let a = dv.dot(n);
                    if a <= 0.0 {
                        continue; // separating or sliding: free
                    }
                    let heaviest_other = present
                        .iter()
                        .enumerate()
                        .filter(|&(j, _)| j != k)
                        .max_by(|x, y| x.1.2.total_cmp(&y.1.2))
                        .map_or(0.0, |(_, p)| view[p.0].2);
                    let mu = (view[f].2 * heaviest_other).max(0.0).sqrt();
                    let t = dv - a * n;
                    let t_len = t.length();
                    let mut new_v = if t_len <= mu * a {
                        v_cm
                    } else {
                        v - a * n - t * (mu * a / t_len)
                    };
                    let x = node.as_vec3a() * dx_m;
                    for c in colliders {
                        if c.contact_normal(x, time_s).is_some() {
                            new_v = c.apply(x, new_v, time_s);
                        }
                    }
                    if new_v.is_finite() {
                        out.push((f, i, new_v - view[f].1));
                    }
                }
            }
            (shared, out)
        })
        .collect();
    let mut report = CouplingReport::default();
    for (shared, corrections) in per_group {
        report.shared_nodes += shared;
        report.corrected += corrections.len();
        for (f, i, v) in corrections {
            fields[f].grid.velocity_m_s[i] = v;
        }
    }
    report
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mpm::binning::Binning;

    /// A grid with the blocks of the given particle positions, node mass `mass(node)` and
    /// velocity `v` everywhere there is mass.
    fn field_grid(x: &[Vec3A], inv_dx: f32, mass: impl Fn(IVec3) -> f32, v: Vec3A) -> SparseGrid {
        let mut bins = Binning::default();
        bins.rebuild(x, inv_dx).expect("bins");
        let mut g = SparseGrid::default();
        g.rebuild(&bins);
        for (b, key) in g.keys.clone().iter().enumerate() {
            for l in 0..BLOCK_NODES {
                let lv = IVec3::new(l as i32 & 3, (l as i32 >> 2) & 3, l as i32 >> 4);
                let m = mass(*key * BLOCK + lv);
                g.mass_kg[b * BLOCK_NODES + l] = m;
                g.velocity_m_s[b * BLOCK_NODES + l] = if m > 0.0 { v } else { Vec3A::ZERO };
            }
        }
        g
    }

    fn momentum(g: &SparseGrid, v_ref: Vec3A) -> Vec3A {
        g.mass_kg
            .iter()
            .zip(&g.velocity_m_s)
            .map(|(m, v)| (*v + v_ref) * *m)
            .sum()
    }

    /// Two fields overlapping in the plane x = 8 (nodes), approaching along x: the normal
    /// velocity is removed at the shared nodes, momentum is unchanged, and with μ = 0 the
    /// tangential velocity stays.
    #[test]
    fn approaching_fields_lose_normal_velocity_and_conserve_momentum() {
        let inv_dx = 1.0;
        let pts: Vec<Vec3A> = (0..16)
            .flat_map(|i| (2..6).map(move |j| Vec3A::new(i as f32 + 0.5, j as f32 + 0.5, 3.5)))
            .collect();
        // Left body: mass on nodes x <= 8; right body: x >= 8; masses differ (1 and 3 kg/node).
        let ramp = |lo: bool, m: f32| {
            move |n: IVec3| {
                let inside = if lo { n.x <= 8 } else { n.x >= 8 };
                if inside && (1..=7).contains(&n.y) && (2..=5).contains(&n.z) {
                    m * if n.x == 8 { 0.5 } else { 1.0 }
                } else {
                    0.0
                }
            }
        };
        let v_a = Vec3A::new(2.0, 0.5, 0.0);
        let v_b = Vec3A::new(-1.0, 0.0, 0.0);
        let mut a = field_grid(&pts, inv_dx, ramp(true, 1.0), v_a);
        let mut b = field_grid(&pts, inv_dx, ramp(false, 3.0), v_b - Vec3A::X);
        let before = momentum(&a, Vec3A::ZERO) + momentum(&b, Vec3A::X);
        let mut fields = [
            Field {
                grid: &mut a,
                v_ref_m_s: Vec3A::ZERO,
                friction: 0.0,
            },
            Field {
                grid: &mut b,
                v_ref_m_s: Vec3A::X,
                friction: 0.0,
            },
        ];
        let r = couple(&mut fields, 1.0, &[], 0.0);
        assert!(
            r.shared_nodes > 0 && r.corrected == 2 * r.shared_nodes,
            "{r:?}"
        );
        let after = momentum(&a, Vec3A::ZERO) + momentum(&b, Vec3A::X);
        assert!(
            (after - before).length() < 1e-4 * before.length(),
            "{before} {after}"
        );
        // Inside the contact plane (away from its edges, where the normal tilts) field a moves
        // with the common normal velocity and keeps its tangential one (μ = 0).
        let mut checked = 0;
        for y in 2..=6 {
            for z in 3..=4 {
                let node = IVec3::new(8, y, z);
                let key = node.div_euclid(IVec3::splat(BLOCK));
                let bi = a.keys.iter().position(|k| *k == key).expect("block");
                let l = node.rem_euclid(IVec3::splat(BLOCK));
                let v = a.velocity_m_s[bi * BLOCK_NODES + (l.x + 4 * l.y + 16 * l.z) as usize];
                // v_cm.x = (0.5 kg · 2 m/s + 1.5 kg · (-1 m/s)) / 2 kg = -0.25 m/s.
                assert!((v.x + 0.25).abs() < 1e-5, "{node}: {v}");
                assert!((v.y - 0.5).abs() < 1e-6, "{node}: {v}");
                checked += 1;
            }
        }
        assert_eq!(checked, 10);
    }

    /// Separating fields are left alone.
    #[test]
    fn separating_fields_are_untouched() {
        let pts = [Vec3A::new(4.5, 4.5, 4.5)];
        let m = |lo: bool| {
            move |n: IVec3| {
                let inside = if lo { n.x <= 5 } else { n.x >= 5 };
                if inside { 1.0 } else { 0.0 }
            }
        };
        let mut a = field_grid(&pts, 1.0, m(true), Vec3A::new(-1.0, 0.0, 0.0));
        let mut b = field_grid(&pts, 1.0, m(false), Vec3A::new(1.0, 0.0, 0.0));
        let (a0, b0) = (a.velocity_m_s.clone(), b.velocity_m_s.clone());
        let r = couple(
            &mut [
                Field {
                    grid: &mut a,
                    v_ref_m_s: Vec3A::ZERO,
                    friction: 0.5,
                },
                Field {
                    grid: &mut b,
                    v_ref_m_s: Vec3A::ZERO,
                    friction: 0.5,
                },
            ],
            1.0,
            &[],
            0.0,
        );
        assert!(r.shared_nodes > 0);
        assert_eq!(r.corrected, 0);
        assert_eq!((a.velocity_m_s, b.velocity_m_s), (a0, b0));
    }
}
