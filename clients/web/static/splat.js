// splat.js: WebGL2 3D Gaussian Splatting renderer (EWA splatting) for the splatphys live viewer.
//
// Method: EWA splatting (Zwicker et al. 2002, "EWA Splatting", IEEE TVCG) as used by 3D Gaussian
// Splatting (Kerbl et al. 2023, SIGGRAPH): every 3D Gaussian N(mu, Sigma) is projected with the
// Jacobian J of the perspective projection at its centre, Sigma' = J W Sigma W^T J^T (3DGS eq. 5),
// and drawn as a screen-space ellipse with alpha = o * exp(-1/2 d^T Sigma'^-1 d), blended in
// depth order (3DGS eq. 3).
//
// Conventions matched with the CPU renderer (clients/render/src):
//  camera.rs   view frame x right, y down, z forward; rows of W = right, down, forward with
//              forward = normalize(look_at - position), right = normalize(forward x up),
//              down = forward x right; fy = H / (2 tan(fov_y/2)), fx = fy; principal point
//              ((W-1)/2, (H-1)/2): pixel (i, j) has its centre at integer (i, j), row 0 on top.
//  project.rs  near-plane cull z <= near (0.2 m); drop opacity < 1/255 and clamp it to <= 1;
//              J built at the centre clamped to 1.3x the frustum (tan_half_fov * 1.3);
//              0.3 px^2 low-pass on the diagonal of Sigma'; drop when det <= 0 or a, c <= 0;
//              conic = Sigma'^-1; radius = ceil(3 sqrt(lambda_max)) with the reference's
//              max(mid^2 - det, 0.1); pixels touched = the tile rect of that radius (getRect,
//              16 px tiles, int truncation as in the reference) intersected with the box where
//              alpha can reach 1/255 (half extents sqrt(2 ln(255 o) 1.01 Sigma'_ii) + 1,
//              ceil/floor, clipped to the image). The quad drawn here covers exactly those
//              pixels, so the cutoff is the CPU renderer's, not a plain 3 sigma ellipse.
//  raster.rs   power = -1/2 (a dx^2 + c dy^2) - b dx dy with d = centre - pixel; skipped when
//              power > 0 or alpha < 1/255; alpha = min(0.99, o exp(power)); front-to-back
//              blending C += T c alpha, T *= (1 - alpha), then C += T * background.
//              Sort key: view depth z (f32 bits), ties by Gaussian index (stable LSD radix sort
//              of index-ordered input), i.e. the CPU per-tile order restricted to one tile.
//  sh.rs       SH degree <= 3 with the reference constants, colour = 0.5 + sum, clamped below at
//              0 only (values > 1 kept in the float target, clamped at the final blit).
//              View direction = normalize(mu - camera position), rotated into the Gaussian's
//              source frame with R^T (the conjugate of the normalised rotation_wxyz), only when
//              degree > 0 (a zero-length rotation hides the Gaussian, as on the CPU).
//  image.rs    8-bit output = round(clamp(v, 0, 1) * 255) (the GPU's unorm conversion).
//  background  black by default (RenderSettings::default); settable.
// Still different:
//  - no early stop: the CPU stops a pixel (without blending that Gaussian) once T would fall
//    below 1e-4; fixed-function blending cannot, so up to ~1e-4 of extra colour per pixel.
//  - exp() is the GPU's, not the CPU's portable polynomial (~1e-7 relative); f32 maths is done in
//    a different order (dot products on the GPU), so boundary pixels of the alpha box / tile rect
//    can rarely flip.
//  - accumulation is RGBA32F when EXT_color_buffer_float + EXT_float_blend exist, else RGBA16F,
//    else RGBA8 (visible banding); T is kept as 1 - A (A += (1 - A) alpha), the same in exact
//    arithmetic as the CPU's product.
//  - the selected object is tinted (display only; nothing is tinted when nothing is selected).
//  - the image size is the canvas's (window size x devicePixelRatio), not scene_info's
//    width_px/height_px; fov_y is kept, so the horizontal field of view follows the aspect ratio.
// Measured: 54 to 95 dB PSNR against splatphys-render on random SH-3 clouds of 600 to 100k
// Gaussians (cameras outside and inside the cloud, black and coloured backgrounds), max
// |difference| 1/255; tests/web_viewer.rs checks >= 30 dB on a live scene (76 dB) and on a rotated
// SH-2 source (77 dB).
//
// Drawing: one non-instanced drawElements call, 2 triangles per splat, slot -> Gaussian index
// through an R32UI draw-order texture (SwiftShader runs instanced draws one instance at a time);
// per-Gaussian data lives in RGBA32F data textures; SH is evaluated in the vertex shader, one
// program variant per SH degree. Limits: N <= 8.3M (data texture), N * ceil(3K/4) <= 4096 x
// MAX_TEXTURE_SIZE texels of SH.

const VS_BODY = `precision highp float; precision highp int; precision highp sampler2D;
uniform sampler2D uData;  // 4 RGBA32F texels per Gaussian: [pos, opacity] [xx xy xz yy] [yz zz id 0] [w x y z]
uniform sampler2D uSH;    // SH_STRIDE texels per Gaussian: K*3 floats, coefficient-major, RGB inner
uniform vec3 uRight, uDown, uFwd, uCamPos;
uniform vec2 uFocal, uPrincipal, uTanHalf, uSize;
uniform float uNear, uSelected;
uniform highp usampler2D uOrder; // Gaussian index per draw slot, front to back
flat out vec2 vMean; flat out vec3 vConic; flat out float vOpacity; flat out vec3 vColor; flat out vec4 vBox;

vec4 fetch(sampler2D t, int linear) {
  int w = textureSize(t, 0).x;
  return texelFetch(t, ivec2(linear % w, linear / w), 0);
}
void hide() { gl_Position = vec4(2.0, 2.0, 2.0, 1.0); }

void main() {
  // Non-instanced: element e = 4 * slot + corner (SwiftShader runs instanced draws one instance
  // at a time, which is ~5x slower for 100k splats).
  int slot = gl_VertexID >> 2;
  int i = int(texelFetch(uOrder, ivec2(slot % ORDER_WIDTH, slot / ORDER_WIDTH), 0).x);
  vec4 d0 = fetch(uData, 4 * i), d1 = fetch(uData, 4 * i + 1);
  vec4 d2 = fetch(uData, 4 * i + 2), q = fetch(uData, 4 * i + 3);
  vec3 p = d0.xyz;
  float o = d0.w;
  if (!(o >= 1.0 / 255.0)) { hide(); return; }  // also drops NaN
  o = min(o, 1.0);
  vec3 rel = p - uCamPos;
  vec3 t = vec3(dot(uRight, rel), dot(uDown, rel), dot(uFwd, rel));
  if (!(t.z > uNear)) { hide(); return; }

  // computeCov2D (3DGS): Jacobian at the centre clamped to 1.3x the frustum.
  vec2 lim = 1.3 * uTanHalf;
  float tx = clamp(t.x / t.z, -lim.x, lim.x) * t.z;
  float ty = clamp(t.y / t.z, -lim.y, lim.y) * t.z;
  float tz2 = t.z * t.z;
  // Rows of T = J W (J's third row is zero): T0 = W^T j0, T1 = W^T j1.
  vec3 t0 = uRight * (uFocal.x / t.z) + uFwd * (-(uFocal.x * tx) / tz2);
  vec3 t1 = uDown * (uFocal.y / t.z) + uFwd * (-(uFocal.y * ty) / tz2);
  mat3 S = mat3(d1.x, d1.y, d1.z,  d1.y, d1.w, d2.x,  d1.z, d2.x, d2.y);
  vec3 st0 = S * t0, st1 = S * t1;
  float a = dot(t0, st0) + 0.3;   // 0.3 px^2 low-pass (3DGS)
  float b = dot(t0, st1);
  float c = dot(t1, st1) + 0.3;
  float det = a * c - b * b;
  if (!(det > 0.0 && a > 0.0 && c > 0.0) || isinf(det)) { hide(); return; }
  float detInv = 1.0 / det;
  vec3 conic = vec3(c * detInv, -b * detInv, a * detInv);
  float mid = 0.5 * (a + c);
  float root = sqrt(max(mid * mid - det, 0.1));
  float radius = ceil(3.0 * sqrt(max(mid + root, mid - root)));
  vec2 mean = uFocal * t.xy / t.z + uPrincipal;

  // Tile rect (getRect, 16 px tiles) intersected with the box where alpha can reach 1/255.
  vec2 grid = ceil(uSize / 16.0);
  vec2 rlo = clamp(vec2(ivec2((mean - radius) / 16.0)), vec2(0.0), grid);
  vec2 rhi = clamp(vec2(ivec2((mean + radius + 15.0) / 16.0)), vec2(0.0), grid);
  if ((rhi.x - rlo.x) * (rhi.y - rlo.y) == 0.0) { hide(); return; }
  float s = 2.0 * log(255.0 * o) * 1.01;
  vec2 half_ = sqrt(s * vec2(a, c)) + 1.0;
  vec2 lo = max(ceil(mean - half_), vec2(0.0));
  vec2 hi = min(floor(mean + half_), uSize - 1.0);
  lo = max(lo, rlo * 16.0);
  hi = min(hi, rhi * 16.0 - 1.0);
  if (lo.x > hi.x || lo.y > hi.y) { hide(); return; }

  // computeColorFromSH with the view direction in the Gaussian's source frame (R^T d).
  vec3 dir = rel;
  float dl = length(dir);
  dir = dl > 0.0 ? dir / dl : vec3(0.0);
  // SH_DEG / SH_STRIDE are compile-time constants (one program per degree) so that every
  // coefficient below is a constant-indexed swizzle of the fetched texels.
  vec4 shv[SH_STRIDE];
  for (int k = 0; k < SH_STRIDE; ++k) shv[k] = fetch(uSH, SH_STRIDE * i + k);
  vec3 col = 0.28209479 * SH0;
#if SH_DEG > 0
  float qn = length(q);
  if (!(qn > 1e-12) || isinf(qn)) { hide(); return; }
  vec4 r = q / qn;                 // w x y z
  vec3 u = -r.yzw;                 // conjugate = inverse rotation: R^T d
  dir = dir + 2.0 * cross(u, cross(u, dir) + r.x * dir);
  float x = dir.x, y = dir.y, z = dir.z;
  col += -0.48860251 * y * SH1 + 0.48860251 * z * SH2 - 0.48860251 * x * SH3;
#endif
#if SH_DEG > 1
  float xx = x * x, yy = y * y, zz = z * z, xy = x * y, yz = y * z, xz = x * z;
  col += 1.09254843 * xy * SH4 - 1.09254843 * yz * SH5
       + 0.31539157 * (2.0 * zz - xx - yy) * SH6 - 1.09254843 * xz * SH7
       + 0.54627421 * (xx - yy) * SH8;
#endif
#if SH_DEG > 2
  col += -0.59004359 * y * (3.0 * xx - yy) * SH9 + 2.89061144 * xy * z * SH10
       - 0.45704580 * y * (4.0 * zz - xx - yy) * SH11
       + 0.37317633 * z * (2.0 * zz - 3.0 * xx - 3.0 * yy) * SH12
       - 0.45704580 * x * (4.0 * zz - xx - yy) * SH13
       + 1.44530572 * z * (xx - yy) * SH14 - 0.59004359 * x * (xx - 3.0 * yy) * SH15;
#endif
  col = max(col + 0.5, vec3(0.0));
  if (d2.z == uSelected) col = mix(col, vec3(1.0, 0.55, 0.1), 0.45);

  // Geometry: the smaller of (1) the rectangle of pixels lo..hi and (2) the rectangle around the
  // ellipse d^T Sigma'^-1 d <= 2 ln(255 o) (alpha >= 1/255) along its eigenvectors, one pixel of
  // slack; the fragment shader discards pixels outside lo..hi, so both cover the same pixels.
  vec2 corner = vec2(float(gl_VertexID & 1), float((gl_VertexID >> 1) & 1));
  vec2 edge = mix(lo - 0.5, hi + 0.5, corner);
  float ev = sqrt(max(mid * mid - det, 0.0));
  vec2 lam = vec2(mid + ev, max(mid - ev, 0.0));
  vec2 e1 = abs(b) > 1e-12 * (a + c) ? normalize(vec2(b, lam.x - a)) : (a >= c ? vec2(1.0, 0.0) : vec2(0.0, 1.0));
  vec2 ext = sqrt(2.0 * log(255.0 * o) * lam) + 1.0;
  if (4.0 * ext.x * ext.y < (hi.x - lo.x + 1.0) * (hi.y - lo.y + 1.0)) {
    vec2 k = corner * 2.0 - 1.0;
    edge = mean + k.x * ext.x * e1 + k.y * ext.y * vec2(-e1.y, e1.x);
  }
  // Pixel coordinates (centres at integers, row 0 on top) -> clip space.
  gl_Position = vec4(2.0 * (edge.x + 0.5) / uSize.x - 1.0, 1.0 - 2.0 * (edge.y + 0.5) / uSize.y, 0.0, 1.0);
  vMean = mean; vConic = conic; vOpacity = o; vColor = col; vBox = vec4(lo, hi);
}`;

/** Vertex shader evaluating SH degree `deg` from `stride` texels per Gaussian (SHj = coefficient j, RGB). */
function vertexShader(deg, stride) {
  const k = (deg + 1) * (deg + 1);
  const lane = (f) => `shv[${f >> 2}].${'xyzw'[f & 3]}`;
  let defs = `#version 300 es\n#define ORDER_WIDTH ${ORDER_WIDTH}\n#define SH_DEG ${deg}\n#define SH_STRIDE ${stride}\n`;
  for (let j = 0; j < k; j++) defs += `#define SH${j} vec3(${lane(3 * j)}, ${lane(3 * j + 1)}, ${lane(3 * j + 2)})\n`;
  return defs + VS_BODY;
}

const FS = `#version 300 es
precision highp float;
uniform vec2 uSize;
flat in vec2 vMean; flat in vec3 vConic; flat in float vOpacity; flat in vec3 vColor; flat in vec4 vBox;
out vec4 outColor;
void main() {
  vec2 pix = vec2(gl_FragCoord.x - 0.5, uSize.y - gl_FragCoord.y - 0.5);
  if (any(lessThan(pix, vBox.xy)) || any(greaterThan(pix, vBox.zw))) discard;  // tile rect / alpha box
  vec2 d = vMean - pix;
  float power = -0.5 * (vConic.x * d.x * d.x + vConic.z * d.y * d.y) - vConic.y * d.x * d.y;
  if (power > 0.0) discard;
  float alpha = min(0.99, vOpacity * exp(power));
  if (alpha < 1.0 / 255.0) discard;
  outColor = vec4(vColor * alpha, alpha);  // premultiplied; blended front to back ("under")
}`;

// Composite: C + T * background, T = 1 - A.
const BLIT_VS = `#version 300 es
void main() { vec2 p = vec2(float((gl_VertexID & 1) * 4 - 1), float((gl_VertexID >> 1) * 4 - 1));
  gl_Position = vec4(p, 0.0, 1.0); }`;
const BLIT_FS = `#version 300 es
precision highp float;
uniform sampler2D uAccum; uniform vec3 uBackground;
out vec4 outColor;
void main() { vec4 c = texelFetch(uAccum, ivec2(gl_FragCoord.xy), 0);
  outColor = vec4(clamp(c.rgb + (1.0 - c.a) * uBackground, 0.0, 1.0), 1.0); }`;

function compile(gl, vs, fs) {
  const prog = gl.createProgram();
  for (const [type, src] of [[gl.VERTEX_SHADER, vs], [gl.FRAGMENT_SHADER, fs]]) {
    const sh = gl.createShader(type);
    gl.shaderSource(sh, src);
    gl.compileShader(sh);
    if (!gl.getShaderParameter(sh, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(sh));
    gl.attachShader(prog, sh);
  }
  gl.linkProgram(prog);
  if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(prog));
  const u = {};
  const n = gl.getProgramParameter(prog, gl.ACTIVE_UNIFORMS);
  for (let k = 0; k < n; k++) {
    const name = gl.getActiveUniform(prog, k).name;
    u[name] = gl.getUniformLocation(prog, name);
  }
  return { prog, u };
}

/** Camera intrinsics/extrinsics exactly as camera.rs `view_params` (world -> view rows). */
export function viewParams(cam, width, height) {
  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const norm = (a) => { const l = Math.hypot(a[0], a[1], a[2]); return l > 0 ? a.map((v) => v / l) : [0, 0, 0]; };
  const fwd = norm(sub(cam.lookAt, cam.position));
  const right = norm(cross(fwd, cam.up));
  const down = cross(fwd, right);
  const tanY = Math.tan((cam.fovYDeg * Math.PI) / 360);
  const f = height / (2 * tanY);
  return {
    right, down, fwd, position: cam.position.slice(), focal: [f, f],
    principal: [(width - 1) / 2, (height - 1) / 2], tanHalf: [width / (2 * f), tanY],
    size: [width, height],
  };
}

const ORDER_WIDTH = 4096; // slots per row of the draw-order texture
const DATA_PER_ROW = 1024; // Gaussians per row of the data texture (4 texels each)

export class SplatRenderer {
  /** `options.accumFormat`: force 'RGBA32F', 'RGBA16F' or 'RGBA8' (default: best available). */
  constructor(canvas, options = {}) {
    const gl = canvas.getContext('webgl2', { antialias: false, alpha: false, depth: false, preserveDrawingBuffer: false });
    if (!gl) throw new Error('WebGL2 is not available');
    this.gl = gl;
    this.canvas = canvas;
    const cbf = gl.getExtension('EXT_color_buffer_float');
    const blend = gl.getExtension('EXT_float_blend');
    const best = cbf && blend ? 'RGBA32F' : cbf ? 'RGBA16F' : 'RGBA8';
    const order = ['RGBA8', 'RGBA16F', 'RGBA32F'];
    const want = options.accumFormat;
    this.accumFormat = order.indexOf(want) >= 0 && order.indexOf(want) <= order.indexOf(best) ? want : best;
    this.programs = new Map(); // vertex shader variant per (SH degree evaluated, texel stride)
    this.blit = compile(gl, BLIT_VS, BLIT_FS);
    // Draw order (R32UI texture) and the element buffer of two triangles per slot.
    this.orderTex = gl.createTexture();
    this.vao = gl.createVertexArray();
    this.elements = gl.createBuffer();
    this.elementSlots = 0;
    this.emptyVao = gl.createVertexArray();
    this.background = [0, 0, 0];
    this.near = 0.2;
    this.maxShDegree = 3;
    this.selected = -2; // object id tinted, -2 = none
    this.n = 0;
    this.dataVersion = 0;
    this.sortCache = null;
    this.fbo = null;
  }

  _texture(width, height, data) {
    const gl = this.gl;
    const tex = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, tex);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, width, height, 0, gl.RGBA, gl.FLOAT, data);
    return tex;
  }

  /** New scene: SH f32[N*K*3], opacity f32[N], objectId u32[N]. Positions start as NaN (hidden). */
  setScene({ n, shDegree, sh, opacity, objectId }) {
    const gl = this.gl;
    for (const t of [this.dataTex, this.shTex]) if (t) gl.deleteTexture(t);
    this.n = n;
    this.shDegree = shDegree;
    const k = (shDegree + 1) * (shDegree + 1);
    // Data texture mirror: 16 floats per Gaussian.
    this.dataWidth = DATA_PER_ROW * 4;
    this.dataRows = Math.max(1, Math.ceil(n / DATA_PER_ROW));
    this.data = new Float32Array(this.dataWidth * this.dataRows * 4);
    this.objectId = new Float32Array(n);
    for (let i = 0; i < n; i++) {
      const b = i * 16;
      this.data[b] = this.data[b + 1] = this.data[b + 2] = NaN;
      this.data[b + 3] = opacity[i];
      const id = objectId[i];
      this.objectId[i] = this.data[b + 10] = id === 0xffffffff ? -1 : id;
      this.data[b + 12] = 1; // identity rotation
    }
    this.dataTex = this._texture(this.dataWidth, this.dataRows, this.data);
    // SH texture: stride texels per Gaussian, laid out linearly.
    this.shStride = Math.ceil((k * 3) / 4);
    const shWidth = Math.min(4096, gl.getParameter(gl.MAX_TEXTURE_SIZE));
    const shRows = Math.max(1, Math.ceil((n * this.shStride) / shWidth));
    const shData = new Float32Array(shWidth * shRows * 4);
    for (let i = 0; i < n; i++) shData.set(sh.subarray(i * k * 3, (i + 1) * k * 3), i * this.shStride * 4);
    this.shTex = this._texture(shWidth, shRows, shData);
    this.dataVersion++;
  }

  /** Frame update for the Gaussians `index` (M of them): positions [M][3], cov [M][6], rot [M][4]. */
  updateGaussians(index, pos, cov, rot) {
    const d = this.data, m = index.length;
    let lo = Infinity, hi = -1;
    for (let j = 0; j < m; j++) {
      const i = index[j];
      if (i >= this.n) continue;
      const b = i * 16;
      d[b] = pos[3 * j]; d[b + 1] = pos[3 * j + 1]; d[b + 2] = pos[3 * j + 2];
      d[b + 4] = cov[6 * j]; d[b + 5] = cov[6 * j + 1]; d[b + 6] = cov[6 * j + 2];
      d[b + 7] = cov[6 * j + 3]; d[b + 8] = cov[6 * j + 4]; d[b + 9] = cov[6 * j + 5];
      d[b + 12] = rot[4 * j]; d[b + 13] = rot[4 * j + 1]; d[b + 14] = rot[4 * j + 2]; d[b + 15] = rot[4 * j + 3];
      const row = (i / DATA_PER_ROW) | 0;
      if (row < lo) lo = row;
      if (row > hi) hi = row;
    }
    if (hi < 0) return;
    const gl = this.gl;
    gl.bindTexture(gl.TEXTURE_2D, this.dataTex);
    // Only the rows holding changed Gaussians (one call, from the CPU mirror).
    gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, lo, this.dataWidth, hi - lo + 1, gl.RGBA, gl.FLOAT, d, lo * this.dataWidth * 4);
    this.dataVersion++;
  }

  /** Centre of Gaussian i (may be NaN before its first frame). */
  position(i) { const b = i * 16; return [this.data[b], this.data[b + 1], this.data[b + 2]]; }

  /**
   * Front-to-back order of the Gaussians in front of the near plane: key = f32 bits of the view
   * depth (positive, so the bits order like the values), stable 2 x 16-bit LSD radix sort of
   * index-ordered input, so ties stay in index order (the CPU renderer's sort key).
   */
  _sort(vp) {
    const key = `${this.dataVersion}|${vp.position}|${vp.fwd}|${this.near}`;
    if (this.sortCache && this.sortCache.key === key) return this.sortCache;
    const n = this.n, d = this.data;
    const depth = new Float32Array(n), bits = new Uint32Array(depth.buffer);
    const idx = new Uint32Array(n);
    const [fx, fy, fz] = vp.fwd, [px, py, pz] = vp.position;
    let count = 0;
    for (let i = 0; i < n; i++) {
      const b = i * 16;
      const z = fx * (d[b] - px) + fy * (d[b + 1] - py) + fz * (d[b + 2] - pz);
      if (z > this.near && d[b + 3] >= 1 / 255) { depth[count] = z; idx[count++] = i; }
    }
    const hist = new Uint32Array(65536);
    let src = idx, tmp = new Uint32Array(count), srcKey = bits, tmpKey = new Uint32Array(count);
    for (const shift of [0, 16]) {
      hist.fill(0);
      for (let j = 0; j < count; j++) hist[(srcKey[j] >>> shift) & 0xffff]++;
      let sum = 0;
      for (let h = 0; h < 65536; h++) { const c = hist[h]; hist[h] = sum; sum += c; }
      for (let j = 0; j < count; j++) {
        const slot = hist[(srcKey[j] >>> shift) & 0xffff]++;
        tmp[slot] = src[j]; tmpKey[slot] = srcKey[j];
      }
      [src, tmp] = [tmp, src];
      [srcKey, tmpKey] = [tmpKey, srcKey];
    }
    const gl = this.gl;
    const rows = Math.max(1, Math.ceil(count / ORDER_WIDTH));
    const order = new Uint32Array(rows * ORDER_WIDTH);
    order.set(src.subarray(0, count));
    gl.bindTexture(gl.TEXTURE_2D, this.orderTex);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.R32UI, ORDER_WIDTH, rows, 0, gl.RED_INTEGER, gl.UNSIGNED_INT, order);
    if (count > this.elementSlots) {
      const slots = Math.max(1024, 2 ** Math.ceil(Math.log2(count)));
      const e = new Uint32Array(slots * 6);
      for (let k = 0; k < slots; k++) e.set([4 * k, 4 * k + 1, 4 * k + 2, 4 * k + 2, 4 * k + 1, 4 * k + 3], 6 * k);
      gl.bindVertexArray(this.vao);
      gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, this.elements);
      gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, e, gl.STATIC_DRAW);
      gl.bindVertexArray(null);
      this.elementSlots = slots;
    }
    this.sortCache = { key, order: src.subarray(0, count), count };
    return this.sortCache;
  }

  _ensureTarget(w, h) {
    const gl = this.gl;
    if (this.fbo && this.fboW === w && this.fboH === h) return;
    if (this.fbo) { gl.deleteFramebuffer(this.fbo); gl.deleteTexture(this.accum); }
    this.accum = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, this.accum);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    const fmt = { RGBA32F: [gl.RGBA32F, gl.FLOAT], RGBA16F: [gl.RGBA16F, gl.HALF_FLOAT], RGBA8: [gl.RGBA8, gl.UNSIGNED_BYTE] }[this.accumFormat];
    gl.texImage2D(gl.TEXTURE_2D, 0, fmt[0], w, h, 0, gl.RGBA, fmt[1], null);
    this.fbo = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, this.fbo);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, this.accum, 0);
    this.fboW = w; this.fboH = h;
  }

  /** Draws the scene for camera `cam` ({position, lookAt, up, fovYDeg}) at the canvas size. */
  render(cam) {
    const gl = this.gl, w = this.canvas.width, h = this.canvas.height;
    const vp = viewParams(cam, w, h);
    this.lastView = vp;
    this._ensureTarget(w, h);
    gl.bindFramebuffer(gl.FRAMEBUFFER, this.fbo);
    gl.viewport(0, 0, w, h);
    gl.clearColor(0, 0, 0, 0);
    gl.clear(gl.COLOR_BUFFER_BIT);
    let count = 0;
    if (this.n > 0) count = this._sort(vp).count;
    if (count > 0) {
      const deg = Math.min(this.shDegree, this.maxShDegree), variant = `${deg}/${this.shStride}`;
      if (!this.programs.has(variant)) this.programs.set(variant, compile(gl, vertexShader(deg, this.shStride), FS));
      const { prog, u } = this.programs.get(variant);
      gl.useProgram(prog);
      gl.activeTexture(gl.TEXTURE0); gl.bindTexture(gl.TEXTURE_2D, this.dataTex);
      gl.activeTexture(gl.TEXTURE1); gl.bindTexture(gl.TEXTURE_2D, this.shTex);
      gl.uniform1i(u.uData, 0); gl.uniform1i(u.uSH, 1);
      gl.uniform3fv(u.uRight, vp.right); gl.uniform3fv(u.uDown, vp.down); gl.uniform3fv(u.uFwd, vp.fwd);
      gl.uniform3fv(u.uCamPos, vp.position);
      gl.uniform2fv(u.uFocal, vp.focal); gl.uniform2fv(u.uPrincipal, vp.principal);
      gl.uniform2fv(u.uTanHalf, vp.tanHalf); gl.uniform2f(u.uSize, w, h);
      gl.uniform1f(u.uNear, this.near); gl.uniform1f(u.uSelected, this.selected);
      // Front-to-back "under" operator on premultiplied colour: C += (1 - A) c a, A += (1 - A) a.
      gl.enable(gl.BLEND);
      gl.blendFuncSeparate(gl.ONE_MINUS_DST_ALPHA, gl.ONE, gl.ONE_MINUS_DST_ALPHA, gl.ONE);
      gl.activeTexture(gl.TEXTURE2); gl.bindTexture(gl.TEXTURE_2D, this.orderTex);
      gl.uniform1i(u.uOrder, 2);
      gl.bindVertexArray(this.vao);
      gl.drawElements(gl.TRIANGLES, 6 * count, gl.UNSIGNED_INT, 0);
      gl.bindVertexArray(null);
      gl.disable(gl.BLEND);
    }
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.viewport(0, 0, w, h);
    gl.useProgram(this.blit.prog);
    gl.activeTexture(gl.TEXTURE0); gl.bindTexture(gl.TEXTURE_2D, this.accum);
    gl.uniform1i(this.blit.u.uAccum, 0);
    gl.uniform3fv(this.blit.u.uBackground, this.background);
    gl.bindVertexArray(this.emptyVao);
    gl.drawArrays(gl.TRIANGLE_STRIP, 0, 4);
    gl.bindVertexArray(null);
    return count;
  }

  /** Canvas pixels after a render: RGB8, top row first (call in the same task as render). */
  readPixelsRGB8() {
    const gl = this.gl, w = this.canvas.width, h = this.canvas.height;
    const rgba = new Uint8Array(w * h * 4);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, rgba);
    const out = new Uint8Array(w * h * 3);
    for (let y = 0; y < h; y++) for (let x = 0; x < w; x++) {
      const s = ((h - 1 - y) * w + x) * 4, t = (y * w + x) * 3;
      out[t] = rgba[s]; out[t + 1] = rgba[s + 1]; out[t + 2] = rgba[s + 2];
    }
    return out;
  }

  /** Float image (C + T * background, unclamped) after a render: f32 RGB, top row first. */
  readPixelsFloat() {
    const gl = this.gl, w = this.fboW, h = this.fboH;
    const rgba = new Float32Array(w * h * 4);
    gl.bindFramebuffer(gl.FRAMEBUFFER, this.fbo);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.FLOAT, rgba);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    const out = new Float32Array(w * h * 3), bg = this.background;
    for (let y = 0; y < h; y++) for (let x = 0; x < w; x++) {
      const s = ((h - 1 - y) * w + x) * 4, t = (y * w + x) * 3, tr = 1 - rgba[s + 3];
      for (let c = 0; c < 3; c++) out[t + c] = rgba[s + c] + tr * bg[c];
    }
    return out;
  }

  /**
   * Screen-space splats of the last rendered view for picking, computed once per view/data:
   * the shader's projection (in f64), pixel box lo..hi, and 16 x 16 px tile lists in draw order.
   */
  _pickData() {
    const vp = this.lastView, sc = this.sortCache;
    const key = `${sc.key}|${vp.size}`;
    if (this.pickCache && this.pickCache.key === key) return this.pickCache;
    const d = this.data, [fx, fy] = vp.focal, [cx, cy] = vp.principal, [W, H] = vp.size;
    const { right: R, down: D, fwd: F, position: C } = vp;
    const lx = 1.3 * vp.tanHalf[0], ly = 1.3 * vp.tanHalf[1];
    const n = sc.count, P = new Float64Array(n * 6), box = new Int32Array(n * 4).fill(-1);
    const gw = Math.ceil(W / 16), gh = Math.ceil(H / 16), counts = new Uint32Array(gw * gh + 1);
    for (let k = 0; k < n; k++) {
      const b = sc.order[k] * 16, o = Math.min(d[b + 3], 1);
      const rx = d[b] - C[0], ry = d[b + 1] - C[1], rz = d[b + 2] - C[2];
      const tz = F[0] * rx + F[1] * ry + F[2] * rz;
      const tx0 = R[0] * rx + R[1] * ry + R[2] * rz, ty0 = D[0] * rx + D[1] * ry + D[2] * rz;
      const tx = Math.min(Math.max(tx0 / tz, -lx), lx) * tz, ty = Math.min(Math.max(ty0 / tz, -ly), ly) * tz;
      const j0x = fx / tz, j0z = -(fx * tx) / (tz * tz), j1y = fy / tz, j1z = -(fy * ty) / (tz * tz);
      const t0 = [R[0] * j0x + F[0] * j0z, R[1] * j0x + F[1] * j0z, R[2] * j0x + F[2] * j0z];
      const t1 = [D[0] * j1y + F[0] * j1z, D[1] * j1y + F[1] * j1z, D[2] * j1y + F[2] * j1z];
      const [xx, xy, xz, yy, yz, zz] = [d[b + 4], d[b + 5], d[b + 6], d[b + 7], d[b + 8], d[b + 9]];
      const st = (v) => [xx * v[0] + xy * v[1] + xz * v[2], xy * v[0] + yy * v[1] + yz * v[2], xz * v[0] + yz * v[1] + zz * v[2]];
      const s0 = st(t0), s1 = st(t1);
      const a = t0[0] * s0[0] + t0[1] * s0[1] + t0[2] * s0[2] + 0.3;
      const bb = t0[0] * s1[0] + t0[1] * s1[1] + t0[2] * s1[2];
      const c = t1[0] * s1[0] + t1[1] * s1[1] + t1[2] * s1[2] + 0.3;
      const det = a * c - bb * bb;
      if (!(det > 0 && a > 0 && c > 0 && Number.isFinite(det))) continue;
      const mx = (fx * tx0) / tz + cx, my = (fy * ty0) / tz + cy;
      const mid = 0.5 * (a + c), root = Math.sqrt(Math.max(mid * mid - det, 0.1));
      const rad = Math.ceil(3 * Math.sqrt(mid + root));
      const rect = [mx - rad, my - rad].map((v, q) => Math.min(Math.max(Math.trunc(v / 16), 0), q ? gh : gw));
      const rhi = [mx + rad + 15, my + rad + 15].map((v, q) => Math.min(Math.max(Math.trunc(v / 16), 0), q ? gh : gw));
      const sl = 2 * Math.log(255 * o) * 1.01, hx = Math.sqrt(sl * a) + 1, hy = Math.sqrt(sl * c) + 1;
      const x0 = Math.max(Math.ceil(mx - hx), 0, rect[0] * 16), y0 = Math.max(Math.ceil(my - hy), 0, rect[1] * 16);
      const x1 = Math.min(Math.floor(mx + hx), W - 1, rhi[0] * 16 - 1), y1 = Math.min(Math.floor(my + hy), H - 1, rhi[1] * 16 - 1);
      if (!(x0 <= x1 && y0 <= y1)) continue;
      P.set([mx, my, c / det, -bb / det, a / det, o], 6 * k);
      box.set([x0, y0, x1, y1], 4 * k);
      for (let ty2 = y0 >> 4; ty2 <= y1 >> 4; ty2++) for (let tx2 = x0 >> 4; tx2 <= x1 >> 4; tx2++) counts[ty2 * gw + tx2 + 1]++;
    }
    for (let t = 0; t < gw * gh; t++) counts[t + 1] += counts[t];
    const cursor = counts.slice(0, gw * gh), slots = new Uint32Array(counts[gw * gh]);
    for (let k = 0; k < n; k++) {
      if (box[4 * k] < 0) continue;
      for (let ty2 = box[4 * k + 1] >> 4; ty2 <= box[4 * k + 3] >> 4; ty2++) {
        for (let tx2 = box[4 * k] >> 4; tx2 <= box[4 * k + 2] >> 4; tx2++) slots[cursor[ty2 * gw + tx2]++] = k;
      }
    }
    this.pickCache = { key, P, box, counts, slots, gw, gh };
    return this.pickCache;
  }

  /**
   * Object under pixel (x, y) (pixel centres at integers, row 0 on top) for the last rendered
   * view: replays the shader's front-to-back blending at that pixel on the CPU and returns the
   * object id with the largest total blending weight sum(alpha T), or -1 when the background
   * Gaussians (id 0xFFFFFFFF) or nothing (total weight < 0.02) dominate.
   */
  pick(x, y) {
    if (!this.lastView || !this.sortCache || !(this.sortCache.count > 0)) return -1;
    const { P, box, counts, slots, gw, gh } = this._pickData();
    const px = Math.round(x), py = Math.round(y), tx = px >> 4, ty = py >> 4;
    if (px < 0 || py < 0 || tx >= gw || ty >= gh) return -1;
    const weight = new Map(), t = ty * gw + tx;
    let T = 1;
    for (let e = counts[t]; e < counts[t + 1]; e++) {
      const k = slots[e], q = 4 * k;
      if (px < box[q] || px > box[q + 2] || py < box[q + 1] || py > box[q + 3]) continue;
      const dx = P[6 * k] - px, dy = P[6 * k + 1] - py;
      const power = -0.5 * (P[6 * k + 2] * dx * dx + P[6 * k + 4] * dy * dy) - P[6 * k + 3] * dx * dy;
      if (power > 0) continue;
      const alpha = Math.min(0.99, P[6 * k + 5] * Math.exp(power));
      if (alpha < 1 / 255) continue;
      const id = this.objectId[this.sortCache.order[k]];
      weight.set(id, (weight.get(id) || 0) + alpha * T);
      T *= 1 - alpha;
      if (T < 1e-4) break;
    }
    let best = -1, bestW = 0.02;
    for (const [id, w] of weight) if (w > bestW) { best = id; bestW = w; }
    return best;
  }
}
