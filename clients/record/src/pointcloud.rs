//! `foxglove.PointCloud` messages (JSON encoding) from a frame and the scene's colours.
//!
//! Each point is 16 bytes: x, y, z as f32 (metres) then r, g, b, a as u8. The colour is the SH
//! DC term evaluated as in 3DGS, c = 0.5 + 0.2820948 · dc, clamped to [0, 1]; alpha is the
//! opacity.

use base64::Engine;
use base64::engine::general_purpose::STANDARD;
use splatphys_ipc::wire::{FrameGaussian, SceneGaussian};

/// Bytes per point.
pub const POINT_STRIDE: usize = 16;
/// SH band-0 constant, 1 / (2 √π).
const SH_C0: f32 = 0.282_094_8;

/// RGBA8 colour of every Gaussian of a scene.
pub fn colours(scene: &[SceneGaussian]) -> Vec<[u8; 4]> {
    let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    scene
        .iter()
        .map(|g| {
            [
                q(0.5 + SH_C0 * g.sh[0]),
                q(0.5 + SH_C0 * g.sh[1]),
                q(0.5 + SH_C0 * g.sh[2]),
                q(g.opacity),
            ]
        })
        .collect()
}

/// One `foxglove.PointCloud` JSON message for a frame at `time_s`. Gaussians without a colour
/// (scene not received yet) are grey.
pub fn pointcloud_json(frame: &[FrameGaussian], colours: &[[u8; 4]], time_s: f64) -> Vec<u8> {
    let mut data = Vec::with_capacity(frame.len() * POINT_STRIDE);
    for (i, g) in frame.iter().enumerate() {
        for x in g.position_m {
            data.extend_from_slice(&x.to_le_bytes());
        }
        data.extend_from_slice(colours.get(i).unwrap_or(&[128, 128, 128, 255]));
    }
    let sec = time_s.max(0.0).floor();
    let nsec = ((time_s.max(0.0) - sec) * 1e9).round().min(999_999_999.0);
    let mut json = format!(
        concat!(
            r#"{{"timestamp":{{"sec":{},"nsec":{}}},"frame_id":"world","#,
            r#""pose":{{"position":{{"x":0,"y":0,"z":0}},"orientation":{{"x":0,"y":0,"z":0,"w":1}}}},"#,
            r#""point_stride":16,"fields":[{{"name":"x","offset":0,"type":7}},{{"name":"y","offset":4,"type":7}},"#,
            r#"{{"name":"z","offset":8,"type":7}},{{"name":"red","offset":12,"type":1}},{{"name":"green","offset":13,"type":1}},"#,
            r#"{{"name":"blue","offset":14,"type":1}},{{"name":"alpha","offset":15,"type":1}}],"data":""#
        ),
        sec as u64, nsec as u64,
    );
    json.reserve(data.len().div_ceil(3) * 4 + 2);
    STANDARD.encode_string(&data, &mut json);
    json.push_str("\"}");
    json.into_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pointcloud_is_valid_json_with_16_bytes_per_point() {
        let frame = vec![FrameGaussian::default(); 5];
        let msg = pointcloud_json(&frame, &[], 1.25);
        let v: serde_json::Value = serde_json::from_slice(&msg).unwrap();
        assert_eq!(v["point_stride"], 16);
        assert_eq!(v["timestamp"]["nsec"], 250_000_000);
        // 5 points x 16 bytes = 80 bytes -> 108 base64 characters (27 groups of 4).
        let data = v["data"].as_str().unwrap();
        assert_eq!(data.len(), 108);
        // Decodes back to the points: zero positions, grey opaque colour.
        let bytes = STANDARD.decode(data).unwrap();
        assert_eq!(bytes.len(), 80);
        assert_eq!(
            &bytes[..16],
            &[0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 128, 128, 128, 255]
        );
    }
}
