//! The binary WebSocket messages from the bridge to the page (little-endian, 4-byte aligned).
//!
//! `scene` (once per scene generation, before its frames), header 32 bytes:
//! `u32 kind = 1, u32 generation, u32 N, u32 sh_degree, u32 object_count, u32 reserved,
//! f64 frame_dt_s`, then `sh: f32[N][K][3]` with K = (sh_degree + 1)², coefficient-major, RGB
//! inner, DC first; `opacity: f32[N]` (after the sigmoid); `object_id: u32[N]`
//! (`u32::MAX` = captured background).
//!
//! `frame` (each frame the page takes), header 48 bytes: `u32 kind = 2, u32 generation, u32 N,
//! u32 M, u64 step, f64 time_s, u64 publish_unix_ns, f64 reserved`, then `index: u32[M]`,
//! `position_m: f32[M][3]`, `covariance_m2: f32[M][6]` (upper triangle xx, xy, xz, yy, yz, zz),
//! `rotation_wxyz: f32[M][4]`. Only the Gaussians that changed since the frame the page holds
//! are sent (M = N for the first frame of a generation), as exact f32: the page's image is that
//! of the published state, with no packing error.

use splatphys_ipc::wire::{FrameGaussian, FrameHeader, SceneGaussian, SceneHeader};

/// `kind` of a scene message.
pub const SCENE_KIND: u32 = 1;
/// `kind` of a frame message.
pub const FRAME_KIND: u32 = 2;
/// Bytes before the arrays of a scene message.
pub const SCENE_HEADER_BYTES: usize = 32;
/// Bytes before the arrays of a frame message.
pub const FRAME_HEADER_BYTES: usize = 48;
/// Bytes per Gaussian in a frame message: index, position, covariance, rotation.
pub const FRAME_BYTES_PER_GAUSSIAN: usize = 4 + 12 + 24 + 16;

/// SH coefficients per colour channel at `degree` (clamped to 3).
pub fn sh_coefficients(degree: u32) -> usize {
    let d = degree.min(3) as usize + 1;
    d * d
}

/// Size of a scene message of `n` Gaussians at SH `degree`, bytes.
pub fn scene_message_bytes(n: usize, degree: u32) -> usize {
    SCENE_HEADER_BYTES + n * (sh_coefficients(degree) * 3 * 4 + 4 + 4)
}

/// Size of a frame message carrying `m` Gaussians, bytes.
pub fn frame_message_bytes(m: usize) -> usize {
    FRAME_HEADER_BYTES + m * FRAME_BYTES_PER_GAUSSIAN
}

fn put_u32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_f32s(out: &mut Vec<u8>, v: &[f32]) {
    for x in v {
        out.extend_from_slice(&x.to_le_bytes());
    }
}

/// The scene message of one generation.
pub fn scene_message(h: &SceneHeader, gaussians: &[SceneGaussian]) -> Vec<u8> {
    let k = sh_coefficients(h.sh_degree);
    let n = gaussians.len();
    let mut out = Vec::with_capacity(scene_message_bytes(n, h.sh_degree));
    for v in [
        SCENE_KIND,
        h.scene_generation,
        n as u32,
        h.sh_degree.min(3),
        h.object_count,
        0,
    ] {
        put_u32(&mut out, v);
    }
    out.extend_from_slice(&h.frame_dt_s.to_le_bytes());
    for g in gaussians {
        put_f32s(&mut out, &g.sh[..k * 3]);
    }
    for g in gaussians {
        put_f32s(&mut out, &[g.opacity]);
    }
    for g in gaussians {
        put_u32(&mut out, g.object_id);
    }
    out
}

/// The indices of the Gaussians of `frame` that differ (bit for bit) from `previous`; all of
/// them when there is no previous frame of the same length.
pub fn changed(frame: &[FrameGaussian], previous: Option<&[FrameGaussian]>) -> Vec<u32> {
    match previous {
        Some(p) if p.len() == frame.len() => frame
            .iter()
            .zip(p)
            .enumerate()
            .filter(|(_, (a, b))| bytemuck::bytes_of(*a) != bytemuck::bytes_of(*b))
            .map(|(i, _)| i as u32)
            .collect(),
        _ => (0..frame.len() as u32).collect(),
    }
}

/// The frame message carrying the Gaussians `indices` of `frame`.
pub fn frame_message(h: &FrameHeader, frame: &[FrameGaussian], indices: &[u32]) -> Vec<u8> {
    let mut out = Vec::with_capacity(frame_message_bytes(indices.len()));
    for v in [
        FRAME_KIND,
        h.scene_generation,
        frame.len() as u32,
        indices.len() as u32,
    ] {
        put_u32(&mut out, v);
    }
    out.extend_from_slice(&h.step.to_le_bytes());
    out.extend_from_slice(&h.time_s.to_le_bytes());
    out.extend_from_slice(&h.publish_unix_ns.to_le_bytes());
    out.extend_from_slice(&0f64.to_le_bytes());
    for &i in indices {
        put_u32(&mut out, i);
    }
    for &i in indices {
        put_f32s(&mut out, &frame[i as usize].position_m);
    }
    for &i in indices {
        put_f32s(&mut out, &frame[i as usize].covariance_m2);
    }
    for &i in indices {
        put_f32s(&mut out, &frame[i as usize].rotation_wxyz);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn u32_at(b: &[u8], at: usize) -> u32 {
        u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
    }

    fn f32_at(b: &[u8], at: usize) -> f32 {
        f32::from_le_bytes(b[at..at + 4].try_into().unwrap())
    }

    fn gaussian(i: usize) -> FrameGaussian {
        let x = i as f32;
        FrameGaussian {
            position_m: [x, x + 0.5, -x],
            covariance_m2: [1.0, 2.0, 3.0, 4.0, 5.0, x],
            rotation_wxyz: [1.0, 0.0, 0.0, x],
        }
    }

    #[test]
    fn scene_message_has_the_documented_layout() {
        let mut gs = vec![SceneGaussian::default(); 3];
        for (i, g) in gs.iter_mut().enumerate() {
            g.sh[0] = i as f32;
            g.sh[3] = 10.0 + i as f32; // first coefficient of band 1, red
            g.opacity = 0.25 * i as f32;
            g.object_id = if i == 2 { u32::MAX } else { i as u32 };
        }
        let h = SceneHeader {
            scene_generation: 7,
            sh_degree: 1,
            object_count: 2,
            frame_dt_s: 0.5,
            ..SceneHeader::default()
        };
        let b = scene_message(&h, &gs);
        assert_eq!(b.len(), scene_message_bytes(3, 1));
        assert_eq!(b.len(), 32 + 3 * (4 * 3 * 4 + 8));
        assert_eq!(
            [0, 4, 8, 12, 16].map(|o| u32_at(&b, o)),
            [SCENE_KIND, 7, 3, 1, 2]
        );
        assert_eq!(f64::from_le_bytes(b[24..32].try_into().unwrap()), 0.5);
        let sh = 32;
        let per = 4 * 3 * 4;
        assert_eq!(f32_at(&b, sh + 2 * per), 2.0, "Gaussian 2, DC red");
        assert_eq!(
            f32_at(&b, sh + 2 * per + 12),
            12.0,
            "Gaussian 2, band 1 red"
        );
        let opacity = sh + 3 * per;
        assert_eq!(f32_at(&b, opacity + 4), 0.25);
        let ids = opacity + 12;
        assert_eq!(u32_at(&b, ids + 8), u32::MAX);
    }

    #[test]
    fn a_frame_carries_only_what_changed_and_every_value_exactly() {
        let previous: Vec<FrameGaussian> = (0..10).map(gaussian).collect();
        let mut frame = previous.clone();
        // One ulp is a change.
        frame[3].position_m[2] = f32::from_bits(frame[3].position_m[2].to_bits() + 1);
        frame[8].rotation_wxyz[1] = 0.1;
        let indices = changed(&frame, Some(&previous));
        assert_eq!(indices, [3, 8]);
        assert_eq!(changed(&frame, None).len(), 10);
        assert_eq!(changed(&frame, Some(&previous[..9])).len(), 10);

        let h = FrameHeader {
            step: 42,
            time_s: 1.25,
            scene_generation: 2,
            publish_unix_ns: 123_456_789,
            ..FrameHeader::default()
        };
        let b = frame_message(&h, &frame, &indices);
        assert_eq!(b.len(), frame_message_bytes(2));
        assert_eq!(b.len(), 48 + 2 * 56);
        assert_eq!([0, 4, 8, 12].map(|o| u32_at(&b, o)), [FRAME_KIND, 2, 10, 2]);
        assert_eq!(u64::from_le_bytes(b[16..24].try_into().unwrap()), 42);
        assert_eq!(f64::from_le_bytes(b[24..32].try_into().unwrap()), 1.25);
        assert_eq!(
            u64::from_le_bytes(b[32..40].try_into().unwrap()),
            123_456_789
        );
        let (idx, pos, cov, rot) = (48, 56, 56 + 24, 56 + 24 + 48);
        assert_eq!([u32_at(&b, idx), u32_at(&b, idx + 4)], [3, 8]);
        assert_eq!(f32_at(&b, pos + 8), frame[3].position_m[2]);
        assert_eq!(f32_at(&b, cov + 24 + 20), frame[8].covariance_m2[5]);
        assert_eq!(f32_at(&b, rot + 16 + 4), 0.1);
    }
}
