//! Object-level state measured from particles (the paper's eq. 2: mass-weighted means): mass,
//! COM, velocity, angular momentum, inertia, the effective radius (eq. 3's bounding sphere: the
//! largest distance of a particle from the COM plus half a grid cell) and the particles' rigid fit.

use glam::{DMat3, DVec3};

use crate::mpm::Particles;

/// Object-level state, measured from the particles in f64 in index order.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BodyState {
    /// Total mass (kg).
    pub mass_kg: f64,
    /// Centre of mass (m).
    pub com_m: DVec3,
    /// COM velocity (m/s).
    pub velocity_m_s: DVec3,
    /// Angular momentum about the COM (kg m²/s), APIC spin term included.
    pub angular_momentum: DVec3,
    /// Inertia tensor about the COM (kg m²).
    pub inertia: DMat3,
    /// Effective radius (m): max particle distance from the COM + dx/2.
    pub radius_m: f64,
    /// Axis-aligned bounds (m).
    pub aabb_m: (DVec3, DVec3),
}

impl BodyState {
    /// Angular velocity ω = I⁻¹ L (rad/s); zero for a degenerate inertia.
    pub fn angular_velocity(&self) -> DVec3 {
        inverse_or_zero(self.inertia) * self.angular_momentum
    }
}

/// I⁻¹, or zero when I is singular (a single particle, a line of particles).
pub fn inverse_or_zero(i: DMat3) -> DMat3 {
    let d = i.determinant();
    let scale = i.x_axis.length() + i.y_axis.length() + i.z_axis.length();
    if d.abs() > 1e-12 * scale.powi(3) && d.is_finite() {
        i.inverse()
    } else {
        DMat3::ZERO
    }
}

/// Mass, COM, COM velocity and bounding box of `p` in one pass (f64 sums in particle order);
/// `None` when it has no mass.
fn zeroth_and_first_moments(p: &Particles) -> Option<(f64, DVec3, DVec3, (DVec3, DVec3))> {
    let mut m = 0.0f64;
    let mut mx = DVec3::ZERO;
    let mut mv = DVec3::ZERO;
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for i in 0..p.len() {
        let mi = p.mass_kg[i] as f64;
        let x = p.x[i].as_dvec3();
        m += mi;
        mx += x * mi;
        mv += p.v[i].as_dvec3() * mi;
        lo = lo.min(x);
        hi = hi.max(x);
    }
    (m > 0.0).then(|| (m, mx / m, mv / m, (lo, hi)))
}

/// The part of [`measure`] the broad phase needs, at a fraction of its cost: mass, COM,
/// velocity, radius and box. `angular_momentum` and `inertia` are left zero; call [`measure`]
/// for a body whose contact is resolved.
pub fn measure_bounds(p: &Particles, dx_m: f32) -> BodyState {
    let Some((m, com, vel, (lo, hi))) = zeroth_and_first_moments(p) else {
        return BodyState::default();
    };
    let c = com.as_vec3a();
    let r2max =
        p.x.iter()
            .map(|x| (*x - c).length_squared())
            .fold(0.0f32, f32::max) as f64;
    BodyState {
        mass_kg: m,
        com_m: com,
        velocity_m_s: vel,
        angular_momentum: DVec3::ZERO,
        inertia: DMat3::ZERO,
        // f32 distances: widen by a relative 1e-6 so the sphere still holds every particle.
        radius_m: r2max.sqrt() * (1.0 + 1e-6) + dx_m as f64 / 2.0,
        aabb_m: (lo, hi),
    }
}

/// Measures mass, COM, velocity, angular momentum and inertia of `p` (cell size `dx_m` for the
/// APIC spin term and the radius margin).
pub fn measure(p: &Particles, dx_m: f32) -> BodyState {
    measure_with_fit(p, dx_m).0
}

/// The particles' rigid fit: the rigid motion (COM velocity and ω) that carries their momentum
/// and orbital angular momentum, and the kinetic energy of their motion relative to it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RigidFit {
    /// COM (m).
    pub com_m: DVec3,
    /// COM velocity (m/s).
    pub velocity_m_s: DVec3,
    /// (Σ m (|r|² 1 − r rᵀ))⁻¹ about the COM, orbital only (no APIC spin, no particle spread)
    /// (1/(kg m²)); zero when singular.
    pub inverse_orbital_inertia: DMat3,
    /// ω = I⁻¹ Σ m r × v (rad/s).
    pub omega_rad_s: DVec3,
    /// ½ Σ m |v − v_com|² − ½ ω · Σ m r × v (J): the energy no rigid motion accounts for.
    pub relative_energy_j: f64,
}

impl RigidFit {
    /// The fit of the same particles (same positions, hence the same COM and inertia) after
    /// their velocities changed: `momentum` Σ m v (kg m/s), `orbital` Σ m r × v about the COM
    /// (kg m²/s) and `twice_energy` Σ m |v|² (J × 2), of total mass `mass_kg`.
    pub fn with_velocities(
        &self,
        mass_kg: f64,
        momentum: DVec3,
        orbital: DVec3,
        twice_energy: f64,
    ) -> Self {
        let velocity = momentum / mass_kg;
        let omega = self.inverse_orbital_inertia * orbital;
        Self {
            velocity_m_s: velocity,
            omega_rad_s: omega,
            relative_energy_j: 0.5 * (twice_energy - mass_kg * velocity.length_squared())
                - 0.5 * omega.dot(orbital),
            ..*self
        }
    }
}

/// [`measure`] and the particles' [`RigidFit`], in the same two passes.
pub fn measure_with_fit(p: &Particles, dx_m: f32) -> (BodyState, RigidFit) {
    let Some((m, com, vel, (lo, hi))) = zeroth_and_first_moments(p) else {
        return Default::default();
    };
    let d = (dx_m as f64).powi(2) / 4.0;
    let mut l = DVec3::ZERO;
    let mut spin = DVec3::ZERO;
    let mut twice_relative = 0.0f64;
    // Second moments Σ m r rᵀ: diagonal and (xy, xz, yz).
    let mut diag = DVec3::ZERO;
    let mut off = DVec3::ZERO;
    let mut r2max = 0.0f64;
    for i in 0..p.len() {
        let mi = p.mass_kg[i] as f64;
        let r = p.x[i].as_dvec3() - com;
        let v = p.v[i].as_dvec3() - vel;
        let c = p.c[i];
        spin += DVec3::new(
            (c.y_axis.z - c.z_axis.y) as f64,
            (c.z_axis.x - c.x_axis.z) as f64,
            (c.x_axis.y - c.y_axis.x) as f64,
        ) * mi;
        l += r.cross(v) * mi;
        twice_relative += mi * v.length_squared();
        let mr = r * mi;
        diag += mr * r;
        off += DVec3::new(mr.x * r.y, mr.x * r.z, mr.y * r.z);
        r2max = r2max.max(r.length_squared());
    }
    let inverse_orbital_inertia = inverse_or_zero(inertia_from_second_moments(diag, off, 0.0));
    let omega = inverse_orbital_inertia * l;
    let fit = RigidFit {
        com_m: com,
        velocity_m_s: vel,
        inverse_orbital_inertia,
        omega_rad_s: omega,
        relative_energy_j: 0.5 * twice_relative - 0.5 * omega.dot(l),
    };
    // Plus each particle's own spread m d (2 on the diagonal).
    let inertia = inertia_from_second_moments(diag, off, 2.0 * d * m);
    let state = BodyState {
        mass_kg: m,
        com_m: com,
        velocity_m_s: vel,
        angular_momentum: l + spin * d,
        inertia,
        radius_m: r2max.sqrt() + dx_m as f64 / 2.0,
        aabb_m: (lo, hi),
    };
    (state, fit)
}

/// The inertia tensor Σ m (|r|² 1 − r rᵀ) + `spread` 1 (kg m²) from the second moments Σ m r rᵀ:
/// `diag` its diagonal, `off` its (xy, xz, yz) entries.
pub fn inertia_from_second_moments(diag: DVec3, off: DVec3, spread: f64) -> DMat3 {
    let trace = diag.x + diag.y + diag.z + spread;
    DMat3::from_cols(
        DVec3::new(trace - diag.x, -off.x, -off.y),
        DVec3::new(-off.x, trace - diag.y, -off.z),
        DVec3::new(-off.y, -off.z, trace - diag.z),
    )
}

/// a bᵀ.
pub fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}
