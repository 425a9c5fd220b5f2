// viewer.js: splatphys live viewer: WebSocket client for the bridge (/ws), orbit camera, overlay
// UI, picking and commands. Rendering is in splat.js (EWA splatting, Zwicker et al. 2002, as in
// 3D Gaussian Splatting, Kerbl et al. 2023).
//
// Protocol (little-endian): binary kind 1 = scene (SH, opacity, object ids), kind 2 = frame
// (index, position, covariance, rotation of the Gaussians that changed); JSON scene_info, status,
// reply, objects, hello from the bridge; command and ready from the page. "ready" is sent after
// the draw call of a frame has been issued (backpressure: the bridge then sends the newest frame).

import { SplatRenderer } from './splat.js';

const $ = (id) => document.getElementById(id);
const canvas = $('view');
const overlay = $('overlay');
const params = new URLSearchParams(location.search);
// Optional query parameters (all passed through to /ws unchanged): accum=RGBA16F|RGBA8 forces the
// accumulation format, background=r,g,b sets the background (default black, as the CPU renderer).
let renderer;
try {
  renderer = new SplatRenderer(canvas, { accumFormat: params.get('accum') || undefined });
} catch (e) {
  $('status').textContent = `cannot render: ${e.message}`;
  throw e;
}
if (params.has('background')) renderer.background = params.get('background').split(',').map(Number);

// ---------------------------------------------------------------------------------------------
// State exposed for tests.
const state = {
  framesDrawn: 0,
  lastStep: null,
  lastLatencyMs: null,
  latencies: [],
  selected: null, // object id or null
  camera: null, // { position, lookAt, up, fovYDeg }
  generation: null,
  connected: false,
  readOnly: false,
  objects: new Map(), // id -> { id, name, mass_kg, kind, com_m, velocity_m_s }
  lastReply: null,
  renderer,
  renderOnce: () => draw(),
  readPixels: () => { draw(); return toBase64(renderer.readPixelsRGB8()); },
  readPixelsFloat: () => { draw(); return renderer.readPixelsFloat(); },
  send: (command) => sendCommand(command),
  pickAt: (x, y) => renderer.pick(x, y),
};
window.splatphys = state;

function toBase64(bytes) {
  let s = '';
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
  return btoa(s);
}

// ---------------------------------------------------------------------------------------------
// Camera: orbit (left drag), pan (right or shift drag), zoom (wheel); the up vector is fixed.
const v = {
  add: (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]],
  sub: (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]],
  scale: (a, s) => [a[0] * s, a[1] * s, a[2] * s],
  dot: (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2],
  cross: (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]],
  len: (a) => Math.hypot(a[0], a[1], a[2]),
  norm: (a) => { const l = Math.hypot(a[0], a[1], a[2]); return l > 0 ? [a[0] / l, a[1] / l, a[2] / l] : a; },
};
// Rodrigues rotation of vector p about unit axis k by angle t.
function rotate(p, k, t) {
  const c = Math.cos(t), s = Math.sin(t);
  return v.add(v.add(v.scale(p, c), v.scale(v.cross(k, p), s)), v.scale(k, v.dot(k, p) * (1 - c)));
}

function orbit(dx, dy) {
  const cam = state.camera, up = v.norm(cam.up);
  let off = v.sub(cam.position, cam.lookAt);
  off = rotate(off, up, -dx * 0.005);
  const right = v.norm(v.cross(v.sub(cam.lookAt, cam.position), up));
  const pitched = rotate(off, right, -dy * 0.005);
  // Keep away from the poles (the camera's right axis would be undefined there).
  if (Math.abs(v.dot(v.norm(pitched), up)) < 0.995) off = pitched;
  cam.position = v.add(cam.lookAt, off);
}

function pan(dx, dy) {
  const cam = state.camera, vp = renderer.lastView;
  if (!vp) return;
  const dist = v.len(v.sub(cam.position, cam.lookAt));
  const s = (2 * dist * Math.tan((cam.fovYDeg * Math.PI) / 360)) / canvas.height;
  const move = v.add(v.scale(vp.right, -dx * s), v.scale(vp.down, -dy * s));
  cam.position = v.add(cam.position, move);
  cam.lookAt = v.add(cam.lookAt, move);
}

function zoom(delta) {
  const cam = state.camera;
  const off = v.scale(v.sub(cam.position, cam.lookAt), Math.exp(delta * 0.001));
  if (v.len(off) > 1e-3) cam.position = v.add(cam.lookAt, off);
}

/** Frame the bounds of the Gaussians (framing.rs: d = r / sin(half narrower fov), az 30, el 20). */
function frameBounds() {
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < renderer.n; i++) {
    const p = renderer.position(i);
    if (!p.every(Number.isFinite)) continue;
    for (let k = 0; k < 3; k++) { lo[k] = Math.min(lo[k], p[k]); hi[k] = Math.max(hi[k], p[k]); }
  }
  if (!(lo[0] <= hi[0])) return false;
  const centre = v.scale(v.add(lo, hi), 0.5);
  const r = Math.max(v.len(v.sub(hi, lo)) * 0.5, 1e-3);
  const fovYDeg = 50, tanY = Math.tan((fovYDeg * Math.PI) / 360);
  const half = Math.atan(Math.min(tanY, (tanY * canvas.width) / canvas.height));
  const d = (r / Math.sin(half)) * 1.05, az = Math.PI / 6, el = Math.PI / 9;
  const dir = [Math.cos(el) * Math.cos(az), Math.cos(el) * Math.sin(az), Math.sin(el)];
  state.camera = { position: v.add(centre, v.scale(dir, d)), lookAt: centre, up: [0, 0, 1], fovYDeg };
  return true;
}

// ---------------------------------------------------------------------------------------------
// Drawing: on demand (new frame or camera change), once per animation frame.
let dirty = true;
let pendingReady = null; // { generation, step, publishMs } of the newest applied frame
const drawTimes = [];

function resize() {
  const dpr = window.devicePixelRatio || 1;
  const w = Math.max(1, Math.round(canvas.clientWidth * dpr)), h = Math.max(1, Math.round(canvas.clientHeight * dpr));
  if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; dirty = true; }
}

function draw() {
  resize();
  if (!state.camera) return false;
  renderer.render(state.camera);
  state.framesDrawn++;
  const now = performance.now();
  drawTimes.push(now);
  while (drawTimes.length && drawTimes[0] < now - 1000) drawTimes.shift();
  return true;
}

function tick() {
  requestAnimationFrame(tick);
  resize();
  if (!state.camera && renderer.n > 0 && pendingReady) frameBounds();
  if (dirty && draw()) {
    dirty = false;
    if (pendingReady) {
      const f = pendingReady;
      pendingReady = null;
      state.lastStep = f.step;
      state.lastLatencyMs = Date.now() - f.publishMs;
      state.latencies.push(state.lastLatencyMs);
      if (state.latencies.length > 1000) state.latencies.shift();
      $('step').textContent = String(f.step);
      $('time').textContent = f.time.toFixed(3) + ' s';
      $('latency').textContent = state.lastLatencyMs.toFixed(1) + ' ms';
      renderer.gl.flush();
      send({ type: 'ready', generation: f.generation, step: f.step });
    }
  }
  $('fps').textContent = String(drawTimes.filter((t) => t > performance.now() - 1000).length);
}

// ---------------------------------------------------------------------------------------------
// WebSocket.
let ws = null;
let nextRequest = 1;
const pendingCommands = new Map(); // request -> command name

function setStatus() {
  const parts = [state.connected ? 'connected' : 'disconnected'];
  const s = state.serverStatus;
  if (s) {
    if (s.server_alive === false) parts.push('server has stopped');
    if (s.finished) parts.push('finished (resume runs on, reset starts over)');
    else if (s.paused) parts.push('paused');
    if (s.failed) parts.push('failed' + (s.failure_reason ? ': ' + s.failure_reason : ''));
    if (s.stalled) parts.push('stalled');
  }
  if (state.readOnly) parts.push('read-only');
  $('status').textContent = parts.join(', ');
  $('banner').hidden = !(s && s.server_alive === false);
}

function send(msg) {
  if (ws && ws.readyState === WebSocket.OPEN) { ws.send(JSON.stringify(msg)); return true; }
  return false;
}

function sendCommand(command) {
  const request = nextRequest++;
  pendingCommands.set(request, command.command);
  if (!send({ type: 'command', request, command })) {
    pendingCommands.delete(request);
    $('reply').textContent = `not sent (${command.command}): not connected`;
  }
  return request;
}

function connect() {
  const proto = location.protocol === 'https:' ? 'wss:' : 'ws:';
  ws = new WebSocket(`${proto}//${location.host}/ws${location.search}`);
  ws.binaryType = 'arraybuffer';
  $('status').textContent = 'connecting';
  ws.onopen = () => { state.connected = true; setStatus(); };
  ws.onclose = () => { state.connected = false; setStatus(); setTimeout(connect, 1000); };
  ws.onmessage = (ev) => {
    if (typeof ev.data === 'string') onJson(JSON.parse(ev.data));
    else onBinary(ev.data);
  };
}

function onBinary(buf) {
  const dv = new DataView(buf);
  const kind = dv.getUint32(0, true);
  if (kind === 1) {
    const generation = dv.getUint32(4, true), n = dv.getUint32(8, true), shDegree = dv.getUint32(12, true);
    const k = (shDegree + 1) * (shDegree + 1);
    let off = 32;
    const sh = new Float32Array(buf, off, n * k * 3); off += n * k * 12;
    const opacity = new Float32Array(buf, off, n); off += n * 4;
    const objectId = new Uint32Array(buf, off, n);
    renderer.setScene({ n, shDegree, sh, opacity, objectId });
    state.generation = generation;
    state.frameDt = dv.getFloat64(24, true);
    dirty = true;
  } else if (kind === 2) {
    const generation = dv.getUint32(4, true), m = dv.getUint32(12, true);
    const step = Number(dv.getBigUint64(16, true)), time = dv.getFloat64(24, true);
    const publishMs = Number(dv.getBigUint64(32, true)) / 1e6;
    if (generation !== state.generation) {
      // A frame of another generation (its scene has not arrived): not drawable; acknowledge it
      // anyway so that the bridge does not wait for a ready that will never come.
      send({ type: 'ready', generation, step });
      return;
    }
    const index = new Uint32Array(buf, 48, m);
    const pos = new Float32Array(buf, 48 + 4 * m, 3 * m);
    const cov = new Float32Array(buf, 48 + 16 * m, 6 * m);
    const rot = new Float32Array(buf, 48 + 40 * m, 4 * m);
    renderer.updateGaussians(index, pos, cov, rot);
    pendingReady = { generation, step, time, publishMs };
    dirty = true;
  }
}

function onJson(msg) {
  switch (msg.type) {
    case 'hello':
      state.readOnly = !!msg.read_only;
      for (const id of ['pause', 'resume', 'stepbtn', 'reset', 'apply']) $(id).disabled = state.readOnly;
      setStatus();
      break;
    case 'scene_info': {
      const first = state.sceneName !== msg.scene_name;
      state.sceneName = msg.scene_name;
      $('scene').textContent = msg.scene_name || '';
      state.objects = new Map((msg.objects || []).map((o) => [o.id, { ...o }]));
      if (msg.camera && (first || !state.camera)) {
        const c = msg.camera;
        state.camera = { position: c.position_m.slice(), lookAt: c.look_at_m.slice(), up: (c.up || [0, 0, 1]).slice(), fovYDeg: c.fov_y_deg || 50 };
        state.sceneCamera = c;
      }
      if (state.selected !== null && !state.objects.has(state.selected)) select(null);
      dirty = true;
      break;
    }
    case 'status':
      state.serverStatus = msg;
      $('sps').textContent = Number.isFinite(msg.steps_per_s) ? msg.steps_per_s.toFixed(1) : '-';
      if (state.lastStep === null) {
        $('step').textContent = String(msg.step);
        $('time').textContent = Number(msg.time_s).toFixed(3) + ' s';
      }
      setStatus();
      break;
    case 'objects':
      for (const o of msg.objects || []) {
        const cur = state.objects.get(o.id) || { id: o.id, name: `object ${o.id}` };
        state.objects.set(o.id, { ...cur, ...o });
      }
      break;
    case 'reply': {
      const name = pendingCommands.get(msg.request) || 'command';
      pendingCommands.delete(msg.request);
      state.lastReply = msg;
      $('reply').textContent = msg.accepted
        ? `accepted: ${name}` + (msg.effective_step != null ? ` (step ${msg.effective_step})` : '')
        : `refused: ${name}: ${msg.reason}`;
      break;
    }
    default:
      break;
  }
}

// ---------------------------------------------------------------------------------------------
// Selection, impulse drag and camera input.
function select(id) {
  state.selected = id;
  renderer.selected = id === null ? -2 : id;
  const o = id === null ? null : state.objects.get(id);
  $('selected').textContent = id === null ? 'none' : o ? o.name : `object ${id}`;
  $('material').hidden = id === null;
  dirty = true;
}

function pixelAt(ev) {
  const r = canvas.getBoundingClientRect();
  const sx = canvas.width / r.width, sy = canvas.height / r.height;
  return [(ev.clientX - r.left) * sx - 0.5, (ev.clientY - r.top) * sy - 0.5];
}

let drag = null; // { mode: 'orbit'|'pan'|'impulse', x, y, x0, y0, moved }
canvas.addEventListener('contextmenu', (ev) => ev.preventDefault());
canvas.addEventListener('pointerdown', (ev) => {
  canvas.setPointerCapture(ev.pointerId);
  let mode = ev.button === 2 || ev.shiftKey ? 'pan' : 'orbit';
  if (mode === 'orbit' && state.selected !== null && !state.readOnly) {
    const [px, py] = pixelAt(ev);
    if (renderer.pick(px, py) === state.selected) mode = 'impulse';
  }
  drag = { mode, x: ev.clientX, y: ev.clientY, x0: ev.clientX, y0: ev.clientY, moved: false };
});
canvas.addEventListener('pointermove', (ev) => {
  if (!drag) return;
  const dx = ev.clientX - drag.x, dy = ev.clientY - drag.y;
  drag.x = ev.clientX; drag.y = ev.clientY;
  if (Math.hypot(ev.clientX - drag.x0, ev.clientY - drag.y0) > 3) drag.moved = true;
  if (drag.mode === 'orbit') orbit(dx, dy);
  else if (drag.mode === 'pan') pan(dx, dy);
  else drawImpulseLine(drag);
  if (drag.mode !== 'impulse') dirty = true;
});
canvas.addEventListener('pointerup', (ev) => {
  if (!drag) return;
  const d = drag;
  drag = null;
  drawImpulseLine(null);
  if (d.mode === 'impulse' && d.moved) {
    sendImpulse(Math.hypot(ev.clientX - d.x0, ev.clientY - d.y0));
  } else if (!d.moved && ev.button === 0) {
    const [px, py] = pixelAt(ev);
    const id = renderer.pick(px, py);
    select(id >= 0 ? id : null);
  }
});
canvas.addEventListener('wheel', (ev) => { ev.preventDefault(); zoom(ev.deltaY); dirty = true; }, { passive: false });

/** Δv = 1 m/s per 100 px of drag (at most 5 m/s) along the camera's forward direction. */
function impulseFor(lengthPx) {
  const dv = Math.min(lengthPx / 100, 5);
  const o = state.objects.get(state.selected);
  const mass = o && Number.isFinite(o.mass_kg) ? o.mass_kg : 0;
  const fwd = renderer.lastView ? renderer.lastView.fwd : [0, 0, 0];
  return { dv, mass, impulse: fwd.map((c) => c * dv * mass) };
}

function sendImpulse(lengthPx) {
  const { impulse, mass } = impulseFor(lengthPx);
  if (!(mass > 0)) { $('reply').textContent = 'no mass known for the selected object'; return; }
  sendCommand({ command: 'impulse', object: state.selected, impulse_n_s: impulse });
}
state.sendImpulse = sendImpulse;

function drawImpulseLine(d) {
  const ctx = overlay.getContext('2d');
  overlay.width = overlay.clientWidth; overlay.height = overlay.clientHeight;
  ctx.clearRect(0, 0, overlay.width, overlay.height);
  if (!d) return;
  const r = overlay.getBoundingClientRect();
  ctx.strokeStyle = '#ff9a1a'; ctx.lineWidth = 3;
  ctx.beginPath(); ctx.moveTo(d.x0 - r.left, d.y0 - r.top); ctx.lineTo(d.x - r.left, d.y - r.top); ctx.stroke();
  const { dv } = impulseFor(Math.hypot(d.x - d.x0, d.y - d.y0));
  ctx.fillStyle = '#fff'; ctx.font = '13px sans-serif';
  ctx.fillText(`Δv ${dv.toFixed(2)} m/s`, d.x - r.left + 8, d.y - r.top - 8);
}

// ---------------------------------------------------------------------------------------------
// Buttons and the material panel.
$('pause').onclick = () => sendCommand({ command: 'pause' });
$('resume').onclick = () => sendCommand({ command: 'resume' });
$('stepbtn').onclick = () => sendCommand({ command: 'step', count: 1 });
$('reset').onclick = () => sendCommand({ command: 'reset' });
$('apply').onclick = () => {
  if (state.selected === null) return;
  const command = { command: 'edit-material', object: state.selected };
  if ($('model').value) command.model = $('model').value;
  // Field names of types/src/material.rs MaterialEdit (note: poisson_ratio).
  for (const [id, key] of [['E', 'youngs_modulus_pa'], ['nu', 'poisson_ratio'], ['density', 'density_kg_m3'],
    ['restitution', 'restitution'], ['friction', 'friction']]) {
    const text = $(id).value.trim();
    if (text !== '') command[key] = Number(text);
  }
  sendCommand(command);
};

select(null);
setStatus();
connect();
requestAnimationFrame(tick);
