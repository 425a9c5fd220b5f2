// browser.mjs: headless Chromium helper for the web viewer tests (playwright-core).
//
// playwright-core is resolved from $PLAYWRIGHT_CORE (a path), this folder's node_modules, or the
// current working directory's.
// Software GL: ANGLE on SwiftShader gives WebGL2 with EXT_color_buffer_float and EXT_float_blend.
import path from 'node:path';
import { createRequire } from 'node:module';
import { pathToFileURL } from 'node:url';

export const CHROMIUM_ARGS = ['--no-sandbox', '--use-gl=angle', '--use-angle=swiftshader',
  '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist'];

async function playwright() {
  if (process.env.PLAYWRIGHT_CORE) return import(pathToFileURL(process.env.PLAYWRIGHT_CORE).href);
  // This folder's node_modules first (plain import), then the current directory's.
  try {
    return await import('playwright-core');
  } catch {
    const where = createRequire(path.join(process.cwd(), 'x.js')).resolve('playwright-core');
    return import(pathToFileURL(where).href);
  }
}

/** Launches Chromium (default /usr/bin/chromium or $CHROMIUM). */
export async function launch() {
  const pw = await playwright();
  const chromium = pw.chromium || pw.default.chromium;
  return chromium.launch({ executablePath: process.env.CHROMIUM || '/usr/bin/chromium', args: CHROMIUM_ARGS });
}

/**
 * Opens the viewer at `url` in a page of exactly width x height CSS pixels at devicePixelRatio 1
 * (so the canvas has width x height pixels) and waits until a frame message was drawn and `minFrames` frames in all.
 */
export async function openViewer(browser, url, { width = 640, height = 480, minFrames = 1, timeoutMs = 60000 } = {}) {
  const page = await browser.newPage({ viewport: { width, height }, deviceScaleFactor: 1 });
  const log = [];
  page.on('console', (m) => log.push(`${m.type()}: ${m.text()}`));
  page.on('pageerror', (e) => log.push(`pageerror: ${e.message}`));
  page.log = log;
  await page.goto(url);
  try {
    await page.waitForFunction((n) => window.splatphys && window.splatphys.lastStep !== null && window.splatphys.framesDrawn >= n, minFrames, { timeout: timeoutMs });
  } catch (e) {
    throw new Error(`${e.message}\npage log:\n${log.join('\n')}`);
  }
  return page;
}

/** Renders once and returns the canvas as { width, height, rgb: Uint8Array } (top row first). */
export async function capture(page) {
  const r = await page.evaluate(() => {
    const c = document.getElementById('view');
    return { width: c.width, height: c.height, b64: window.splatphys.readPixels() };
  });
  return { width: r.width, height: r.height, rgb: new Uint8Array(Buffer.from(r.b64, 'base64')) };
}
