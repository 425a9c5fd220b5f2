//! Helpers shared by the integration tests: a deterministic generator and scene builders.
#![allow(dead_code)]

use glam::{Mat3, Quat, Vec3};
use splatphys_render::Splats;

/// splitmix64, enough for reproducible test scenes.
pub struct SplitMix(pub u64);

impl SplitMix {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit()
    }

    pub fn unit_quat(&mut self) -> Quat {
        Quat::from_xyzw(
            self.range(-1.0, 1.0),
            self.range(-1.0, 1.0),
            self.range(-1.0, 1.0),
            self.range(-1.0, 1.0),
        )
        .normalize()
    }
}

/// Upper triangle `xx, xy, xz, yy, yz, zz` of a symmetric matrix.
pub fn sym6(c: Mat3) -> [f32; 6] {
    [
        c.x_axis.x, c.y_axis.x, c.z_axis.x, c.y_axis.y, c.z_axis.y, c.z_axis.z,
    ]
}

/// Symmetric matrix from its upper triangle.
pub fn mat_from6(c: [f32; 6]) -> Mat3 {
    Mat3::from_cols(
        Vec3::new(c[0], c[1], c[2]),
        Vec3::new(c[1], c[3], c[4]),
        Vec3::new(c[2], c[4], c[5]),
    )
}

/// Covariance R diag(s²) Rᵀ.
pub fn covariance(rotation: Quat, scales: Vec3) -> [f32; 6] {
    let rs = Mat3::from_quat(rotation) * Mat3::from_diagonal(scales);
    sym6(rs * rs.transpose())
}

/// Appends one Gaussian with SH coefficients `sh` (`K` triples, matching `splats.sh_degree`).
pub fn push(splats: &mut Splats, p: Vec3, cov: [f32; 6], opacity: f32, sh: &[[f32; 3]]) {
    splats.positions.push(p.to_array());
    splats.covariances.push(cov);
    splats.opacities.push(opacity);
    splats.sh.extend_from_slice(sh);
}

/// SH DC coefficient that evaluates to colour `c` (degree 0: c = C0 · dc + 0.5).
pub fn dc_for(c: [f32; 3]) -> [f32; 3] {
    c.map(|v| (v - 0.5) / splatphys_render::sh::SH_C0)
}

/// `n` random Gaussians in a cube of half-size `half_m` around the origin, SH degree `degree`
/// with random coefficients, anisotropic covariances (σ 5-60 mm), opacities 0.2-1.
pub fn random_scene(seed: u64, n: usize, half_m: f32, degree: u8) -> Splats {
    let mut rng = SplitMix(seed);
    let k = (degree as usize + 1).pow(2);
    let mut s = Splats {
        sh_degree: degree,
        ..Splats::default()
    };
    for _ in 0..n {
        let p = Vec3::new(
            rng.range(-half_m, half_m),
            rng.range(-half_m, half_m),
            rng.range(-half_m, half_m),
        );
        let scales = Vec3::new(
            rng.range(0.005, 0.06),
            rng.range(0.005, 0.06),
            rng.range(0.005, 0.06),
        );
        let q = rng.unit_quat();
        let mut sh = Vec::with_capacity(k);
        for j in 0..k {
            let amp = if j == 0 { 1.5 } else { 0.6 };
            sh.push([
                rng.range(-amp, amp),
                rng.range(-amp, amp),
                rng.range(-amp, amp),
            ]);
        }
        let o = rng.range(0.2, 1.0);
        push(&mut s, p, covariance(q, scales), o, &sh);
    }
    s
}
