//! Particle state in struct-of-arrays form (glam SIMD types), `N` = [`Particles::len`].

use glam::{Mat3A, Vec3A};

/// The smallest stretch (singular value) a particle's plastic deformation F_p keeps: sand and
/// snow flow without bound, and a Gaussian following all of it turns into a needle or a disc.
pub const PLASTIC_STRETCH_MIN: f32 = 0.25;
/// The largest stretch a particle's plastic deformation F_p keeps ([`PLASTIC_STRETCH_MIN`]).
pub const PLASTIC_STRETCH_MAX: f32 = 4.0;

/// MPM particles. Every array has length `N`; index i is one particle throughout a run.
#[derive(Debug, Default, PartialEq)]
pub struct Particles {
    /// `[N]` positions (m, world frame, z up).
    pub x: Vec<Vec3A>,
    /// `[N]` velocities (m/s).
    pub v: Vec<Vec3A>,
    /// `[N]` APIC affine velocity matrix C ≈ ∇v (1/s).
    pub c: Vec<Mat3A>,
    /// `[N]` elastic deformation gradient F (dimensionless; plasticity is projected out of it).
    pub f: Vec<Mat3A>,
    /// `[N]` plastic deformation gradient F_p (dimensionless; identity for elastic models): the
    /// total deformation is F F_p, which is what the Gaussians a particle carries follow
    /// (`g2p`'s return mapping updates it; its stretches are bounded to
    /// [[`PLASTIC_STRETCH_MIN`], [`PLASTIC_STRETCH_MAX`]] where flow is unbounded).
    pub f_plastic: Vec<Mat3A>,
    /// `[N]` scalar plastic state of the material (snow: Jp; others: accumulated plastic strain).
    pub plastic: Vec<f32>,
    /// `[N]` mass (kg).
    pub mass_kg: Vec<f32>,
    /// `[N]` initial volume (m³).
    pub volume0_m3: Vec<f32>,
    /// `[N]` index into the solver's material table.
    pub material: Vec<u16>,
    /// `[N]` object index (which simulated object the particle belongs to).
    pub object: Vec<u32>,
}

crate::clone_reusing::clone_reusing!(Particles {
    x,
    v,
    c,
    f,
    f_plastic,
    plastic,
    mass_kg,
    volume0_m3,
    material,
    object,
});

impl Particles {
    /// Number of particles.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// True when there are no particles.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Appends one particle at rest in its reference configuration (F = I, C = 0).
    #[allow(clippy::too_many_arguments)]
    pub fn push(
        &mut self,
        x_m: Vec3A,
        v_m_s: Vec3A,
        mass_kg: f32,
        volume0_m3: f32,
        material: u16,
        object: u32,
        plastic: f32,
    ) {
        self.x.push(x_m);
        self.v.push(v_m_s);
        self.c.push(Mat3A::ZERO);
        self.f.push(Mat3A::IDENTITY);
        self.f_plastic.push(Mat3A::IDENTITY);
        self.plastic.push(plastic);
        self.mass_kg.push(mass_kg);
        self.volume0_m3.push(volume0_m3);
        self.material.push(material);
        self.object.push(object);
    }

    /// Appends all particles of `other`.
    pub fn extend_from(&mut self, other: &Particles) {
        self.x.extend_from_slice(&other.x);
        self.v.extend_from_slice(&other.v);
        self.c.extend_from_slice(&other.c);
        self.f.extend_from_slice(&other.f);
        self.f_plastic.extend_from_slice(&other.f_plastic);
        self.plastic.extend_from_slice(&other.plastic);
        self.mass_kg.extend_from_slice(&other.mass_kg);
        self.volume0_m3.extend_from_slice(&other.volume0_m3);
        self.material.extend_from_slice(&other.material);
        self.object.extend_from_slice(&other.object);
    }

    /// The particles in the order `order` (`[N]`, a permutation of 0..N): particle k of the
    /// result is particle `order[k]` of `self`. `None` when `order` is not a permutation.
    pub fn permuted(&self, order: &[usize]) -> Option<Particles> {
        let mut seen = vec![false; self.len()];
        if order.len() != self.len()
            || !order
                .iter()
                .all(|&i| i < seen.len() && !std::mem::replace(&mut seen[i], true))
        {
            return None;
        }
        // Destructured so that a new field cannot be left out.
        let Particles {
            x,
            v,
            c,
            f,
            f_plastic,
            plastic,
            mass_kg,
            volume0_m3,
            material,
            object,
        } = self;
        fn pick<T: Copy>(a: &[T], order: &[usize]) -> Vec<T> {
            order.iter().map(|&i| a[i]).collect()
        }
        Some(Particles {
            x: pick(x, order),
            v: pick(v, order),
            c: pick(c, order),
            f: pick(f, order),
            f_plastic: pick(f_plastic, order),
            plastic: pick(plastic, order),
            mass_kg: pick(mass_kg, order),
            volume0_m3: pick(volume0_m3, order),
            material: pick(material, order),
            object: pick(object, order),
        })
    }

    /// The first particle index whose position, velocity, C or F is not finite.
    pub fn first_non_finite(&self) -> Option<usize> {
        (0..self.len()).find(|&i| {
            !(self.x[i].is_finite()
                && self.v[i].is_finite()
                && self.c[i].is_finite()
                && self.f[i].is_finite())
        })
    }
}

impl Particles {
    /// Particles on a regular lattice of `spacing_m` filling the box `[min_m, max_m)`, at rest,
    /// each with volume spacing³ and mass density · volume. Lattice sites sit at cell centres.
    pub fn lattice_box(
        min_m: Vec3A,
        max_m: Vec3A,
        spacing_m: f32,
        density_kg_m3: f32,
        material: u16,
        object: u32,
    ) -> Self {
        Self::lattice(
            min_m,
            max_m,
            spacing_m,
            density_kg_m3,
            material,
            object,
            |_| true,
        )
    }

    /// Particles on a lattice of `spacing_m` inside the sphere of `radius_m` about `center_m`.
    pub fn lattice_sphere(
        center_m: Vec3A,
        radius_m: f32,
        spacing_m: f32,
        density_kg_m3: f32,
        material: u16,
        object: u32,
    ) -> Self {
        let r = Vec3A::splat(radius_m);
        Self::lattice(
            center_m - r,
            center_m + r,
            spacing_m,
            density_kg_m3,
            material,
            object,
            |x| (x - center_m).length_squared() <= radius_m * radius_m,
        )
    }

    fn lattice(
        min_m: Vec3A,
        max_m: Vec3A,
        spacing_m: f32,
        density_kg_m3: f32,
        material: u16,
        object: u32,
        keep: impl Fn(Vec3A) -> bool,
    ) -> Self {
        let mut out = Self::default();
        let n = ((max_m - min_m) / spacing_m).round().as_uvec3();
        let volume = spacing_m * spacing_m * spacing_m;
        for i in 0..n.x {
            for j in 0..n.y {
                for k in 0..n.z {
                    let x = min_m
                        + (glam::UVec3::new(i, j, k).as_vec3a() + Vec3A::splat(0.5)) * spacing_m;
                    if keep(x) {
                        out.push(
                            x,
                            Vec3A::ZERO,
                            density_kg_m3 * volume,
                            volume,
                            material,
                            object,
                            0.0,
                        );
                    }
                }
            }
        }
        out
    }

    /// Sets the plastic state of every particle to its material's initial value.
    pub fn init_plastic_state(&mut self, materials: &[crate::material::Material]) {
        use crate::material::ConstitutiveModel;
        for (p, &m) in self.plastic.iter_mut().zip(&self.material) {
            if let Some(mat) = materials.get(m as usize) {
                *p = mat.initial_plastic_state();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn permuting_and_permuting_back_restores_every_field() {
        let mut p = Particles::lattice_box(Vec3A::ZERO, Vec3A::splat(0.3), 0.1, 1000.0, 0, 7);
        for (i, (v, plastic)) in p.v.iter_mut().zip(&mut p.plastic).enumerate() {
            *v = Vec3A::splat(i as f32);
            *plastic = i as f32 * 0.5;
        }
        let n = p.len();
        let order: Vec<usize> = (0..n).map(|k| (k * 7 + 3) % n).collect();
        let q = p.permuted(&order).expect("a permutation");
        assert_eq!(q.v[0], p.v[order[0]]);
        assert_eq!(q.plastic[5], p.plastic[order[5]]);
        let mut inverse = vec![0; n];
        for (k, &i) in order.iter().enumerate() {
            inverse[i] = k;
        }
        let back = q.permuted(&inverse).expect("a permutation");
        assert_eq!(back.x, p.x);
        assert_eq!(back.v, p.v);
        assert_eq!(back.plastic, p.plastic);
        assert_eq!(back.mass_kg, p.mass_kg);
        assert_eq!(back.object, p.object);
        assert!(p.permuted(&vec![0; n]).is_none(), "a repeated index");
        assert!(p.permuted(&order[1..]).is_none(), "too short");
    }
}
