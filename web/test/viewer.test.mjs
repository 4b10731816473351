// Browser test of the viewer (ctest: viewer_browser). Headless Chromium (Debian's, software WebGL2
// through SwiftShader) driven by playwright-core loads `retimegs view` for a model written by
// view_helper (stretched primitives over the whole clip, open windows at both clip ends, soft
// window edges, degree-3 SH, a colour map on cam0) and for a small model trained here, and
// compares canvas screenshots with `retimegs render` of the same camera and time: PSNR >= 28 dB and SSIM >= 0.9 with the project's own
// metrics (view_helper compare). A merged model (view_helper merged) near its seam: the frame is
// the mix of the two sides' images by the handover's weight, and render's frame, with half-float
// images and without (the 8-bit path of a browser without EXT_color_buffer_float). Also:
// scrubbing the slider changes the frame to the slider's time, the exported static site draws
// the same frame, a missing WebGL2 shows a message.
//
//   node web/test/viewer.test.mjs RETIMEGS_BINARY VIEW_HELPER_BINARY
// Exit 0 passed, 1 failed, 77 skipped (no Chromium or no web/node_modules: the reason is printed).
// RETIMEGS_VIEWER_SHOTS=DIR keeps the screenshots and renders there.
import { spawn, execFileSync } from 'node:child_process';
import { existsSync, mkdtempSync, mkdirSync, copyFileSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { createServer } from 'node:http';
import { tmpdir } from 'node:os';
import { join, extname } from 'node:path';

import { imagesAt, seamHandover, timeSettings } from '../time_model.js';

const [retimegs, helper] = process.argv.slice(2);
if (!retimegs || !helper) {
  console.error('usage: viewer.test.mjs RETIMEGS_BINARY VIEW_HELPER_BINARY');
  process.exit(2);
}
const chromiumPath = process.env.CHROMIUM || '/usr/bin/chromium';
if (!existsSync(chromiumPath)) {
  console.log(`SKIP: no Chromium at ${chromiumPath} (Debian package chromium; scripts/test.sh installs it)`);
  process.exit(77);
}
let chromium;
try {
  ({ chromium } = await import('playwright-core'));
} catch {
  console.log('SKIP: playwright-core is not installed (run npm ci in web/; scripts/test.sh does)');
  process.exit(77);
}

const started = Date.now();
const work = mkdtempSync(join(tmpdir(), 'retimegs-viewer-'));
const shots = process.env.RETIMEGS_VIEWER_SHOTS;
if (shots) mkdirSync(shots, { recursive: true });
const model = join(work, 'model.rgs'), scene = join(work, 'scene');
let failures = 0;
const check = (ok, what) => {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
  if (!ok) ++failures;
};
const children = [];
let browser = null, staticServer = null;
function cleanUp() {
  for (const child of children) child.kill();
  staticServer?.close();
  rmSync(work, { recursive: true, force: true });
}

// `retimegs view` on a free port; resolves with the URL it prints.
function serve(args) {
  const child = spawn(retimegs, ['view', ...args, '--port', '0'], { stdio: ['ignore', 'pipe', 'pipe'] });
  children.push(child);
  return new Promise((resolve, reject) => {
    let out = '', err = '';
    child.stdout.on('data', (d) => {
      out += d;
      const match = out.match(/serving (http:\/\/\S+)/);
      if (match) resolve(match[1]);
    });
    child.stderr.on('data', (d) => { err += d; });
    child.on('exit', (code) => reject(new Error(`retimegs view exited ${code}: ${err}`)));
  });
}

// A static host of a folder (the exported site), as any web server would serve it.
function serveFolder(folder) {
  const types = { '.html': 'text/html', '.js': 'text/javascript', '.json': 'application/json' };
  staticServer = createServer((request, response) => {
    const path = new URL(request.url, 'http://x').pathname;
    const file = join(folder, path === '/' ? 'index.html' : path.slice(1));
    if (!existsSync(file)) { response.writeHead(404).end(); return; }
    response.writeHead(200, { 'Content-Type': types[extname(file)] || 'application/octet-stream' });
    response.end(readFileSync(file));
  });
  return new Promise((resolve) => staticServer.listen(0, '127.0.0.1',
    () => resolve(`http://127.0.0.1:${staticServer.address().port}/`)));
}

// `retimegs render` of `which` at camera and t, rendered once.
const renders = new Map();
function render(camera, t, which = { model, scene }) {
  const key = JSON.stringify([which.model, camera, t]);
  if (renders.has(key)) return renders.get(key);
  const out = join(work, `render${renders.size}_${camera}_t${t}.png`);
  execFileSync(retimegs, ['render', '--model', which.model, '--scene', which.scene, '--camera',
                          camera, '--time', String(t), '--out', out]);
  renders.set(key, out);
  return out;
}

// A small trained model: the minimal synthetic scene (4 cameras x 5 frames, 96x72), 200
// iterations with at most 4000 primitives and a stretching pass at iteration 150 (besides the
// still points that initialisation already spans over the clip). About 15 s on 2 cores.
function trainSmallModel() {
  const trainedScene = join(work, 'trained_scene'), run = join(work, 'run');
  execFileSync(retimegs, ['synth', '--preset', 'minimal', '--cameras', '4', '--frames', '5',
                          '--size', '96x72', '--out', trainedScene], { stdio: ['ignore', 'ignore', 'pipe'] });
  writeFileSync(join(work, 'train.json'), '{"stretch_every": 150}');
  execFileSync(retimegs, ['train', '--scene', trainedScene, '--out', run, '--preset', 'fast',
                          '--iters', '200', '--cap', '4000', '--config', join(work, 'train.json')],
               { stdio: ['ignore', 'ignore', 'pipe'] });
  return { model: join(run, 'model.rgs'), scene: trainedScene };
}

// Viewer screenshots of `cases` ([camera, t]) against `retimegs render`, `prefix` naming them.
async function compareWithRender(page, url, which, cases, prefix, size) {
  for (const [camera, t] of cases) {
    await frame(page, url, `?camera=${camera}&t=${t}&paused=1`);
    const state = await page.evaluate(() => window.retimegs.state());
    check(state.width === size[0] && state.height === size[1],
          `${prefix} ${camera} t=${t}: canvas is the camera's ${size[0]}x${size[1]}`);
    const shot = await screenshot(page, `${prefix}_viewer_${camera}_t${t}`);
    const reference = render(camera, t, which);
    if (shots) copyFileSync(reference, join(shots, `${prefix}_render_${camera}_t${t}.png`));
    const { psnr, ssim } = compare(shot, reference);
    check(psnr >= 28 && ssim >= 0.9, `${prefix} ${camera} t=${t}: viewer vs render PSNR ` +
                                     `${psnr.toFixed(2)} dB, SSIM ${ssim.toFixed(4)}`);
  }
}

// PSNR and SSIM of image a against image b, or against the mix w b + (1 - w) c.
function compare(a, b, c = null, w = 1) {
  const text = execFileSync(helper, ['compare', a, b, ...(c ? [c, String(w)] : [])]).toString();
  const [, psnr, ssim] = text.match(/psnr (\S+) ssim (\S+)/);
  // psnr prints inf for identical images.
  return { psnr: /inf/.test(psnr) ? Infinity : Number(psnr), ssim: Number(ssim) };
}

// Loads `query` and waits for window.retimegs.frameReady (or the page's error).
async function frame(page, url, query) {
  await page.goto(url + query);
  await page.waitForFunction(() => window.retimegs && (window.retimegs.frameReady ||
                                                       window.retimegs.error), null,
                             { timeout: 120000 });
  const error = await page.evaluate(() => window.retimegs.error);
  if (error) throw new Error(`${query}: ${error}`);
}

// The canvas's own pixels (its drawing buffer, as a PNG): the image the viewer drew, at the
// camera's size whatever the page's layout and zoom.
async function screenshot(page, name) {
  const path = join(work, `${name}.png`);
  const url = await page.evaluate(() => document.getElementById('canvas').toDataURL('image/png'));
  writeFileSync(path, Buffer.from(url.slice(url.indexOf(',') + 1), 'base64'));
  if (shots) copyFileSync(path, join(shots, `${name}.png`));
  return path;
}

// The merged fixture (view_fixture_merged_model): still primitives, one group the window before
// the seam at t = 4, one the window after it, the background in both, colours that never clamp.
// Each side alone draws one image at every time, so the frame at a time near the seam must be the
// mix of the frames at the clip's ends (each side alone there) by the handover's weight: within
// 8-bit rounding (one level everywhere would be 48 dB). Checked on cam1 (no colour map, whose
// clamping of dark pixels would not commute with the mix), and the frames against render.
async function checkSeam(page, url, which, prefix) {
  const response = await fetch(new URL('model.json', url));
  const settings = timeSettings(await response.json());
  const shotAt = async (camera, t) => {
    await frame(page, url, `?camera=${camera}&t=${t}&paused=1`);
    return screenshot(page, `${prefix}_${camera}_t${t}`);
  };
  const ends = [settings.first, settings.last];
  check(ends.every((t) => imagesAt(settings, t).length === 1),
        `${prefix}: one side alone at the clip's ends`);
  const before = await shotAt('cam1', ends[0]), after = await shotAt('cam1', ends[1]);
  const apart = compare(before, after);
  check(apart.psnr < 25, `${prefix}: the two sides differ (PSNR ${apart.psnr.toFixed(2)} dB)`);
  for (const t of [4, 4.25]) {
    const weight = seamHandover(settings, t).before;
    const mixed = compare(await shotAt('cam1', t), before, after, weight);
    check(mixed.psnr >= 45, `${prefix} cam1 t=${t}: the sides mixed by ${weight.toFixed(4)} ` +
                            `(PSNR ${mixed.psnr.toFixed(2)} dB, SSIM ${mixed.ssim.toFixed(4)})`);
  }
  await compareWithRender(page, url, which, [['cam0', 4], ['cam1', 4.25]], prefix, [160, 120]);
}

try {
  execFileSync(helper, ['fixture', work]);
  const url = await serve(['--model', model, '--scene', scene]);
  browser = await chromium.launch({
    executablePath: chromiumPath,
    args: ['--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist'],
  });
  const context = await browser.newContext({ viewport: { width: 800, height: 600 },
                                             deviceScaleFactor: 1 });
  const page = await context.newPage();
  page.on('pageerror', (e) => console.log(`page error: ${e.message}`));

  // The fixture: two cameras (cam0 with its colour map, cam1 without) at a training frame, at
  // an in-between time on the soft window edges, and at both clip ends (open windows, stretched
  // primitives on their linear continuation).
  await compareWithRender(page, url, { model, scene },
                          [['cam0', 4], ['cam1', 4], ['cam0', 3.5], ['cam1', 3.5], ['cam0', 0],
                           ['cam1', 8]], 'fixture', [160, 120]);

  // A merged model at its seam, with half-float images and with 8-bit ones.
  execFileSync(helper, ['merged', work]);
  const merged = { model: join(work, 'merged.rgs'), scene };
  const mergedUrl = await serve(['--model', merged.model, '--scene', scene]);
  await checkSeam(page, mergedUrl, merged, 'merged');
  const eightBit = await context.newPage();
  await eightBit.addInitScript(() => {
    const original = WebGL2RenderingContext.prototype.getExtension;
    WebGL2RenderingContext.prototype.getExtension = function (name) {
      return name === 'EXT_color_buffer_float' ? null : original.call(this, name);
    };
  });
  await checkSeam(eightBit, mergedUrl, merged, 'merged_8bit');
  await eightBit.close();

  // A trained model: two training cameras (their learned colour maps) at training frame 2 and at
  // the held-out frame 3.
  const trained = trainSmallModel();
  const trainedUrl = await serve(['--model', trained.model, '--scene', trained.scene]);
  await compareWithRender(page, trainedUrl, trained,
                          [['cam00', 2], ['cam02', 2], ['cam00', 3], ['cam02', 3]], 'trained',
                          [96, 72]);

  // Scrubbing: the slider moves time, the frame changes and is the render of the new time.
  await frame(page, url, '?camera=cam1&t=2&paused=1');
  const before = await screenshot(page, 'scrub_before');
  await page.locator('#slider').fill('5.25');
  await page.waitForFunction(() => window.retimegs.frameReady, null, { timeout: 120000 });
  const t = await page.evaluate(() => window.retimegs.state().t);
  check(Math.abs(t - 5.25) < 1e-9, `scrub: the slider sets t = ${t}`);
  const after = await screenshot(page, 'scrub_after');
  const moved = compare(before, after);
  check(moved.psnr < 30, `scrub: the frame changed (PSNR ${moved.psnr.toFixed(2)} dB to the one before)`);
  const scrubbed = compare(after, render('cam1', 5.25));
  check(scrubbed.psnr >= 28 && scrubbed.ssim >= 0.9,
        `scrub: the new frame matches render at t=5.25 (PSNR ${scrubbed.psnr.toFixed(2)} dB, SSIM ${scrubbed.ssim.toFixed(4)})`);

  // The exported static site shows the same frame.
  const site = join(work, 'site');
  execFileSync(retimegs, ['export', '--model', model, '--scene', scene, '--web', site]);
  const siteUrl = await serveFolder(site);
  await frame(page, siteUrl, '?camera=cam0&t=3.5&paused=1');
  const exported = compare(await screenshot(page, 'export_cam0_t3.5'), join(work, 'fixture_viewer_cam0_t3.5.png'));
  check(exported.psnr >= 50, `export --web: same frame as view (PSNR ${exported.psnr.toFixed(2)} dB)`);

  // An unknown camera is named, with the choices.
  await page.goto(url + '?camera=nope');
  await page.waitForFunction(() => window.retimegs?.error);
  const unknown = await page.evaluate(() => window.retimegs.error);
  check(/camera=nope.*cam0, cam1/.test(unknown), `unknown camera: "${unknown}"`);

  // Without WebGL2 the page says so instead of showing a blank canvas.
  const noGl = await context.newPage();
  await noGl.addInitScript(() => {
    const original = HTMLCanvasElement.prototype.getContext;
    HTMLCanvasElement.prototype.getContext = function (type, ...rest) {
      return type === 'webgl2' ? null : original.call(this, type, ...rest);
    };
  });
  await noGl.goto(url);
  const message = noGl.locator('#message');
  await message.waitFor({ state: 'visible' });
  check(/needs WebGL2/.test(await message.textContent()), 'no WebGL2: a message is shown');
} catch (error) {
  console.log(`FAIL ${error.stack || error}`);
  ++failures;
} finally {
  await browser?.close();
  cleanUp();
}
console.log(`viewer browser test: ${failures ? `${failures} failed` : 'passed'} in ` +
            `${((Date.now() - started) / 1000).toFixed(1)} s`);
process.exit(failures ? 1 : 0);
