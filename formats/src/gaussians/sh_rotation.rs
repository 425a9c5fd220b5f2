//! Rotating real spherical-harmonic (SH) colour coefficients of degrees 1 to 3, so that a
//! Gaussian placed with a rotation R shows towards the view direction R d the colour it showed
//! towards d before.
//!
//! # Basis and convention
//!
//! The basis is exactly the one the 3DGS reference rasterizer evaluates (Kerbl et al. 2023,
//! `computeColorFromSH` in `forward.cu`; `eval_sh` in `utils/sh_utils.py`; our renderer's
//! `splatphys_render::sh::eval_sh`), constants from Sloan, "Stupid Spherical Harmonics (SH)
//! Tricks" (2008), with its signs: for a unit view direction d = (x, y, z) from the camera
//! towards the Gaussian,
//!
//! ```text
//! band 1: -C1 y, C1 z, -C1 x
//! band 2: C2₀ xy, C2₁ yz, C2₂ (2z² - x² - y²), C2₃ xz, C2₄ (x² - y²)
//! band 3: C3₀ y(3x² - y²), C3₁ xyz, C3₂ y(4z² - x² - y²), C3₃ z(2z² - 3x² - 3y²),
//!         C3₄ x(4z² - x² - y²), C3₅ z(x² - y²), C3₆ x(x² - 3y²)
//! ```
//!
//! and colour = C0 dc + Σ c_j B_j(d) + 0.5 per channel. [`sh_basis`] returns these 15 values.
//! Coefficients are stored as the INRIA PLY stores `f_rest_*` ([`GaussianCloud::sh_rest`]):
//! channel-major, for each of R, G, B the `K - 1` coefficients beyond DC, `K = (degree + 1)²`.
//!
//! # Method
//!
//! Rotation maps each band's function space onto itself (the band-l functions are the harmonic
//! homogeneous polynomials of degree l; Sloan 2008 sec. "Rotation"; Green, "Spherical Harmonic
//! Lighting: The Gritty Details", 2003). So for every band there is a (2l+1)×(2l+1) matrix
//! M_l with Σ_i (M_l c)_i B_i(d) = Σ_j c_j B_j(Rᵀ d) for all d, and a linear map of a
//! (2l+1)-dimensional space is fixed by its values at 2l+1 or more generic directions: the
//! "sample and invert" construction. With Y\[i\]\[s\] = B_i(n_s) and Z\[j\]\[s\] = B_j(Rᵀ n_s) at
//! sample directions n_s, Z = P Y with M_l = Pᵀ, so M_l solves (Y Yᵀ) M_l = Y Zᵀ. We sample
//! [`SAMPLE_DIRECTIONS`] points of a Fibonacci spiral (more than 2l+1, so the fit is a
//! well-conditioned least-squares problem; being exact, its residual is rounding only) and solve
//! in f64 with partial pivoting. Ivanic and Ruedenberg, "Rotation Matrices for Real Spherical
//! Harmonics. Direct Determination by Recursion", J. Phys. Chem. 100 (1996) 6342, give
//! recurrences for the same matrices; at degree 3 the two cost the same, once per source.
//!
//! The matrices depend on the ratios of the constants within a band; the renderer's f32
//! constants are these f64 values rounded, a relative difference below 1e-7.

use glam::{DMat3, DQuat, DVec3, Quat};
use rayon::prelude::*;

use super::GaussianCloud;

/// Degree-1 constant, √(3 / 4π).
pub const SH_C1: f64 = 0.488_602_511_902_919_9;
/// Degree-2 constants (signs as in the 3DGS reference).
pub const SH_C2: [f64; 5] = [
    1.092_548_430_592_079_2,
    -1.092_548_430_592_079_2,
    0.315_391_565_252_520_05,
    -1.092_548_430_592_079_2,
    0.546_274_215_296_039_6,
];
/// Degree-3 constants (signs as in the 3DGS reference).
pub const SH_C3: [f64; 7] = [
    -0.590_043_589_926_643_5,
    2.890_611_442_640_554,
    -0.457_045_799_464_465_8,
    0.373_176_332_590_115_4,
    -0.457_045_799_464_465_8,
    1.445_305_721_320_277,
    -0.590_043_589_926_643_5,
];

/// Number of sample directions the band matrices are fitted at (at least 7 = 2·3 + 1).
pub const SAMPLE_DIRECTIONS: usize = 32;

/// The 15 SH basis functions beyond DC, bands 1 to 3 in storage order (band 1: 0..3, band 2:
/// 3..8, band 3: 8..15), at direction `d` (unit for the renderer's values; the functions are
/// homogeneous polynomials, so any length gives the same rotation law).
pub fn sh_basis(d: DVec3) -> [f64; 15] {
    let (x, y, z) = (d.x, d.y, d.z);
    let (xx, yy, zz) = (x * x, y * y, z * z);
    [
        -SH_C1 * y,
        SH_C1 * z,
        -SH_C1 * x,
        SH_C2[0] * x * y,
        SH_C2[1] * y * z,
        SH_C2[2] * (2.0 * zz - xx - yy),
        SH_C2[3] * x * z,
        SH_C2[4] * (xx - yy),
        SH_C3[0] * y * (3.0 * xx - yy),
        SH_C3[1] * x * y * z,
        SH_C3[2] * y * (4.0 * zz - xx - yy),
        SH_C3[3] * z * (2.0 * zz - 3.0 * xx - 3.0 * yy),
        SH_C3[4] * x * (4.0 * zz - xx - yy),
        SH_C3[5] * z * (xx - yy),
        SH_C3[6] * x * (xx - 3.0 * yy),
    ]
}

/// Unit direction `s` of [`SAMPLE_DIRECTIONS`] on a Fibonacci spiral (near-uniform on the
/// sphere, none on a coordinate axis or plane, where the basis has zeros).
fn sample_direction(s: usize) -> DVec3 {
    let golden_angle = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let z = 1.0 - (2.0 * s as f64 + 1.0) / SAMPLE_DIRECTIONS as f64;
    let r = (1.0 - z * z).sqrt();
    let phi = golden_angle * s as f64;
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Rotation matrices of SH bands 1, 2 and 3 for one 3D rotation R, in the 3DGS basis of
/// [`sh_basis`]: rotated coefficients c' = M_l c per band and channel satisfy
/// Σ c'_j B_j(R d) = Σ c_j B_j(d) for every direction d.
///
/// ```
/// use glam::{DMat3, DVec3};
/// use splatphys_formats::gaussians::sh_rotation::{ShRotation, sh_basis};
///
/// let r = DMat3::from_rotation_x(-std::f64::consts::FRAC_PI_2); // y-down capture to z-up
/// let rot = ShRotation::from_mat3(r);
/// let mut c = [0.3, -0.1, 0.7, 0.2, 0.0, -0.4, 0.1, 0.5]; // one channel, degree 2
/// let before = c;
/// rot.rotate_channel(&mut c);
/// let d = DVec3::new(0.2, -0.6, 0.77).normalize();
/// let dot = |c: &[f64], d| c.iter().zip(sh_basis(d)).map(|(a, b)| a * b).sum::<f64>();
/// assert!((dot(&c[..], r * d) - dot(&before[..], d)).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShRotation {
    /// `[3][3]` row-major M_1 (coefficients 0..3 beyond DC).
    pub band1: [[f64; 3]; 3],
    /// `[5][5]` row-major M_2 (coefficients 3..8 beyond DC).
    pub band2: [[f64; 5]; 5],
    /// `[7][7]` row-major M_3 (coefficients 8..15 beyond DC).
    pub band3: [[f64; 7]; 7],
}

impl ShRotation {
    /// The band matrices of `rotation` (assumed orthonormal with determinant 1; a reflection
    /// gives the matrices of that reflection, which odd bands see as a sign flip).
    pub fn from_mat3(rotation: DMat3) -> Self {
        Self {
            band1: band_matrix(rotation, 0),
            band2: band_matrix(rotation, 3),
            band3: band_matrix(rotation, 8),
        }
    }

    /// The band matrices of a quaternion rotation (normalised in f64 first).
    pub fn from_quat(rotation: Quat) -> Self {
        let q = DQuat::from_xyzw(
            rotation.x as f64,
            rotation.y as f64,
            rotation.z as f64,
            rotation.w as f64,
        )
        .normalize();
        Self::from_mat3(DMat3::from_quat(q))
    }

    /// Rotates one colour channel's coefficients beyond DC in place: `rest[j]` is the
    /// coefficient of `sh_basis(d)[j]`. Every band lying wholly inside `rest` is rotated (3, 8
    /// and 15 values mean degrees 1, 2 and 3); values past the last whole band are left as
    /// they are.
    pub fn rotate_channel(&self, rest: &mut [f64]) {
        apply_band(&self.band1, rest, 0);
        apply_band(&self.band2, rest, 3);
        apply_band(&self.band3, rest, 8);
    }

    /// Rotates one Gaussian's `f_rest_*` values in place: `[3][k]` channel-major f32 (the
    /// layout of [`GaussianCloud::sh_rest`]), `k = rest.len() / 3`. Arithmetic is f64; each
    /// result is rounded to f32 once.
    pub fn rotate_gaussian(&self, rest: &mut [f32]) {
        let k = rest.len() / 3;
        if k == 0 {
            return;
        }
        let mut channel = [0.0f64; 15];
        for block in rest.chunks_exact_mut(k) {
            let n = k.min(15);
            for (c, v) in channel.iter_mut().zip(block.iter()) {
                *c = f64::from(*v);
            }
            self.rotate_channel(&mut channel[..n]);
            for (v, c) in block.iter_mut().zip(channel.iter()) {
                *v = *c as f32;
            }
        }
    }
}

/// Rotates the SH coefficients of every Gaussian of `cloud` for a rotation `rotation` applied
/// to the cloud (positions and orientations rotated by R elsewhere), so colours follow the
/// rotation: the colour towards R d afterwards equals the colour towards d before. The
/// identity (either sign of the quaternion), clouds without `f_rest_*` values and Gaussians whose
/// `f_rest_*` values are all zero (degree-0 captures that store zeros) are left bit-identical.
/// Gaussians are independent, so the result does not depend on the thread count.
pub fn rotate_cloud_sh(cloud: &mut GaussianCloud, rotation: Quat) {
    let rest_len = cloud.sh_rest_len;
    if rest_len < 9 || rotation == Quat::IDENTITY || rotation == -Quat::IDENTITY {
        return;
    }
    let m = ShRotation::from_quat(rotation);
    cloud
        .sh_rest
        .par_chunks_exact_mut(rest_len)
        .filter(|rest| rest.iter().any(|&v| v != 0.0))
        .for_each(|rest| m.rotate_gaussian(rest));
}

/// Fits the band matrix of the `N` basis functions starting at `offset` in [`sh_basis`] (see
/// the module docs: solves (Y Yᵀ) M = Y Zᵀ).
fn band_matrix<const N: usize>(rotation: DMat3, offset: usize) -> [[f64; N]; N] {
    let rt = rotation.transpose();
    let mut gram = [[0.0f64; N]; N];
    let mut rhs = [[0.0f64; N]; N];
    for s in 0..SAMPLE_DIRECTIONS {
        let n = sample_direction(s);
        let y = sh_basis(n);
        let z = sh_basis(rt * n);
        for i in 0..N {
            for j in 0..N {
                gram[i][j] += y[offset + i] * y[offset + j];
                rhs[i][j] += y[offset + i] * z[offset + j];
            }
        }
    }
    solve(gram, rhs)
}

/// Solves A X = B for square `[N][N]` A and B by Gaussian elimination with partial pivoting.
/// A is the Gram matrix of linearly independent functions at spread-out directions, so it is
/// symmetric positive definite and well conditioned; no pivot is ever near zero.
// Row operations read one row of `a` (or `b`) while writing another: indices, not iterators.
#[allow(clippy::needless_range_loop)]
fn solve<const N: usize>(mut a: [[f64; N]; N], mut b: [[f64; N]; N]) -> [[f64; N]; N] {
    for col in 0..N {
        let pivot = (col..N)
            .max_by(|&p, &q| a[p][col].abs().total_cmp(&a[q][col].abs()))
            .unwrap_or(col);
        a.swap(col, pivot);
        b.swap(col, pivot);
        for row in col + 1..N {
            let f = a[row][col] / a[col][col];
            for k in col..N {
                a[row][k] -= f * a[col][k];
            }
            for k in 0..N {
                b[row][k] -= f * b[col][k];
            }
        }
    }
    for col in (0..N).rev() {
        for k in 0..N {
            let mut v = b[col][k];
            for j in col + 1..N {
                v -= a[col][j] * b[j][k];
            }
            b[col][k] = v / a[col][col];
        }
    }
    b
}

/// c\[offset..offset + N\] = M c\[offset..offset + N\] when the band lies wholly inside `c`.
fn apply_band<const N: usize>(m: &[[f64; N]; N], c: &mut [f64], offset: usize) {
    let Some(band) = c.get_mut(offset..offset + N) else {
        return;
    };
    let mut out = [0.0f64; N];
    for (o, row) in out.iter_mut().zip(m) {
        *o = row.iter().zip(band.iter()).map(|(a, b)| a * b).sum();
    }
    band.copy_from_slice(&out);
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Σ c_j B_j(d) over the first `c.len()` functions.
    fn eval(c: &[f64], d: DVec3) -> f64 {
        c.iter().zip(sh_basis(d)).map(|(a, b)| a * b).sum()
    }

    fn random_rotation(rng: &mut ChaCha8Rng) -> DMat3 {
        let q = DQuat::from_xyzw(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        )
        .normalize();
        DMat3::from_quat(q)
    }

    fn random_unit(rng: &mut ChaCha8Rng) -> DVec3 {
        loop {
            let v = DVec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            let n = v.length();
            if n > 0.1 && n <= 1.0 {
                return v / n;
            }
        }
    }

    #[test]
    fn rotated_coefficients_show_the_same_colour_towards_the_rotated_direction() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for _ in 0..50 {
            let r = random_rotation(&mut rng);
            let m = ShRotation::from_mat3(r);
            for len in [3, 8, 15] {
                let c: Vec<f64> = (0..len).map(|_| rng.random_range(-1.0..1.0)).collect();
                let mut rotated = c.clone();
                m.rotate_channel(&mut rotated);
                for _ in 0..10 {
                    let d = random_unit(&mut rng);
                    // f64 throughout: only rounding remains (~1e-15 per term).
                    let (a, b) = (eval(&rotated, r * d), eval(&c, d));
                    assert!((a - b).abs() < 1e-12, "len {len}: {a} vs {b}");
                }
            }
        }
    }

    #[test]
    fn band_1_coefficients_rotate_as_the_vector_they_encode() {
        // Band 1 is C1 a·d with a = (-c₂, -c₀, c₁) (from -C1 y c₀ + C1 z c₁ - C1 x c₂), and
        // the rotated function is C1 (R a)·d: a closed form independent of the fit.
        let r = DMat3::from_rotation_z(0.7) * DMat3::from_rotation_x(-1.1);
        let c = [0.3, -0.8, 0.5];
        let a = DVec3::new(-c[2], -c[0], c[1]);
        let ra = r * a;
        let expected = [-ra.y, ra.z, -ra.x];
        let mut got = c;
        ShRotation::from_mat3(r).rotate_channel(&mut got);
        for (g, e) in got.iter().zip(expected) {
            assert!((g - e).abs() < 1e-13, "{got:?} vs {expected:?}");
        }
    }

    #[test]
    fn band_2_coefficients_rotate_as_the_quadratic_form_they_encode() {
        // Band 2 is dᵀ Q d for a symmetric traceless Q; the rotated function has Q' = R Q Rᵀ.
        let quadratic = |c: &[f64]| {
            let [a, b, e, f, g] = [c[0], c[1], c[2], c[3], c[4]];
            let (xy, yz, xz) = (SH_C2[0] * a / 2.0, SH_C2[1] * b / 2.0, SH_C2[3] * f / 2.0);
            let (zz, xx_yy) = (SH_C2[2] * e, SH_C2[4] * g);
            DMat3::from_cols(
                DVec3::new(-zz + xx_yy, xy, xz),
                DVec3::new(xy, -zz - xx_yy, yz),
                DVec3::new(xz, yz, 2.0 * zz),
            )
        };
        let r = DMat3::from_rotation_y(0.4) * DMat3::from_rotation_z(-2.3);
        let c = [0.0, 0.0, 0.0, 0.2, -0.6, 0.9, 0.1, -0.3];
        let mut got = c;
        ShRotation::from_mat3(r).rotate_channel(&mut got);
        let expected = r * quadratic(&c[3..]) * r.transpose();
        let found = quadratic(&got[3..]);
        assert!(found.abs_diff_eq(expected, 1e-13), "{found} vs {expected}");
        assert_eq!(&got[..3], &c[..3], "band 1 stays zero");
    }

    #[test]
    fn identity_is_a_no_op_and_inverse_rotation_round_trips() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let c: Vec<f64> = (0..15).map(|_| rng.random_range(-1.0..1.0)).collect();
        let mut same = c.clone();
        ShRotation::from_mat3(DMat3::IDENTITY).rotate_channel(&mut same);
        for (a, b) in same.iter().zip(&c) {
            assert!((a - b).abs() < 1e-14, "identity: {same:?}");
        }
        for _ in 0..20 {
            let r = random_rotation(&mut rng);
            let mut there_and_back = c.clone();
            ShRotation::from_mat3(r).rotate_channel(&mut there_and_back);
            ShRotation::from_mat3(r.transpose()).rotate_channel(&mut there_and_back);
            for (a, b) in there_and_back.iter().zip(&c) {
                assert!((a - b).abs() < 1e-12, "round trip: {there_and_back:?}");
            }
        }
    }

    #[test]
    fn composed_rotations_compose_band_matrices() {
        // M(R2 R1) = M(R2) M(R1): rotating twice equals rotating once by the product.
        let (r1, r2) = (DMat3::from_rotation_x(0.9), DMat3::from_rotation_y(-0.5));
        let c: Vec<f64> = (0..15).map(|j| (j as f64 * 0.37).sin()).collect();
        let mut twice = c.clone();
        ShRotation::from_mat3(r1).rotate_channel(&mut twice);
        ShRotation::from_mat3(r2).rotate_channel(&mut twice);
        let mut once = c;
        ShRotation::from_mat3(r2 * r1).rotate_channel(&mut once);
        for (a, b) in twice.iter().zip(&once) {
            assert!((a - b).abs() < 1e-12, "{twice:?} vs {once:?}");
        }
    }

    #[test]
    fn cloud_rotation_keeps_channels_apart_and_skips_identity_and_degree_0() {
        let mut cloud = GaussianCloud::with_capacity(2, 24);
        for i in 0..2 {
            cloud.positions.push([0.0; 3]);
            cloud.sh_dc.push([0.1, 0.2, 0.3]);
            cloud.opacity_logit.push(0.0);
            cloud.log_scales.push([-3.0; 3]);
            cloud.rotations_wxyz.push([1.0, 0.0, 0.0, 0.0]);
            cloud
                .sh_rest
                .extend((0..24).map(|j| ((i * 24 + j) as f32 * 0.21).cos()));
        }
        let before = cloud.clone();
        rotate_cloud_sh(&mut cloud, Quat::IDENTITY);
        assert_eq!(cloud, before, "identity leaves the cloud bit-identical");

        let q = Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2);
        rotate_cloud_sh(&mut cloud, q);
        let m = ShRotation::from_quat(q);
        for i in 0..2 {
            for ch in 0..3 {
                let at = i * 24 + ch * 8;
                let mut expected: Vec<f64> = before.sh_rest[at..at + 8]
                    .iter()
                    .map(|&v| f64::from(v))
                    .collect();
                m.rotate_channel(&mut expected);
                let got = &cloud.sh_rest[at..at + 8];
                for (g, e) in got.iter().zip(&expected) {
                    assert_eq!(*g, *e as f32, "Gaussian {i} channel {ch}");
                }
            }
        }
        assert_eq!(cloud.sh_dc, before.sh_dc, "DC is rotation invariant");

        let mut flat = GaussianCloud::with_capacity(0, 0);
        rotate_cloud_sh(&mut flat, q);
        assert!(flat.sh_rest.is_empty());
    }
}
