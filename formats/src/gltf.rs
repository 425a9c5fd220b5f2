//! glTF 2.0 with `KHR_gaussian_splatting` (Khronos, release candidate; KhronosGroup/glTF
//! `extensions/2.0/Khronos/KHR_gaussian_splatting/README.md` at 63770cc, April 2026): a GLB or
//! a `.gltf` whose mesh primitives (mode POINTS) carry Gaussians as vertex attributes.
//!
//! Attributes: `POSITION` (VEC3), `KHR_gaussian_splatting:ROTATION` (VEC4 unit quaternion x, y,
//! z, w; float or normalized signed byte/short), `:SCALE` (VEC3, linear; float or unsigned
//! byte/short, normalized or not), `:OPACITY` (SCALAR, after the sigmoid; float or normalized
//! unsigned byte/short), `:SH_DEGREE_0_COEF_0` (VEC3, the raw DC coefficient) and
//! `:SH_DEGREE_l_COEF_n` for l = 1..3, n = 0..2l (m ascending). The glTF crate maps every such
//! attribute to one invalid key, so the chunks and the JSON are read here directly.
//!
//! Node transforms apply: each Gaussian's centre is moved by its node's global matrix M and its
//! covariance becomes M Σ Mᵀ (decomposed back into scales and a rotation); SH turn with the
//! rotation of M. The result is then turned from glTF's frame (+Y up, +Z forward, +X left) into
//! PLY's (x right, y down, z forward), a half turn about z, so a GLB and the PLY it was made
//! from load alike. The SPZ-compressed variant (`KHR_gaussian_splatting_compression_spz_2`,
//! draft PR #2531 at 90db926: an SPZ file in a buffer view, stored in glTF's frame) is read too.

use std::path::{Path, PathBuf};

use base64::Engine;
use glam::{DMat3, DMat4, DQuat, DVec3};
use serde_json::Value;

use super::{FormatError, read_bytes};
use crate::gaussians::GaussianCloud;
use crate::gaussians::sh_rotation::ShRotation;
use crate::splat::alpha_to_logit;

/// The magic number that starts a GLB (`glTF`).
pub const GLB_MAGIC: &[u8; 4] = b"glTF";
const EXT: &str = "KHR_gaussian_splatting";
const SPZ_EXT: &str = "KHR_gaussian_splatting_compression_spz_2";

/// Reads a GLB or `.gltf` holding `KHR_gaussian_splatting` primitives (every one in the default
/// scene, or in every root node when the file names no scene), in PLY's frame.
///
/// # Errors
/// [`FormatError::Io`]; [`FormatError::Layout`] naming the JSON path for a malformed container,
/// a missing or ill-typed accessor, a buffer too short, or a file without Gaussians.
pub fn read_gltf(path: impl AsRef<Path>) -> Result<GaussianCloud, FormatError> {
    let path = path.as_ref();
    parse_gltf(path, &read_bytes(path)?)
}

fn bad(path: &Path, element: impl Into<String>, problem: impl Into<String>) -> FormatError {
    FormatError::Layout {
        path: path.to_path_buf(),
        element: element.into(),
        problem: problem.into(),
    }
}

/// Parses GLB or glTF JSON `bytes`; `path` names the file in errors and locates external
/// buffers.
///
/// # Errors
/// As [`read_gltf`].
pub fn parse_gltf(path: &Path, bytes: &[u8]) -> Result<GaussianCloud, FormatError> {
    let (json, bin) = if bytes.starts_with(GLB_MAGIC) {
        split_glb(path, bytes)?
    } else {
        (bytes, None)
    };
    let doc: Value = serde_json::from_slice(json)
        .map_err(|e| bad(path, "JSON", format!("not glTF JSON: {e}")))?;
    let gltf = Gltf {
        path: path.to_path_buf(),
        buffers: load_buffers(path, &doc, bin)?,
        doc,
    };
    let mut cloud: Option<GaussianCloud> = None;
    for (mesh, matrix) in gltf.mesh_instances()? {
        let prims = gltf.doc["meshes"][mesh]["primitives"]
            .as_array()
            .cloned()
            .unwrap_or_default();
        for (p, prim) in prims.iter().enumerate() {
            let Some(ext) = prim["extensions"].get(EXT) else {
                continue;
            };
            let at = format!("meshes[{mesh}].primitives[{p}]");
            let mut part = match ext["extensions"].get(SPZ_EXT) {
                Some(spz) => gltf.spz_primitive(&at, spz)?,
                None => gltf.primitive(&at, prim)?,
            };
            transform(&mut part, matrix);
            match &mut cloud {
                None => cloud = Some(part),
                Some(c) => c.append(part),
            }
        }
    }
    let mut cloud = cloud.ok_or_else(|| {
        bad(
            path,
            "meshes",
            format!("no primitive with {EXT} in the scene"),
        )
    })?;
    // glTF (x left, y up, z forward) → PLY (x right, y down, z forward): a half turn about z.
    transform(&mut cloud, DMat4::from_rotation_z(std::f64::consts::PI));
    Ok(cloud)
}

fn split_glb<'a>(path: &Path, b: &'a [u8]) -> Result<(&'a [u8], Option<&'a [u8]>), FormatError> {
    let u32_at = |o: usize| -> Option<usize> {
        b.get(o..o + 4)
            .map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]) as usize)
    };
    let mut at = 12;
    let (mut json, mut bin) = (None, None);
    while let (Some(len), Some(kind)) = (u32_at(at), u32_at(at + 4)) {
        let body = b
            .get(at + 8..at + 8 + len)
            .ok_or_else(|| bad(path, "GLB", format!("chunk at byte {at} runs past the end")))?;
        match kind {
            0x4E4F_534A => json = json.or(Some(body)),
            0x004E_4942 => bin = bin.or(Some(body)),
            _ => {}
        }
        at += 8 + len;
    }
    let json = json.ok_or_else(|| bad(path, "GLB", "no JSON chunk"))?;
    Ok((json, bin))
}

fn load_buffers(path: &Path, doc: &Value, bin: Option<&[u8]>) -> Result<Vec<Vec<u8>>, FormatError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut out = Vec::new();
    for (i, buffer) in doc["buffers"].as_array().into_iter().flatten().enumerate() {
        let data = match buffer["uri"].as_str() {
            None => bin
                .ok_or_else(|| {
                    bad(
                        path,
                        format!("buffers[{i}]"),
                        "no uri and no GLB binary chunk",
                    )
                })?
                .to_vec(),
            Some(uri) if uri.starts_with("data:") => {
                let b64 = uri
                    .split_once(";base64,")
                    .map(|(_, d)| d)
                    .ok_or_else(|| bad(path, format!("buffers[{i}]"), "data URI is not base64"))?;
                base64::engine::general_purpose::STANDARD
                    .decode(b64)
                    .map_err(|e| bad(path, format!("buffers[{i}]"), format!("bad base64: {e}")))?
            }
            Some(uri) => read_bytes(&dir.join(percent_decode(uri)))?,
        };
        out.push(data);
    }
    Ok(out)
}

fn percent_decode(uri: &str) -> PathBuf {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        if bytes[i] == b'%'
            && let (Some(h), Some(l)) = (
                bytes.get(i + 1).and_then(|c| hex(*c)),
                bytes.get(i + 2).and_then(|c| hex(*c)),
            )
        {
            out.push((h * 16 + l) as u8);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    PathBuf::from(String::from_utf8_lossy(&out).into_owned())
}

struct Gltf {
    path: PathBuf,
    doc: Value,
    buffers: Vec<Vec<u8>>,
}

impl Gltf {
    /// Every (mesh index, global matrix) of the default scene (or all root nodes).
    fn mesh_instances(&self) -> Result<Vec<(usize, DMat4)>, FormatError> {
        let nodes = self.doc["nodes"].as_array().cloned().unwrap_or_default();
        let roots: Vec<usize> =
            match self.doc["scenes"].get(self.doc["scene"].as_u64().unwrap_or(0) as usize) {
                Some(scene) => ids(&scene["nodes"]),
                None => {
                    let mut child = vec![false; nodes.len()];
                    for n in &nodes {
                        for c in ids(&n["children"]) {
                            if let Some(f) = child.get_mut(c) {
                                *f = true;
                            }
                        }
                    }
                    (0..nodes.len()).filter(|&i| !child[i]).collect()
                }
            };
        let mut out = Vec::new();
        let mut stack: Vec<(usize, DMat4, usize)> =
            roots.into_iter().map(|r| (r, DMat4::IDENTITY, 0)).collect();
        while let Some((n, parent, depth)) = stack.pop() {
            let node = nodes
                .get(n)
                .ok_or_else(|| bad(&self.path, "nodes", format!("node {n} does not exist")))?;
            if depth > 64 {
                return Err(bad(
                    &self.path,
                    format!("nodes[{n}]"),
                    "node hierarchy deeper than 64 (a cycle?)",
                ));
            }
            let global = parent * local_matrix(node);
            if let Some(mesh) = node["mesh"].as_u64() {
                out.push((mesh as usize, global));
            }
            for c in ids(&node["children"]) {
                stack.push((c, global, depth + 1));
            }
        }
        Ok(out)
    }

    /// The elements of accessor `a` as f64, `components` per element, normalized integers
    /// mapped as glTF says (unsigned c / max, signed max(c / max, −1)).
    fn accessor(&self, at: &str, a: usize, components: usize) -> Result<Vec<f64>, FormatError> {
        let acc = &self.doc["accessors"][a];
        let where_ = format!("{at}: accessors[{a}]");
        let err = |p: String| bad(&self.path, where_.clone(), p);
        if acc.is_null() {
            return Err(err("does not exist".into()));
        }
        if acc.get("sparse").is_some() {
            return Err(err("sparse accessors are not supported".into()));
        }
        let count = acc["count"]
            .as_u64()
            .ok_or_else(|| err("no count".into()))? as usize;
        let ctype = acc["componentType"].as_u64().unwrap_or(0);
        let normalized = acc["normalized"].as_bool().unwrap_or(false);
        let size = match ctype {
            5120 | 5121 => 1,
            5122 | 5123 => 2,
            5125 | 5126 => 4,
            t => return Err(err(format!("component type {t} unknown"))),
        };
        let Some(view_id) = acc["bufferView"].as_u64() else {
            return Err(err(
                "no bufferView (accessors without data are not supported)".into(),
            ));
        };
        let view = &self.doc["bufferViews"][view_id as usize];
        let buffer = self
            .buffers
            .get(view["buffer"].as_u64().unwrap_or(u64::MAX) as usize)
            .ok_or_else(|| err(format!("bufferView {view_id} names no buffer")))?;
        let start = view["byteOffset"].as_u64().unwrap_or(0) as usize
            + acc["byteOffset"].as_u64().unwrap_or(0) as usize;
        let stride = view["byteStride"]
            .as_u64()
            .map_or(size * components, |s| s as usize);
        let needed = match count {
            0 => Some(0),
            _ => (count - 1)
                .checked_mul(stride)
                .and_then(|b| b.checked_add(size * components)),
        }
        .ok_or_else(|| err(format!("{count} elements overflow the address space")))?;
        let data = buffer
            .get(start..start.saturating_add(needed))
            .ok_or_else(|| {
                err(format!(
                    "needs bytes {start}..{} of a {}-byte buffer",
                    start.saturating_add(needed),
                    buffer.len()
                ))
            })?;
        let mut out = Vec::with_capacity(count * components);
        for e in 0..count {
            for c in 0..components {
                let o = e * stride + c * size;
                let raw = &data[o..o + size];
                let v = match ctype {
                    5126 => f64::from(f32::from_le_bytes([raw[0], raw[1], raw[2], raw[3]])),
                    5120 => norm(f64::from(raw[0] as i8), 127.0, normalized, true),
                    5121 => norm(f64::from(raw[0]), 255.0, normalized, false),
                    5122 => norm(
                        f64::from(i16::from_le_bytes([raw[0], raw[1]])),
                        32767.0,
                        normalized,
                        true,
                    ),
                    5123 => norm(
                        f64::from(u16::from_le_bytes([raw[0], raw[1]])),
                        65535.0,
                        normalized,
                        false,
                    ),
                    _ => f64::from(u32::from_le_bytes([raw[0], raw[1], raw[2], raw[3]])),
                };
                if !v.is_finite() {
                    return Err(FormatError::NonFinite {
                        path: self.path.clone(),
                        element: where_.clone(),
                        property: format!("component {c}"),
                        row: e,
                        value: v,
                    });
                }
                out.push(v);
            }
        }
        Ok(out)
    }

    fn attribute(
        &self,
        at: &str,
        prim: &Value,
        name: &str,
        components: usize,
    ) -> Result<Option<Vec<f64>>, FormatError> {
        match prim["attributes"][name].as_u64() {
            None => Ok(None),
            Some(a) => self
                .accessor(
                    &format!("{at}.attributes[\"{name}\"]"),
                    a as usize,
                    components,
                )
                .map(Some),
        }
    }

    fn primitive(&self, at: &str, prim: &Value) -> Result<GaussianCloud, FormatError> {
        let need = |name: &str, components| {
            self.attribute(at, prim, name, components)?
                .ok_or_else(|| bad(&self.path, at, format!("attribute {name} missing")))
        };
        let pos = need("POSITION", 3)?;
        let n = pos.len() / 3;
        let rot = need("KHR_gaussian_splatting:ROTATION", 4)?;
        let scale = need("KHR_gaussian_splatting:SCALE", 3)?;
        let opacity = need("KHR_gaussian_splatting:OPACITY", 1)?;
        let dc = need("KHR_gaussian_splatting:SH_DEGREE_0_COEF_0", 3)?;
        let mut bands: Vec<Vec<f64>> = Vec::new();
        'degrees: for l in 1..=3usize {
            let mut coeffs = Vec::new();
            for m in 0..=2 * l {
                match self.attribute(
                    at,
                    prim,
                    &format!("KHR_gaussian_splatting:SH_DEGREE_{l}_COEF_{m}"),
                    3,
                )? {
                    Some(c) => coeffs.push(c),
                    None if m == 0 => break 'degrees,
                    None => {
                        return Err(bad(
                            &self.path,
                            at,
                            format!("SH degree {l} has coefficients 0..{m} only"),
                        ));
                    }
                }
            }
            bands.extend(coeffs);
        }
        for (name, len, per) in [
            ("ROTATION", rot.len(), 4),
            ("SCALE", scale.len(), 3),
            ("OPACITY", opacity.len(), 1),
            ("SH_DEGREE_0_COEF_0", dc.len(), 3),
        ]
        .into_iter()
        .chain(bands.iter().map(|b| ("SH", b.len(), 3)))
        {
            if len != per * n {
                return Err(bad(
                    &self.path,
                    at,
                    format!("{name} has {} elements, POSITION {n}", len / per),
                ));
            }
        }
        let k = bands.len();
        let mut cloud = GaussianCloud::with_capacity(n, 3 * k);
        for i in 0..n {
            cloud
                .positions
                .push([0, 1, 2].map(|c| pos[3 * i + c] as f32));
            cloud.rotations_wxyz.push(
                [rot[4 * i + 3], rot[4 * i], rot[4 * i + 1], rot[4 * i + 2]].map(|v| v as f32),
            );
            cloud.log_scales.push([0, 1, 2].map(|c| {
                let s = scale[3 * i + c].max(crate::posed::MIN_SCALE_M);
                s.ln() as f32
            }));
            cloud.opacity_logit.push(alpha_to_logit(opacity[i]));
            cloud.sh_dc.push([0, 1, 2].map(|c| dc[3 * i + c] as f32));
            for c in 0..3 {
                for b in &bands {
                    cloud.sh_rest.push(b[3 * i + c] as f32);
                }
            }
        }
        Ok(cloud)
    }

    fn spz_primitive(&self, at: &str, spz: &Value) -> Result<GaussianCloud, FormatError> {
        let view_id = spz["bufferView"]
            .as_u64()
            .ok_or_else(|| bad(&self.path, at, format!("{SPZ_EXT} without a bufferView")))?;
        let view = &self.doc["bufferViews"][view_id as usize];
        let buffer = self
            .buffers
            .get(view["buffer"].as_u64().unwrap_or(u64::MAX) as usize)
            .ok_or_else(|| {
                bad(
                    &self.path,
                    at,
                    format!("bufferView {view_id} names no buffer"),
                )
            })?;
        let start = view["byteOffset"].as_u64().unwrap_or(0) as usize;
        let len = view["byteLength"].as_u64().unwrap_or(0) as usize;
        let bytes = buffer
            .get(start..start.saturating_add(len))
            .ok_or_else(|| {
                bad(
                    &self.path,
                    at,
                    format!("bufferView {view_id} runs past its buffer"),
                )
            })?;
        crate::spz::parse_spz(&self.path, bytes, crate::spz::SpzFrame::AsStored)
    }
}

fn ids(v: &Value) -> Vec<usize> {
    v.as_array()
        .into_iter()
        .flatten()
        .filter_map(|x| x.as_u64().map(|x| x as usize))
        .collect()
}

fn norm(v: f64, max: f64, normalized: bool, signed: bool) -> f64 {
    match (normalized, signed) {
        (false, _) => v,
        (true, true) => (v / max).max(-1.0),
        (true, false) => v / max,
    }
}

fn local_matrix(node: &Value) -> DMat4 {
    let nums = |v: &Value| -> Vec<f64> {
        v.as_array()
            .into_iter()
            .flatten()
            .filter_map(Value::as_f64)
            .collect()
    };
    let m = nums(&node["matrix"]);
    if m.len() == 16 {
        return DMat4::from_cols_slice(&m);
    }
    let t = nums(&node["translation"]);
    let r = nums(&node["rotation"]);
    let s = nums(&node["scale"]);
    let t = if t.len() == 3 {
        DVec3::new(t[0], t[1], t[2])
    } else {
        DVec3::ZERO
    };
    let r = if r.len() == 4 {
        DQuat::from_xyzw(r[0], r[1], r[2], r[3]).normalize()
    } else {
        DQuat::IDENTITY
    };
    let s = if s.len() == 3 {
        DVec3::new(s[0], s[1], s[2])
    } else {
        DVec3::ONE
    };
    DMat4::from_scale_rotation_translation(s, r, t)
}

/// Applies the affine map `m` to every Gaussian: centres m·p; for a proper rotation the
/// orientations and SH turn ([`GaussianCloud::rotate`]) and scales stay exactly as stored;
/// otherwise covariances become A Σ Aᵀ (A the linear part, decomposed back into scales and a
/// rotation) and SH turn by the rotation of A's polar decomposition.
fn transform(cloud: &mut GaussianCloud, m: DMat4) {
    if m == DMat4::IDENTITY {
        return;
    }
    let a = DMat3::from_mat4(m);
    let rigid = (a.transpose() * a - DMat3::IDENTITY)
        .to_cols_array()
        .iter()
        .all(|d| d.abs() < 1e-12)
        && a.determinant() > 0.0;
    if rigid {
        cloud.rotate(a);
    } else {
        for p in &mut cloud.positions {
            *p = (a * DVec3::from(p.map(f64::from))).as_vec3().to_array();
        }
        for i in 0..cloud.len() {
            let s = cloud.covariance(i).as_dmat3();
            let t = a * s * a.transpose();
            let upper = [
                t.x_axis.x, t.y_axis.x, t.z_axis.x, t.y_axis.y, t.z_axis.y, t.z_axis.z,
            ]
            .map(|v| v as f32);
            let (log_scales, q) = crate::posed::scales_and_rotation(&upper);
            cloud.log_scales[i] = log_scales;
            cloud.rotations_wxyz[i] = q;
        }
        if cloud.sh_rest_len >= 9 {
            let sh = ShRotation::from_mat3(polar_rotation(a));
            for rest in cloud.sh_rest.chunks_exact_mut(cloud.sh_rest_len) {
                sh.rotate_gaussian(rest);
            }
        }
    }
    let t = m.w_axis.truncate();
    for p in &mut cloud.positions {
        *p = (DVec3::from(p.map(f64::from)) + t).as_vec3().to_array();
    }
}

/// The rotation factor R of A = R S (polar decomposition), by Higham's iteration
/// R ← (R + R⁻ᵀ) / 2; a reflection (det < 0) is returned as R with det −1.
fn polar_rotation(a: DMat3) -> DMat3 {
    let mut r = a;
    for _ in 0..50 {
        if r.determinant().abs() < 1e-300 {
            return DMat3::IDENTITY;
        }
        let next = (r + r.inverse().transpose()) * 0.5;
        if (next - r).to_cols_array().iter().all(|d| d.abs() < 1e-14) {
            return next;
        }
        r = next;
    }
    r
}
