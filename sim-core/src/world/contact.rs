//! Object-object contact at the COM level (the paper's stage 2, eqs. 3-6, written as the standard
//! impulse law; docs/com-layer.md maps one to the other).
//!
//! Broad phase: bounding spheres (eq. 3: |c_i - c_j| <= r_i + r_j) and boxes. Narrow phase: the
//! overlap of the two objects' occupied grid cells, so a donut and a vase collide where their
//! particles meet. The contact zone of each object is its particles in cells the other occupies;
//! the contact point is the midpoint of the two zones' centroids, and the normal n (from A to B)
//! is the difference of the objects' outward normals there, each estimated as the direction from
//! the centroid of that object's particles within 3 cells of the point to the point.
//!
//! Response, for approaching pairs only (v_rel·n < 0, v_rel = v_B - v_A at the contact point):
//! j_n = -(1 + e) v_rel·n / (1/m_A + 1/m_B + n·[(I_A⁻¹ (r_A × n)) × r_A + (I_B⁻¹ (r_B × n)) × r_B]),
//! Coulomb friction j_t <= μ j_n against the tangential velocity, impulse J = j_n n + j_t t on B and
//! -J on A, at the contact point, so linear and angular momentum are both conserved.
//!
//! The world's contact pass (`World::resolve_contacts`, once per substep over every pair with an
//! awake object) and the impulse hand-out to rigid and deformable objects are at the end.

use glam::{DMat3, DVec3, IVec3};
use rayon::prelude::*;

use super::body::{self, Body, BodyState, measure};
use super::{World, coherence};
use crate::scene::{Method, ObjectKind};

/// A detected contact between bodies `a` and `b`.
#[derive(Debug, Clone, PartialEq)]
pub struct Contact {
    /// Unit normal from A to B.
    pub normal: DVec3,
    /// Contact point (m).
    pub point_m: DVec3,
    /// A's particles in cells B occupies.
    pub zone_a: Vec<u32>,
    /// B's particles in cells A occupies.
    pub zone_b: Vec<u32>,
}

#[inline]
fn cell(x: glam::Vec3A, inv_h: f32) -> IVec3 {
    (x * inv_h).floor().as_ivec3()
}

/// Broad phase: bounding spheres and boxes (expanded by `margin_m`) overlap.
pub fn broad_phase(a: &BodyState, b: &BodyState, margin_m: f64) -> bool {
    let d = (a.com_m - b.com_m).length();
    if d > a.radius_m + b.radius_m + margin_m {
        return false;
    }
    let m = DVec3::splat(margin_m);
    (a.aabb_m.0 - m).cmple(b.aabb_m.1).all() && (b.aabb_m.0 - m).cmple(a.aabb_m.1).all()
}

/// Narrow phase on occupied cells of size `cell_m`; `None` when no cell is shared.
pub fn narrow_phase(
    a: &Body,
    sa: &BodyState,
    b: &Body,
    sb: &BodyState,
    cell_m: f32,
) -> Option<Contact> {
    let inv_h = 1.0 / cell_m;
    // Only particles inside the boxes' overlap (grown by a cell) can share a cell, and the
    // normal below looks 3 cells around the contact point (which lies in that grown overlap):
    // one pass per body keeps the particles of the overlap grown by 4 cells, and everything
    // after works on those.
    let lo = sa.aabb_m.0.max(sb.aabb_m.0) - DVec3::splat(cell_m as f64);
    let hi = sa.aabb_m.1.min(sb.aabb_m.1) + DVec3::splat(cell_m as f64);
    let (lo3, hi3) = (
        (lo - DVec3::splat(3.0 * cell_m as f64)).as_vec3a(),
        (hi + DVec3::splat(3.0 * cell_m as f64)).as_vec3a(),
    );
    let near = |body: &Body| -> Vec<u32> {
        (0..body.particles.len() as u32)
            .filter(|&i| {
                let x = body.particles.x[i as usize];
                x.cmpge(lo3).all() && x.cmple(hi3).all()
            })
            .collect()
    };
    let (near_a, near_b) = (near(a), near(b));
    if near_a.is_empty() || near_b.is_empty() {
        return None;
    }
    let inside = |x: glam::Vec3A| {
        let x = x.as_dvec3();
        x.cmpge(lo).all() && x.cmple(hi).all()
    };
    // Occupied cells as a sorted, deduplicated list (binary search; no hashing).
    let cells_of = |body: &Body, near: &[u32]| -> Vec<[i32; 3]> {
        let mut c: Vec<[i32; 3]> = near
            .iter()
            .map(|&i| body.particles.x[i as usize])
            .filter(|x| inside(*x))
            .map(|x| cell(x, inv_h).to_array())
            .collect();
        c.sort_unstable();
        c.dedup();
        c
    };
    let cells_b = cells_of(b, &near_b);
    if cells_b.is_empty() {
        return None;
    }
    let zone = |body: &Body, near: &[u32], other: &[[i32; 3]]| -> Vec<u32> {
        near.iter()
            .copied()
            .filter(|&i| {
                let x = body.particles.x[i as usize];
                inside(x) && other.binary_search(&cell(x, inv_h).to_array()).is_ok()
            })
            .collect()
    };
    let zone_a = zone(a, &near_a, &cells_b);
    if zone_a.is_empty() {
        return None;
    }
    let cells_a = cells_of(a, &near_a);
    let zone_b = zone(b, &near_b, &cells_a);
    if zone_b.is_empty() {
        return None;
    }
    let centroid = |body: &Body, z: &[u32]| {
        let mut m = 0.0;
        let mut mx = DVec3::ZERO;
        for &i in z {
            let mi = body.particles.mass_kg[i as usize] as f64;
            m += mi;
            mx += body.particles.x[i as usize].as_dvec3() * mi;
        }
        mx / m.max(f64::MIN_POSITIVE)
    };
    let ca = centroid(a, &zone_a);
    let cb = centroid(b, &zone_b);
    let point = (ca + cb) * 0.5;
    // Local-centroid normals: each object's particles within 3 cells of the contact point lie
    // mostly behind its surface, so point - their centroid is its outward normal there. Robust
    // even when the zones hold a handful of particles (zone centroids alone are not).
    let reach2 = (3.0 * cell_m as f64).powi(2);
    let outward = |body: &Body, near: &[u32]| {
        let mut m = 0.0;
        let mut mx = DVec3::ZERO;
        for &i in near {
            let (x, mi) = (
                body.particles.x[i as usize],
                body.particles.mass_kg[i as usize],
            );
            let x = x.as_dvec3();
            if (x - point).length_squared() <= reach2 {
                m += mi as f64;
                mx += x * mi as f64;
            }
        }
        if m > 0.0 {
            (point - mx / m).try_normalize()
        } else {
            None
        }
    };
    let normal = match (outward(a, &near_a), outward(b, &near_b)) {
        (Some(na), Some(nb)) => (na - nb).try_normalize(),
        (Some(na), None) => Some(na),
        (None, Some(nb)) => Some(-nb),
        (None, None) => None,
    }
    .or_else(|| (cb - ca).try_normalize())
    .or_else(|| (sb.com_m - sa.com_m).try_normalize())
    .unwrap_or(DVec3::Z);
    Some(Contact {
        normal,
        point_m: point,
        zone_a,
        zone_b,
    })
}

/// Per-body quantities the impulse law needs.
#[derive(Debug, Clone, Copy)]
pub struct Dynamics {
    /// COM (m).
    pub com_m: DVec3,
    /// COM velocity (m/s).
    pub velocity_m_s: DVec3,
    /// Angular velocity (rad/s).
    pub omega_rad_s: DVec3,
    /// 1/m (zero: immovable).
    pub inverse_mass: f64,
    /// I⁻¹ about the COM (zero: immovable).
    pub inverse_inertia: DMat3,
}

impl Dynamics {
    fn point_velocity(&self, p: DVec3) -> DVec3 {
        self.velocity_m_s + self.omega_rad_s.cross(p - self.com_m)
    }

    fn effective(&self, p: DVec3, dir: DVec3) -> f64 {
        let r = p - self.com_m;
        self.inverse_mass + dir.dot((self.inverse_inertia * r.cross(dir)).cross(r))
    }
}

/// The impulse on B (−it on A) for a contact at `point` with normal `n` (A to B), restitution
/// `e` and friction `mu`; `None` when the bodies are not approaching there. Approach speeds
/// below `resting_speed_m_s` are treated as resting contact (e = 0), so gravity's per-substep
/// velocity does not make resting objects bounce.
pub fn impulse(
    a: &Dynamics,
    b: &Dynamics,
    point: DVec3,
    n: DVec3,
    e: f64,
    mu: f64,
    resting_speed_m_s: f64,
) -> Option<DVec3> {
    let v_rel = b.point_velocity(point) - a.point_velocity(point);
    let vn = v_rel.dot(n);
    if vn >= 0.0 {
        return None;
    }
    let k_n = a.effective(point, n) + b.effective(point, n);
    if k_n <= 0.0 || !k_n.is_finite() {
        return None;
    }
    let e = if -vn < resting_speed_m_s { 0.0 } else { e };
    let jn = -(1.0 + e) * vn / k_n;
    let vt = v_rel - n * vn;
    let mut j = n * jn;
    if let Some(t) = vt.try_normalize() {
        let k_t = a.effective(point, t) + b.effective(point, t);
        if k_t > 0.0 {
            // Sticking needs |vt| / k_t; Coulomb caps it at mu j_n.
            let jt = (vt.length() / k_t).min(mu * jn);
            j -= t * jt;
        }
    }
    j.is_finite().then_some(j)
}

impl World {
    fn dynamics(&self, k: usize, s: &BodyState) -> Dynamics {
        let b = &self.bodies[k];
        if b.kind == ObjectKind::Rigid {
            let rs = &b.rigid;
            Dynamics {
                com_m: rs.com_m,
                velocity_m_s: rs.velocity_m_s,
                omega_rad_s: rs.omega_rad_s,
                inverse_mass: 1.0 / rs.mass_kg.max(f64::MIN_POSITIVE),
                inverse_inertia: body::inverse_or_zero(b.rigid_world_inertia()),
            }
        } else {
            Dynamics {
                com_m: s.com_m,
                velocity_m_s: if b.kind == ObjectKind::Static {
                    DVec3::ZERO
                } else {
                    s.velocity_m_s
                },
                omega_rad_s: if b.kind == ObjectKind::Static {
                    DVec3::ZERO
                } else {
                    s.angular_velocity()
                },
                inverse_mass: b.inverse_mass(s),
                inverse_inertia: b.inverse_inertia(s),
            }
        }
    }

    /// Step 2 and 3 of a COM substep (module docs): every pair of objects, one of them awake,
    /// through the broad and narrow phase; an approaching contact gets the impulse law's
    /// impulse, the zone and the object-level state ([`super::coherence`]). Pairs of
    /// deformable objects are left to the grid in the `mpm` and `multi-field` baselines.
    pub(super) fn resolve_contacts(&mut self, dt: f64) {
        let n = self.bodies.len();
        if n < 2 {
            return;
        }
        let dx = self.dx_m();
        // Static and sleeping objects do not move: their state is measured once and cached
        // (cleared when they wake or are edited).
        // Awake objects get the broad phase's bounds only; the full state (inertia, angular
        // momentum) is measured for the objects of a pair that passes it.
        let mut states: Vec<(BodyState, bool)> = self
            .bodies
            .par_iter_mut()
            .map(|b| {
                if b.is_active() {
                    b.state_cache = None;
                    return (body::measure_bounds(&b.particles, dx), false);
                }
                let s = *b
                    .state_cache
                    .get_or_insert_with(|| measure(&b.particles, dx));
                (s, true)
            })
            .collect();
        let resting = 2.0 * self.gravity_m_s2.length() as f64 * dt;
        for i in 0..n {
            for j in i + 1..n {
                let (bi, bj) = (&self.bodies[i], &self.bodies[j]);
                if !(bi.is_active() || bj.is_active()) {
                    continue;
                }
                if self.settings.method != Method::Com
                    && bi.kind == ObjectKind::Deformable
                    && bj.kind == ObjectKind::Deformable
                {
                    continue; // the grid handles these in the baselines
                }
                if !broad_phase(&states[i].0, &states[j].0, dx as f64) {
                    continue;
                }
                for k in [i, j] {
                    if !states[k].1 {
                        states[k] = (measure(&self.bodies[k].particles, dx), true);
                    }
                }
                let (bi, bj) = (&self.bodies[i], &self.bodies[j]);
                let Some(c) = narrow_phase(bi, &states[i].0, bj, &states[j].0, dx) else {
                    continue;
                };
                self.bodies[i].contacts += 1;
                self.bodies[j].contacts += 1;
                for k in [i, j] {
                    self.bodies[k].wake_on_contact();
                }
                let (da, db) = (
                    self.dynamics(i, &states[i].0),
                    self.dynamics(j, &states[j].0),
                );
                let e = self.bodies[i].restitution.min(self.bodies[j].restitution) as f64;
                let mu = ((self.bodies[i].friction * self.bodies[j].friction) as f64).sqrt();
                let Some(jv) = impulse(&da, &db, c.point_m, c.normal, e, mu, resting) else {
                    continue;
                };
                self.stats.contact_impulses += 1;
                self.give_impulse(i, -jv, c.point_m, &c.zone_a);
                self.give_impulse(j, jv, c.point_m, &c.zone_b);
            }
        }
    }

    /// Gives impulse `j` (N s) at `point` (m) to object `k`: rigid objects through their rigid
    /// state, deformable ones through the particles of `zone` ([`super::coherence`]).
    pub(super) fn give_impulse(&mut self, k: usize, j: DVec3, point: DVec3, zone: &[u32]) {
        let b = &mut self.bodies[k];
        b.impulse_total_n_s += j.length();
        match b.kind {
            ObjectKind::Static => {}
            ObjectKind::Rigid => {
                let inv_i = body::inverse_or_zero(b.rigid_world_inertia());
                let rs = &mut b.rigid;
                rs.velocity_m_s += j / rs.mass_kg;
                rs.omega_rad_s += inv_i * (point - rs.com_m).cross(j);
                b.sync_rigid_particles();
            }
            ObjectKind::Deformable => coherence::apply_impulse(b, j, point, zone),
        }
    }
}
