// viewer_e2e.mjs: drives the viewer page in headless Chromium for tests/web_viewer.rs.
//
//   node viewer_e2e.mjs capture URL WIDTH HEIGHT OUT_RGB   -> JSON line on stdout
//   node viewer_e2e.mjs still URL WIDTH HEIGHT OUT_RGB     -> JSON line on stdout
//   node viewer_e2e.mjs interact URL WIDTH HEIGHT          -> JSON line on stdout
//   node viewer_e2e.mjs perf URL WIDTH HEIGHT SECONDS      -> JSON line on stdout
//   node viewer_e2e.mjs stopped URL WIDTH HEIGHT OUT_JSON  -> "READY" on stdout, JSON to OUT_JSON
//   node viewer_e2e.mjs finished URL WIDTH HEIGHT          -> JSON line on stdout
//
// capture: the step counter must advance while the server runs; then `pause` is clicked and the
// paused frame's pixels (RGB8, top row first) are written to OUT_RGB for the PSNR check against
// splatphys-render. still: the first frame of a paused server, its pixels to OUT_RGB. interact: with the server paused, click an object (select), drag from it
// (impulse), step once and report the reply and the object's velocity before and after; then
// apply E = 1e39 in the material panel and report the refusal text. perf: frames drawn per
// second and publish-to-draw latency while the server runs. stopped: says READY once a frame is
// drawn, then waits for the caller to stop the server and reports the banner and that the last
// frame is still drawn. finished: opened after the server reached the end of its scene, the
// page draws the last frame and says "finished"; reset goes back to step 0, resume runs on.
import fs from 'node:fs';
import { launch } from './browser.mjs';

const [mode, url, w, h, arg] = process.argv.slice(2);
const width = Number(w), height = Number(h);

const browser = await launch();
const page = await browser.newPage({ viewport: { width, height }, deviceScaleFactor: 1 });
const log = [];
page.on('console', (m) => { if (m.type() === 'error') log.push(m.text()); });
page.on('pageerror', (e) => log.push(`pageerror: ${e.message}`));

const sp = (f, a) => page.evaluate(f, a);
const waitFor = (f, a, timeout = 60000) => page.waitForFunction(f, a, { timeout, polling: 50 });
const out = { mode, log };

try {
  out.stage = 'first frame';
  await page.goto(url);
  // A frame applied and drawn (the page also draws the scene before its first frame arrives).
  await waitFor(() => window.splatphys && window.splatphys.lastStep !== null);
  if (mode === 'capture') {
    out.step0 = await sp(() => window.splatphys.lastStep);
    await waitFor((s) => window.splatphys.lastStep > s + 2, out.step0);
    out.step1 = await sp(() => window.splatphys.lastStep);
    out.stepText = await page.textContent('#step');
    await page.click('#pause');
    await waitFor(() => window.splatphys.serverStatus && window.splatphys.serverStatus.paused);
    // The paused frame: the status step and the drawn step agree and stay.
    await waitFor(() => window.splatphys.lastStep === window.splatphys.serverStatus.step);
    await page.waitForTimeout(500);
    out.pausedStep = await sp(() => window.splatphys.lastStep);
    const b64 = await sp(() => window.splatphys.readPixels());
    fs.writeFileSync(arg, Buffer.from(b64, 'base64'));
    out.stepAfter = await sp(() => window.splatphys.lastStep);
  } else if (mode === 'still') {
    await page.waitForTimeout(300);
    out.step = await sp(() => window.splatphys.lastStep);
    fs.writeFileSync(arg, Buffer.from(await sp(() => window.splatphys.readPixels()), 'base64'));
  } else if (mode === 'interact') {
    await waitFor(() => window.splatphys.objects.size > 0 && [...window.splatphys.objects.values()].every((o) => o.mass_kg > 0));
    // A pixel of object 0, found with the page's own picking.
    const px = await sp(({ width, height }) => {
      let best = null;
      for (let y = 4; y < height; y += 4) {
        for (let x = 4; x < width; x += 4) {
          if (window.splatphys.pickAt(x, y) === 0) {
            if (!best) best = [x, y, 0];
            best[2] += 1;
          }
        }
      }
      return best;
    }, { width, height });
    if (!px) throw new Error('object 0 is not on screen');
    out.objectPixels = px[2] * 16;
    const before = await sp(() => window.splatphys.objects.get(0).velocity_m_s.slice());
    // Click: select.
    await page.mouse.click(px[0] + 0.5, px[1] + 0.5);
    await waitFor(() => window.splatphys.selected === 0, null, 10000);
    out.selectedText = await page.textContent('#selected');
    // Drag from it: 100 px is 1 m/s along the view direction.
    const replies = await sp(() => window.splatphys.lastReply);
    await page.mouse.move(px[0] + 0.5, px[1] + 0.5);
    await page.mouse.down();
    for (let i = 1; i <= 10; i++) await page.mouse.move(px[0] + 0.5 + 10 * i, px[1] + 0.5);
    await page.mouse.up();
    await waitFor((r) => window.splatphys.lastReply && window.splatphys.lastReply !== r, replies, 10000)
      .catch(() => {});
    out.impulseReply = await sp(() => window.splatphys.lastReply);
    const stepBefore = await sp(() => window.splatphys.lastStep);
    await page.click('#stepbtn');
    await waitFor((s) => window.splatphys.lastStep > s, stepBefore, 30000);
    await page.waitForTimeout(300);
    out.velocityBefore = before;
    out.velocityAfter = await sp(() => window.splatphys.objects.get(0).velocity_m_s.slice());
    // A refused material edit shows the server's reason.
    await page.fill('#E', '1e39');
    const r2 = await sp(() => window.splatphys.lastReply.request);
    await page.click('#apply');
    // Replies come in request order; the material edit's is the next after the step's.
    await waitFor((r) => window.splatphys.lastReply.request > r && window.splatphys.lastReply.request >= 3, r2, 10000);
    out.materialReply = await sp(() => window.splatphys.lastReply);
    out.replyText = await page.textContent('#reply');
  } else if (mode === 'stopped') {
    console.log('READY');
    await waitFor(() => !document.getElementById('banner').hidden, null, 60000);
    await page.waitForTimeout(300);
    out.banner = await page.textContent('#banner');
    out.statusText = await page.textContent('#status');
    const rgb = Buffer.from(await sp(() => window.splatphys.readPixels()), 'base64');
    out.litPixels = rgb.reduce((n, _, i) => n + (i % 3 === 0 && (rgb[i] | rgb[i + 1] | rgb[i + 2]) > 8 ? 1 : 0), 0);
  } else if (mode === 'finished') {
    out.stage = 'finished status';
    await waitFor(() => window.splatphys.serverStatus && window.splatphys.serverStatus.finished);
    out.stage = 'last frame drawn';
    await waitFor(() => window.splatphys.lastStep === window.splatphys.serverStatus.step);
    await page.waitForTimeout(300);
    out.finalStep = await sp(() => window.splatphys.lastStep);
    out.statusText = await page.textContent('#status');
    const rgb = Buffer.from(await sp(() => window.splatphys.readPixels()), 'base64');
    out.litPixels = rgb.reduce((n, _, i) => n + (i % 3 === 0 && (rgb[i] | rgb[i + 1] | rgb[i + 2]) > 8 ? 1 : 0), 0);
    out.stage = 'reset';
    await page.click('#reset');
    await waitFor(() => window.splatphys.lastStep === 0, null, 30000);
    out.stepAfterReset = await sp(() => window.splatphys.lastStep);
    out.stage = 'resume';
    await page.click('#resume');
    await waitFor(() => window.splatphys.lastStep > 2, null, 60000);
    out.stepAfterResume = await sp(() => window.splatphys.lastStep);
  } else if (mode === 'perf') {
    await page.waitForTimeout(2000);
    const f0 = await sp(() => [window.splatphys.framesDrawn, performance.now()]);
    await sp(() => { window.splatphys.latencies.length = 0; });
    await page.waitForTimeout(Number(arg) * 1000);
    const f1 = await sp(() => [window.splatphys.framesDrawn, performance.now()]);
    out.framesPerS = (f1[0] - f0[0]) / ((f1[1] - f0[1]) / 1000);
    const lat = (await sp(() => window.splatphys.latencies.slice())).sort((a, b) => a - b);
    const q = (p) => lat.length ? lat[Math.min(lat.length - 1, Math.floor(p * lat.length))] : null;
    out.latencyMs = { p50: q(0.5), p99: q(0.99), samples: lat.length };
  }
  out.ok = true;
} catch (e) {
  out.ok = false;
  out.error = String(e && e.message || e);
  // What the page held when it gave up (which wait `stage` names).
  out.page = await sp(() => window.splatphys && {
    lastStep: window.splatphys.lastStep,
    status: window.splatphys.serverStatus,
  }).catch(() => null);
}
if (mode === 'stopped') fs.writeFileSync(arg, JSON.stringify(out));
console.log(JSON.stringify(out));
await browser.close();
process.exit(out.ok ? 0 : 1);
