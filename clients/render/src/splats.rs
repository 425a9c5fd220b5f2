//! The renderer's input: Gaussians as struct-of-arrays in world units, already decoded.
//!
//! Each Gaussian is a 3D normal density N(μ, Σ) with an opacity o and a view-dependent colour
//! given by real spherical-harmonic (SH) coefficients (Kerbl et al. 2023, sec. 4). After a
//! deformation F (PhysGaussian, Xie et al. 2024, eq. 6-7) the simulation publishes μ' = x,
//! Σ' = F Σ Fᵀ and the rotation R of the polar decomposition F = R S; view directions d are then
//! evaluated in the Gaussian's rest frame as Rᵀ d, so a rotated object looks the same from the
//! rotated direction.

use splatphys_formats::gaussians::{GaussianCloud, sh_coeffs_per_channel};

/// Bad renderer input: mismatched array lengths or an unsupported SH degree.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum InputError {
    /// An array does not have the length implied by the number of positions.
    #[error("splat array {field} has {found} entries, expected {expected} (N = {n} Gaussians)")]
    LengthMismatch {
        /// Name of the array (`covariances`, `opacities`, `sh`, `rotations`).
        field: &'static str,
        /// Expected number of entries.
        expected: usize,
        /// Number of entries found.
        found: usize,
        /// Number of Gaussians (length of `positions`).
        n: usize,
    },
    /// SH degree above 3.
    #[error("SH degree {degree} is not supported (0 to 3)")]
    ShDegree {
        /// The degree given.
        degree: u8,
    },
}

/// Borrowed Gaussians, struct-of-arrays; `N` = number of positions.
///
/// Nothing is copied: the slices may view shared memory. Non-finite Gaussians are allowed here
/// and skipped by the renderer.
#[derive(Debug, Clone, Copy)]
pub struct SplatView<'a> {
    /// `[N][3]` f32 centres, world metres, z up.
    pub positions: &'a [[f32; 3]],
    /// `[N][6]` f32 covariances Σ, upper triangle `xx, xy, xz, yy, yz, zz`, m².
    pub covariances: &'a [[f32; 6]],
    /// `[N]` f32 opacities in [0, 1] (already passed through the sigmoid).
    pub opacities: &'a [f32],
    /// `[N][K][3]` f32 SH coefficients, flattened coefficient-major (DC first, then the degree-1
    /// coefficients ...), one RGB triple per coefficient, `K = (sh_degree + 1)²`. The same order
    /// as [`GaussianCloud::sh_coefficients`].
    pub sh: &'a [[f32; 3]],
    /// SH degree 0..=3 of `sh`.
    pub sh_degree: u8,
    /// `[N][4]` f32 rotations `w x y z` that rotate SH view directions (see the module docs), or
    /// empty for the identity. Normalised by the renderer.
    pub rotations: &'a [[f32; 4]],
}

impl<'a> SplatView<'a> {
    /// Checks the lengths and the SH degree and builds the view.
    ///
    /// # Errors
    /// [`InputError::LengthMismatch`] when an array length does not match `positions.len()`,
    /// [`InputError::ShDegree`] when `sh_degree > 3`.
    pub fn new(
        positions: &'a [[f32; 3]],
        covariances: &'a [[f32; 6]],
        opacities: &'a [f32],
        sh: &'a [[f32; 3]],
        sh_degree: u8,
        rotations: &'a [[f32; 4]],
    ) -> Result<Self, InputError> {
        let view = Self {
            positions,
            covariances,
            opacities,
            sh,
            sh_degree,
            rotations,
        };
        view.validate()?;
        Ok(view)
    }

    /// Number of Gaussians `N`.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// True when there are no Gaussians.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Number of SH coefficients per channel, `K = (sh_degree + 1)²`.
    pub fn coeffs_per_gaussian(&self) -> usize {
        sh_coeffs_per_channel(self.sh_degree)
    }

    /// Checks array lengths and the SH degree (the fields are public, so a view built by hand is
    /// checked again before rendering).
    ///
    /// # Errors
    /// See [`SplatView::new`].
    pub fn validate(&self) -> Result<(), InputError> {
        if self.sh_degree > 3 {
            return Err(InputError::ShDegree {
                degree: self.sh_degree,
            });
        }
        let n = self.positions.len();
        let k = self.coeffs_per_gaussian();
        let check = |field, expected: usize, found: usize| {
            if expected == found {
                Ok(())
            } else {
                Err(InputError::LengthMismatch {
                    field,
                    expected,
                    found,
                    n,
                })
            }
        };
        check("covariances", n, self.covariances.len())?;
        check("opacities", n, self.opacities.len())?;
        check("sh", n * k, self.sh.len())?;
        if !self.rotations.is_empty() {
            check("rotations", n, self.rotations.len())?;
        }
        Ok(())
    }
}

/// Owned Gaussians with the same layout as [`SplatView`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Splats {
    /// `[N][3]` centres, world metres, z up.
    pub positions: Vec<[f32; 3]>,
    /// `[N][6]` covariances `xx, xy, xz, yy, yz, zz`, m².
    pub covariances: Vec<[f32; 6]>,
    /// `[N]` opacities in [0, 1].
    pub opacities: Vec<f32>,
    /// `[N][K][3]` SH coefficients, coefficient-major, `K = (sh_degree + 1)²`.
    pub sh: Vec<[f32; 3]>,
    /// SH degree 0..=3.
    pub sh_degree: u8,
    /// `[N][4]` rotations `w x y z` for SH view directions, or empty for the identity.
    pub rotations: Vec<[f32; 4]>,
}

impl Splats {
    /// Decodes a [`GaussianCloud`] (INRIA raw values) into renderer input: covariance from
    /// [`GaussianCloud::covariance`], opacity from [`GaussianCloud::opacity`], SH from
    /// [`GaussianCloud::sh_coefficients`]; no rotations. Units are the cloud's (metres once the
    /// scene transform is applied).
    pub fn from_cloud(cloud: &GaussianCloud) -> Self {
        let n = cloud.len();
        let k = sh_coeffs_per_channel(cloud.sh_degree);
        let mut sh = Vec::with_capacity(n * k);
        let mut covariances = Vec::with_capacity(n);
        let mut opacities = Vec::with_capacity(n);
        for i in 0..n {
            let c = cloud.covariance(i);
            covariances.push([
                c.x_axis.x, c.y_axis.x, c.z_axis.x, c.y_axis.y, c.z_axis.y, c.z_axis.z,
            ]);
            opacities.push(cloud.opacity(i));
            sh.extend(cloud.sh_coefficients(i));
        }
        Self {
            positions: cloud.positions.clone(),
            covariances,
            opacities,
            sh,
            sh_degree: cloud.sh_degree,
            rotations: Vec::new(),
        }
    }

    /// Keeps only the SH coefficients up to `degree` (no-op when already at or below it).
    /// Files that store zero `f_rest_*` values render faster at degree 0.
    pub fn truncate_sh(&mut self, degree: u8) {
        if degree >= self.sh_degree {
            return;
        }
        let k_old = sh_coeffs_per_channel(self.sh_degree);
        let k_new = sh_coeffs_per_channel(degree);
        let mut sh = Vec::with_capacity(self.positions.len() * k_new);
        for chunk in self.sh.chunks_exact(k_old) {
            sh.extend_from_slice(&chunk[..k_new]);
        }
        self.sh = sh;
        self.sh_degree = degree;
    }

    /// Borrowed view of these Gaussians.
    ///
    /// # Errors
    /// See [`SplatView::new`] (the public fields may have been edited inconsistently).
    pub fn view(&self) -> Result<SplatView<'_>, InputError> {
        SplatView::new(
            &self.positions,
            &self.covariances,
            &self.opacities,
            &self.sh,
            self.sh_degree,
            &self.rotations,
        )
    }
}
