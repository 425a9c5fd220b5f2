//! Particle state in struct-of-arrays form (glam SIMD types), `N` = [`Particles::len`].

use glam::{Mat3A, Vec3A};

/// MPM particles. Every array has length `N`; index i is one particle throughout a run.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Particles {
    /// `[N]` positions (m, world frame, z up).
    pub x: Vec<Vec3A>,
    /// `[N]` velocities (m/s).
    pub v: Vec<Vec3A>,
    /// `[N]` APIC affine velocity matrix C ≈ ∇v (1/s).
    pub c: Vec<Mat3A>,
    /// `[N]` elastic deformation gradient F (dimensionless; plasticity is projected out of it).
    pub f: Vec<Mat3A>,
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
        self.plastic.extend_from_slice(&other.plastic);
        self.mass_kg.extend_from_slice(&other.mass_kg);
        self.volume0_m3.extend_from_slice(&other.volume0_m3);
        self.material.extend_from_slice(&other.material);
        self.object.extend_from_slice(&other.object);
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
