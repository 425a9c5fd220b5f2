//! The impulse law of one contact patch between two deformable objects, on their object-level
//! (rigid) dynamics, each as the contact solver's [`SolverBody`]: one sequential-impulse step (Catto 2005) with an accumulated, clamped
//! impulse, restitution as a target separation speed, Coulomb friction as an isotropic cone, and
//! for resting patches a couple whose pressure centre stays inside the patch's footprint.

use glam::DVec3;

use super::narrow::Footprint;
use crate::contact::SolverBody;

/// A patch's accumulated impulse on B (−it on A): the force part `linear_n_s` (N s) at the
/// contact point and the couple `angular_n_m_s` (N m s) of a pressure centre away from it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Accumulated {
    /// Impulse at the contact point (N s).
    pub linear_n_s: DVec3,
    /// Couple (N m s).
    pub angular_n_m_s: DVec3,
}

impl Accumulated {
    pub fn scaled(self, f: f64) -> Self {
        Self {
            linear_n_s: self.linear_n_s * f,
            angular_n_m_s: self.angular_n_m_s * f,
        }
    }

    pub fn plus(self, o: Self) -> Self {
        Self {
            linear_n_s: self.linear_n_s + o.linear_n_s,
            angular_n_m_s: self.angular_n_m_s + o.angular_n_m_s,
        }
    }
}

/// What the law asks of one patch.
#[derive(Debug, Clone, Copy)]
pub struct PatchLaw<'a> {
    /// Contact point (m).
    pub point_m: DVec3,
    /// Unit normal from A to B.
    pub normal: DVec3,
    /// The relative normal velocity to reach (m/s): the restitution law's −e v_n for an impact,
    /// 0 at rest.
    pub target_vn_m_s: f64,
    /// Coulomb friction coefficient μ.
    pub friction: f64,
    /// Where a resting patch may press; `None` for an impact (no couple).
    pub footprint: Option<&'a Footprint>,
}

/// One sequential-impulse step of a patch: the change of its accumulated impulse `acc` that
/// brings the relative normal velocity at the point to the law's target and the tangential one
/// to zero, keeping the normal impulse λ = acc·n >= 0 and its tangential part in the Coulomb cone
/// (|j_t| <= μ λ). With a footprint (a resting patch) it also brings the relative angular
/// velocity to zero by a couple whose pressure centre stays inside the footprint and whose
/// twist stays within torsional friction (|h·n| <= μ λ × the footprint's mean arm). `None` when
/// nothing changes.
///
/// For one patch, approaching at v_n with no impulse yet, this is the impulse law
/// j_n = −(1 + e) v_n / (1/m_A + 1/m_B + n·[(I_A⁻¹ (r_A × n)) × r_A + (I_B⁻¹ (r_B × n)) × r_B]).
pub fn patch_impulse(
    a: &SolverBody,
    b: &SolverBody,
    law: &PatchLaw<'_>,
    acc: Accumulated,
) -> Option<Accumulated> {
    let (point, n, mu) = (law.point_m, law.normal, law.friction);
    let (ra, rb) = (point - a.com_m, point - b.com_m);
    let v_rel = b.velocity_at(rb) - a.velocity_at(ra);
    let vn = v_rel.dot(n);
    let k_n = a.response(ra, n, n) + b.response(rb, n, n);
    if k_n <= 0.0 || !k_n.is_finite() {
        return None;
    }
    let j = acc.linear_n_s;
    let lam_old = j.dot(n).max(0.0);
    let lam = (lam_old + (law.target_vn_m_s - vn) / k_n).max(0.0);
    let jt_old = j - n * j.dot(n);
    let mut jt = jt_old;
    let vt = v_rel - n * vn;
    if let Some(t) = vt.try_normalize() {
        let k_t = a.response(ra, t, t) + b.response(rb, t, t);
        if k_t > 0.0 {
            jt -= t * (vt.length() / k_t);
        }
    }
    if jt.length() > mu * lam {
        jt = jt.normalize_or_zero() * (mu * lam);
    }
    let dj = n * (lam - lam_old) + (jt - jt_old);
    let dh = match law.footprint {
        Some(footprint) => couple_change(a, b, law, footprint, dj, lam, acc),
        None => DVec3::ZERO,
    };
    let change = Accumulated {
        linear_n_s: dj,
        angular_n_m_s: dh,
    };
    (change.linear_n_s.is_finite()
        && change.angular_n_m_s.is_finite()
        && change != Accumulated::default())
    .then_some(change)
}

/// The change of a resting patch's couple (N m s) against the relative spin left after the
/// force change `dj`, with normal impulse `lam` ([`patch_impulse`]).
fn couple_change(
    a: &SolverBody,
    b: &SolverBody,
    law: &PatchLaw<'_>,
    footprint: &Footprint,
    dj: DVec3,
    lam: f64,
    acc: Accumulated,
) -> DVec3 {
    let (point, n) = (law.point_m, law.normal);
    let (ra, rb) = (point - a.com_m, point - b.com_m);
    let w_rel = (b.omega_rad_s + b.inverse_inertia * rb.cross(dj))
        - (a.omega_rad_s - a.inverse_inertia * ra.cross(dj));
    let k_w = a.inverse_inertia + b.inverse_inertia;
    let mut h = acc.angular_n_m_s;
    if k_w.determinant().abs() > 0.0 {
        h -= k_w.inverse() * w_rel;
    }
    let (h_n, h_t) = (n * h.dot(n), h - n * h.dot(n));
    let twist_max = law.friction * lam * footprint.mean_arm_m();
    let h_n = if h_n.length() > twist_max {
        h_n.normalize_or_zero() * twist_max
    } else {
        h_n
    };
    // Pressure centre d with d × (λ n) = h_t, so d = n × h_t / λ, kept inside the footprint.
    let h_t = if lam > 0.0 {
        let d = n.cross(h_t) / lam;
        let reach = d.try_normalize().map_or(0.0, |u| footprint.reach_m(u));
        let d = if d.length() > reach {
            d.normalize_or_zero() * reach
        } else {
            d
        };
        d.cross(n) * lam
    } else {
        DVec3::ZERO
    };
    h_n + h_t - acc.angular_n_m_s
}
