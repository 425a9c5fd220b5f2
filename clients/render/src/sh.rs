//! Real spherical harmonics up to degree 3 evaluated as in the 3DGS reference rasterizer
//! (Kerbl et al. 2023, sec. 4; `computeColorFromSH` in `forward.cu`, constants from
//! Sloan, "Stupid Spherical Harmonics Tricks", 2008): colour = Σ c_lm Y_lm(d) + 0.5, clamped
//! below at 0 (not above: values over 1 are clamped only when the image is quantised).

use glam::Vec3;

/// Y_00.
pub const SH_C0: f32 = 0.282_094_8;
/// Degree-1 constant.
pub const SH_C1: f32 = 0.488_602_5;
/// Degree-2 constants.
pub const SH_C2: [f32; 5] = [
    1.092_548_4,
    -1.092_548_4,
    0.315_391_57,
    -1.092_548_4,
    0.546_274_2,
];
/// Degree-3 constants.
pub const SH_C3: [f32; 7] = [
    -0.590_043_6,
    2.890_611_4,
    -0.457_045_8,
    0.373_176_33,
    -0.457_045_8,
    1.445_305_7,
    -0.590_043_6,
];

/// Number of coefficients per channel for `degree` (capped at 3): (degree + 1)².
pub const fn coeffs_for_degree(degree: u8) -> usize {
    let d = if degree > 3 { 3 } else { degree as usize };
    (d + 1) * (d + 1)
}

/// RGB colour of one Gaussian seen along unit direction `dir` (from the camera towards the
/// Gaussian, in the Gaussian's own frame), from its `[K][3]` coefficients (`K >= (degree+1)²`,
/// DC first). Degrees above 3 are treated as 3.
pub fn eval_sh(degree: u8, coeffs: &[[f32; 3]], dir: Vec3) -> [f32; 3] {
    let sh = |i: usize| Vec3::from(coeffs[i]);
    let mut result = SH_C0 * sh(0);
    if degree > 0 {
        let (x, y, z) = (dir.x, dir.y, dir.z);
        result = result - SH_C1 * y * sh(1) + SH_C1 * z * sh(2) - SH_C1 * x * sh(3);
        if degree > 1 {
            let (xx, yy, zz) = (x * x, y * y, z * z);
            let (xy, yz, xz) = (x * y, y * z, x * z);
            result = result
                + SH_C2[0] * xy * sh(4)
                + SH_C2[1] * yz * sh(5)
                + SH_C2[2] * (2.0 * zz - xx - yy) * sh(6)
                + SH_C2[3] * xz * sh(7)
                + SH_C2[4] * (xx - yy) * sh(8);
            if degree > 2 {
                result = result
                    + SH_C3[0] * y * (3.0 * xx - yy) * sh(9)
                    + SH_C3[1] * xy * z * sh(10)
                    + SH_C3[2] * y * (4.0 * zz - xx - yy) * sh(11)
                    + SH_C3[3] * z * (2.0 * zz - 3.0 * xx - 3.0 * yy) * sh(12)
                    + SH_C3[4] * x * (4.0 * zz - xx - yy) * sh(13)
                    + SH_C3[5] * z * (xx - yy) * sh(14)
                    + SH_C3[6] * x * (xx - 3.0 * yy) * sh(15);
            }
        }
    }
    let c = (result + Vec3::splat(0.5)).max(Vec3::ZERO);
    c.to_array()
}
