//! A set of 3D Gaussians in the INRIA 3DGS parameterisation (Kerbl et al. 2023).
//!
//! Values are stored exactly as a trainer writes them (log scales, logit opacity, raw
//! quaternions), so that PLY -> [`GaussianCloud`] -> PLY is bit-exact. Use the decoding
//! accessors ([`GaussianCloud::scale`], [`GaussianCloud::opacity`],
//! [`GaussianCloud::rotation`], [`GaussianCloud::covariance`]) to get physical values.
//! [`sh_rotation`] turns the SH colour coefficients along with a rotation of the cloud.

pub mod sh_rotation;

use glam::{Mat3, Quat, Vec3};

/// Number of SH coefficients per colour channel for an SH degree (0..=3): (degree + 1)².
pub const fn sh_coeffs_per_channel(degree: u8) -> usize {
    (degree as usize + 1) * (degree as usize + 1)
}

/// Gaussians in struct-of-arrays form, `N` = [`GaussianCloud::len`].
///
/// Frame: the file's own frame and units until a scene transform is applied
/// (`scene::transform::apply_similarity`); after that world metres, z up.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GaussianCloud {
    /// `[N][3]` centre positions (m once placed in the world).
    pub positions: Vec<[f32; 3]>,
    /// `[N][3]` normals when the file had `nx ny nz`, else `None`. Unused by the physics.
    pub normals: Option<Vec<[f32; 3]>>,
    /// SH degree 0..=3.
    pub sh_degree: u8,
    /// `[N][3]` SH DC coefficients `f_dc_0..2` (one per RGB channel).
    pub sh_dc: Vec<[f32; 3]>,
    /// `[N][3 * (K - 1)]` flattened, `K` = [`sh_coeffs_per_channel`]: the `f_rest_*` values in
    /// file order (INRIA: channel-major, all R coefficients, then G, then B). Empty for degree 0
    /// files that carry no `f_rest_*` properties; all zeros when the file stores zeros.
    pub sh_rest: Vec<f32>,
    /// Number of `f_rest_*` properties per Gaussian as found in the file (0, 9, 24 or 45).
    pub sh_rest_len: usize,
    /// `[N]` opacity logits (opacity = sigmoid(logit)).
    pub opacity_logit: Vec<f32>,
    /// `[N][3]` natural-log scales (standard deviations in file units).
    pub log_scales: Vec<[f32; 3]>,
    /// `[N][4]` rotation quaternions `w x y z` exactly as stored (not always unit length).
    pub rotations_wxyz: Vec<[f32; 4]>,
    /// Extra per-vertex properties kept by name, each `[N]` (semantic features `feat_*`...).
    pub extra: Vec<(String, Vec<f32>)>,
}

impl GaussianCloud {
    /// An empty cloud with room for `n` Gaussians carrying `sh_rest_len` `f_rest_*` values each
    /// (0, 9, 24 or 45); the SH degree is the one that count implies.
    pub fn with_capacity(n: usize, sh_rest_len: usize) -> Self {
        Self {
            positions: Vec::with_capacity(n),
            sh_degree: match sh_rest_len {
                0 => 0,
                9 => 1,
                24 => 2,
                _ => 3,
            },
            sh_dc: Vec::with_capacity(n),
            sh_rest: Vec::with_capacity(n * sh_rest_len),
            sh_rest_len,
            opacity_logit: Vec::with_capacity(n),
            log_scales: Vec::with_capacity(n),
            rotations_wxyz: Vec::with_capacity(n),
            ..Self::default()
        }
    }

    /// Number of Gaussians.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// True when there are no Gaussians.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Centre of Gaussian `i`.
    pub fn position(&self, i: usize) -> Vec3 {
        Vec3::from(self.positions[i])
    }

    /// Standard deviations (exp of the log scales) of Gaussian `i`.
    pub fn scale(&self, i: usize) -> Vec3 {
        Vec3::from(self.log_scales[i]).exp()
    }

    /// Opacity in [0, 1] (sigmoid of the stored logit) of Gaussian `i`.
    pub fn opacity(&self, i: usize) -> f32 {
        1.0 / (1.0 + (-self.opacity_logit[i]).exp())
    }

    /// Unit rotation of Gaussian `i` (the stored quaternion normalised; identity if degenerate).
    pub fn rotation(&self, i: usize) -> Quat {
        let [w, x, y, z] = self.rotations_wxyz[i];
        let q = Quat::from_xyzw(x, y, z, w);
        let n = q.length();
        if n.is_finite() && n > 1e-12 {
            q / n
        } else {
            Quat::IDENTITY
        }
    }

    /// Covariance Σ0 = R S² Rᵀ of Gaussian `i` (file units squared).
    pub fn covariance(&self, i: usize) -> Mat3 {
        let r = Mat3::from_quat(self.rotation(i));
        let s = self.scale(i);
        let rs = r * Mat3::from_diagonal(s);
        rs * rs.transpose()
    }

    /// All SH coefficients of Gaussian `i` as `[K][3]` RGB triples, DC first, in the order the
    /// renderer evaluates them (coefficient-major). `K` = [`sh_coeffs_per_channel`].
    pub fn sh_coefficients(&self, i: usize) -> Vec<[f32; 3]> {
        let k = sh_coeffs_per_channel(self.sh_degree);
        let mut out = Vec::with_capacity(k);
        out.push(self.sh_dc[i]);
        let rest = k - 1;
        if rest > 0 && self.sh_rest_len >= 3 * rest {
            let base = &self.sh_rest[i * self.sh_rest_len..(i + 1) * self.sh_rest_len];
            for j in 0..rest {
                out.push([base[j], base[rest + j], base[2 * rest + j]]);
            }
        } else {
            out.resize(k, [0.0; 3]);
        }
        out
    }

    /// Turns every Gaussian by the proper rotation `rotation` (about the origin): centres,
    /// orientations (q' = R ⊗ q) and the SH coefficients of degrees 1 to 3 ([`sh_rotation`]),
    /// so each Gaussian shows towards R d the colour it showed towards d. Scales, opacity and DC
    /// are unchanged; normals turn too.
    pub fn rotate(&mut self, rotation: glam::DMat3) {
        let r = rotation.as_mat3();
        let q = Quat::from_mat3(&r).normalize();
        for p in &mut self.positions {
            *p = (r * Vec3::from(*p)).to_array();
        }
        if let Some(normals) = &mut self.normals {
            for n in normals {
                *n = (r * Vec3::from(*n)).to_array();
            }
        }
        for w in &mut self.rotations_wxyz {
            let turned = q * Quat::from_xyzw(w[1], w[2], w[3], w[0]);
            *w = [turned.w, turned.x, turned.y, turned.z];
        }
        if self.sh_rest_len >= 9 {
            let m = sh_rotation::ShRotation::from_mat3(rotation);
            for rest in self.sh_rest.chunks_exact_mut(self.sh_rest_len) {
                m.rotate_gaussian(rest);
            }
        }
    }

    /// Appends the Gaussians of `more`. SH degrees may differ: the lower one's missing higher
    /// coefficients become zeros. Extra properties are kept when both clouds carry the same
    /// names in the same order, and dropped otherwise; normals likewise.
    pub fn append(&mut self, mut more: GaussianCloud) {
        if self.is_empty() && self.sh_rest_len == 0 && self.extra.is_empty() {
            *self = more;
            return;
        }
        let rest_len = self.sh_rest_len.max(more.sh_rest_len);
        self.widen_sh(rest_len);
        more.widen_sh(rest_len);
        let same_extra = self.extra.len() == more.extra.len()
            && self.extra.iter().zip(&more.extra).all(|(a, b)| a.0 == b.0);
        if same_extra {
            for (a, b) in self.extra.iter_mut().zip(more.extra.iter_mut()) {
                a.1.append(&mut b.1);
            }
        } else {
            self.extra.clear();
        }
        match (&mut self.normals, &mut more.normals) {
            (Some(a), Some(b)) => a.append(b),
            _ => self.normals = None,
        }
        self.positions.append(&mut more.positions);
        self.sh_dc.append(&mut more.sh_dc);
        self.sh_rest.append(&mut more.sh_rest);
        self.opacity_logit.append(&mut more.opacity_logit);
        self.log_scales.append(&mut more.log_scales);
        self.rotations_wxyz.append(&mut more.rotations_wxyz);
    }

    /// Pads each Gaussian's channel-major `f_rest` to `rest_len` values (0, 9, 24 or 45): zeros
    /// for the missing higher coefficients of every channel. No-op when it already has as many.
    pub fn widen_sh(&mut self, rest_len: usize) {
        let (from_k, to_k) = (self.sh_rest_len / 3, rest_len / 3);
        if to_k <= from_k {
            return;
        }
        let n = self.len();
        let mut rest = vec![0.0f32; n * rest_len];
        for i in 0..n {
            for c in 0..3 {
                let src = &self.sh_rest[i * self.sh_rest_len + c * from_k..][..from_k];
                rest[i * rest_len + c * to_k..][..from_k].copy_from_slice(src);
            }
        }
        self.sh_rest = rest;
        self.sh_rest_len = rest_len;
        self.sh_degree = match rest_len {
            9 => 1,
            24 => 2,
            _ => 3,
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn widening_keeps_each_channel_block() {
        let mut c = GaussianCloud::with_capacity(1, 9);
        c.positions.push([0.0; 3]);
        c.sh_rest
            .extend_from_slice(&[1., 2., 3., 4., 5., 6., 7., 8., 9.]);
        c.widen_sh(24);
        assert_eq!(c.sh_rest[0..3], [1., 2., 3.]);
        assert_eq!(c.sh_rest[3..8], [0.; 5]);
        assert_eq!(c.sh_rest[8..11], [4., 5., 6.]);
        assert_eq!(c.sh_rest[16..19], [7., 8., 9.]);
        assert_eq!(c.sh_degree, 2);
    }
}
