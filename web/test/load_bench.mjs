// Load and sort times of the viewer for a large model in headless Chromium (software WebGL2:
// SwiftShader, so far slower than a GPU). Not part of ctest.
//
//   node web/test/load_bench.mjs RETIMEGS_BINARY VIEW_HELPER_BINARY [N=300000] [SHOTS_DIR]
// Writes a fixture model of N primitives (view_helper fixture), serves it with `retimegs view`,
// and reports: the .rgs and model.bin sizes, the time to the first frame (data fetched, textures
// uploaded, first frame shown), the worker's sort time at one time and while playing, and the
// frame rate while playing. SHOTS_DIR gets a screenshot of the page.
import { spawn, execFileSync } from 'node:child_process';
import { mkdtempSync, rmSync, statSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { chromium } from 'playwright-core';

const [retimegs, helper, count = '300000', shots] = process.argv.slice(2);

// Milliseconds from setting a new time to its frame drawn and read back (sort and GPU included).
async function frameTime(page) {
  const start = Date.now();
  await page.evaluate(() => window.retimegs.setTime(4.25));
  await page.waitForFunction(() => window.retimegs.frameReady, null, { timeout: 600000 });
  await page.evaluate(() => document.getElementById('canvas').toDataURL().length);
  return Date.now() - start;
}
const work = mkdtempSync(join(tmpdir(), 'retimegs-viewer-bench-'));
execFileSync(helper, ['fixture', work, count]);
const model = join(work, 'model.rgs');
execFileSync(retimegs, ['export', '--model', model, '--scene', join(work, 'scene'), '--web',
                        join(work, 'site')], { stdio: 'ignore' });
const rgsBytes = statSync(model).size, binBytes = statSync(join(work, 'site', 'model.bin')).size;
console.log(`model: ${count} primitives, .rgs ${(rgsBytes / 1e6).toFixed(1)} MB, model.bin ` +
            `${(binBytes / 1e6).toFixed(1)} MB (${((100 * binBytes) / rgsBytes).toFixed(0)} %)`);

const server = spawn(retimegs, ['view', '--model', model, '--scene', join(work, 'scene'),
                                '--port', '0'], { stdio: ['ignore', 'pipe', 'inherit'] });
const url = await new Promise((resolve) => {
  let out = '';
  server.stdout.on('data', (d) => {
    out += d;
    const match = out.match(/serving (http:\/\/\S+)/);
    if (match) resolve(match[1]);
  });
});
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
  args: ['--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist'],
});
try {
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  await page.goto(`${url}?t=3.5&paused=1`);
  await page.waitForFunction(() => window.retimegs.frameReady || window.retimegs.error, null,
                             { timeout: 600000 });
  const first = await page.evaluate(() => ({ ...window.retimegs }));
  if (first.error) throw new Error(first.error);
  console.log(`first frame: data fetched ${first.fetchedMs.toFixed(0)} ms, textures uploaded ` +
              `${first.uploadedMs.toFixed(0)} ms, shown ${first.loadMs.toFixed(0)} ms after ` +
              `navigation; ${first.visible} visible; worker sort ${first.sortMs.toFixed(1)} ms`);
  if (shots) await page.screenshot({ path: join(shots, `viewer-${count}.png`) });
  console.log(`a new time, paused: ${(await frameTime(page)).toFixed(0)} ms to the drawn frame`);
  // Play for 5 s, sampling the worker's sort time and the frame rate shown.
  await page.evaluate(() => document.getElementById('play').click());
  const sorts = [];
  for (let k = 0; k < 10; ++k) {
    await page.waitForTimeout(500);
    sorts.push(await page.evaluate(() => window.retimegs.sortMs));
  }
  const hud = await page.evaluate(() => document.getElementById('hud').textContent);
  sorts.sort((a, b) => a - b);
  console.log(`playing: worker sort median ${sorts[5].toFixed(1)} ms (min ${sorts[0].toFixed(1)}, ` +
              `max ${sorts[9].toFixed(1)}); HUD: ${hud}`);
  // The same at a scene camera's small canvas (160x120): the fill rate no longer dominates.
  await page.close();
  const smallPage = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  await smallPage.goto(`${url}?camera=cam0&t=3.5&paused=1`);
  await smallPage.waitForFunction(() => window.retimegs.frameReady, null, { timeout: 600000 });
  const small = await smallPage.evaluate(() => ({ ...window.retimegs }));
  console.log(`camera=cam0, a new time, paused: ${(await frameTime(smallPage)).toFixed(0)} ms`);
  console.log(`camera=cam0 (160x120): shown ${small.loadMs.toFixed(0)} ms after navigation; ` +
              `worker sort ${small.sortMs.toFixed(1)} ms`);
  await smallPage.evaluate(() => document.getElementById('play').click());
  await smallPage.waitForTimeout(5000);
  const smallSort = await smallPage.evaluate(() => window.retimegs.sortMs);
  const smallHud = await smallPage.evaluate(() => document.getElementById('hud').textContent);
  if (shots) await smallPage.screenshot({ path: join(shots, `viewer-${count}-cam0.png`) });
  console.log(`camera=cam0 playing: worker sort ${smallSort.toFixed(1)} ms; HUD: ${smallHud}`);
} finally {
  await browser.close();
  server.kill();
  rmSync(work, { recursive: true, force: true });
}
