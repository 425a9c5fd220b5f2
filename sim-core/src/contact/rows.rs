//! What the contact solvers work on: bodies and contact points as they see them, and the
//! algebra of one contact row they share (relative velocity, impulses on a pair, effective mass).

use glam::{DMat3, DVec3};

/// A body as the solver sees it. Immovable bodies (static objects, colliders) have zero inverse
/// mass and inertia.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverBody {
    /// COM (m).
    pub com_m: DVec3,
    /// COM velocity (m/s).
    pub velocity_m_s: DVec3,
    /// Angular velocity (rad/s).
    pub omega_rad_s: DVec3,
    /// 1/m (1/kg).
    pub inverse_mass: f64,
    /// World I⁻¹ about the COM (1/(kg m²)).
    pub inverse_inertia: DMat3,
    /// Split-impulse pseudo-velocity (m/s).
    pub push_m_s: DVec3,
    /// Split-impulse pseudo angular velocity (rad/s).
    pub push_rad_s: DVec3,
    /// The velocity change from external forces over the substep (m/s; gravity g dt), already
    /// in `velocity_m_s`: the soft step ([`super::soft_step`]) spreads it over its steps.
    pub external_m_s: DVec3,
}

impl SolverBody {
    /// A body that nothing moves, with surface velocity `velocity_m_s` (moving colliders).
    pub fn immovable(velocity_m_s: DVec3) -> Self {
        Self::new(DVec3::ZERO, velocity_m_s, DVec3::ZERO, 0.0, DMat3::ZERO)
    }

    /// A body with the given state.
    pub fn new(
        com_m: DVec3,
        velocity_m_s: DVec3,
        omega_rad_s: DVec3,
        inverse_mass: f64,
        inverse_inertia: DMat3,
    ) -> Self {
        Self {
            com_m,
            velocity_m_s,
            omega_rad_s,
            inverse_mass,
            inverse_inertia,
            push_m_s: DVec3::ZERO,
            push_rad_s: DVec3::ZERO,
            external_m_s: DVec3::ZERO,
        }
    }

    /// Whether no impulse can move it (zero inverse mass and inertia).
    pub(crate) fn is_immovable(&self) -> bool {
        self.inverse_mass == 0.0 && self.inverse_inertia == DMat3::ZERO
    }

    /// The velocity (m/s) of the body's point at `r` (m) from its COM.
    pub(crate) fn velocity_at(&self, r: DVec3) -> DVec3 {
        self.velocity_m_s + self.omega_rad_s.cross(r)
    }

    pub(super) fn push_at(&self, r: DVec3) -> DVec3 {
        self.push_m_s + self.push_rad_s.cross(r)
    }

    /// Takes impulse `p` (N s) at `r` (m) from its COM.
    pub(crate) fn apply(&mut self, r: DVec3, p: DVec3) {
        self.velocity_m_s += p * self.inverse_mass;
        self.omega_rad_s += self.inverse_inertia * r.cross(p);
    }

    /// Takes angular impulse `l` (N m s) about its COM.
    pub(crate) fn apply_angular(&mut self, l: DVec3) {
        self.omega_rad_s += self.inverse_inertia * l;
    }

    pub(super) fn apply_push(&mut self, r: DVec3, p: DVec3) {
        self.push_m_s += p * self.inverse_mass;
        self.push_rad_s += self.inverse_inertia * r.cross(p);
    }

    /// d·(I⁻¹ (r × e)) × r + 1/m: the response along d to a unit impulse along e at r.
    pub(crate) fn response(&self, r: DVec3, d: DVec3, e: DVec3) -> f64 {
        if self.inverse_mass == 0.0 {
            return 0.0;
        }
        self.inverse_mass * d.dot(e) + d.dot((self.inverse_inertia * r.cross(e)).cross(r))
    }
}

/// One contact point between bodies `a` and `b`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactPoint {
    /// Body indices into the solver's body slice.
    pub a: usize,
    /// Second body.
    pub b: usize,
    /// Contact point (m).
    pub point_m: DVec3,
    /// Unit normal from A to B.
    pub normal: DVec3,
    /// Separation along the normal (m): negative when penetrating.
    pub separation_m: f64,
    /// Restitution e of the pair.
    pub restitution: f64,
    /// Coulomb friction μ of the pair (finite: a sticky surface is [`super::STICKY_FRICTION`]).
    pub friction: f64,
    /// Rolling resistance b of the pair (m): its patch resists rolling with a couple of at most
    /// b times its normal impulse.
    pub rolling_resistance_m: f64,
    /// Its pair carried a normal impulse in the last substep: lasting contact, which takes no
    /// restitution at any of its points (a jam re-makes points that no warm start matches).
    pub lasting: bool,
    /// Accumulated normal impulse on B (N s); warm-start value on entry.
    pub normal_impulse: f64,
    /// This point's share of its patch's tangential impulse on B (N s), in proportion to its
    /// normal impulse; warm start on entry (a patch starts from the sum of its points' shares).
    pub tangent_impulse: DVec3,
    /// This point's share of its patch's torsional impulse on B about the normal (N m s); warm
    /// start on entry.
    pub twist_impulse: f64,
}

/// Per-point constants of one solve.
pub(super) struct Row {
    pub(super) ra: DVec3,
    pub(super) rb: DVec3,
    pub(super) k_n: f64,
    /// Distance from its patch's anchor in the tangent plane (m): its arm in torsional friction.
    pub(super) arm_m: f64,
    pub(super) target_vn: f64,
    /// Split-impulse target (m/s of pseudo-velocity along n): positive pushes a penetrating
    /// point out, negative pulls a point that bounced across a gap back by what it would have
    /// travelled to close it.
    pub(super) push_target: f64,
    pub(super) push_impulse: f64,
    /// The gap (m) this point bounces across if its normal impulse engages (restitution
    /// target set with separation s > 0), else 0.
    pub(super) bounce_gap_m: f64,
}

impl Row {
    /// A point with arms `ra`, `rb` (m) and normal effective mass `k_n` (1/kg), no targets.
    pub(super) fn new(ra: DVec3, rb: DVec3, k_n: f64) -> Self {
        Self {
            ra,
            rb,
            k_n,
            arm_m: 0.0,
            target_vn: 0.0,
            push_target: 0.0,
            push_impulse: 0.0,
            bounce_gap_m: 0.0,
        }
    }
}

pub(super) fn relative(bodies: &[SolverBody], a: usize, b: usize, ra: DVec3, rb: DVec3) -> DVec3 {
    bodies[b].velocity_at(rb) - bodies[a].velocity_at(ra)
}

pub(super) fn apply_pair(
    bodies: &mut [SolverBody],
    a: usize,
    b: usize,
    ra: DVec3,
    rb: DVec3,
    p: DVec3,
) {
    bodies[a].apply(ra, -p);
    bodies[b].apply(rb, p);
}

/// An angular impulse `l` on B about its COM, and −`l` on A.
pub(super) fn apply_twist(bodies: &mut [SolverBody], a: usize, b: usize, l: DVec3) {
    bodies[a].apply_angular(-l);
    bodies[b].apply_angular(l);
}

pub(super) fn effective(
    bodies: &[SolverBody],
    a: usize,
    b: usize,
    ra: DVec3,
    rb: DVec3,
    d: DVec3,
    e: DVec3,
) -> f64 {
    bodies[a].response(ra, d, e) + bodies[b].response(rb, d, e)
}
