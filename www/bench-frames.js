#!/usr/bin/env node
// The viewer's frame times on large models, in headless Chromium on
// SwiftShader (software GL, as on a machine without a GPU): for each scene,
// the full frames drawn when the camera stands still and the light frames
// drawn while it orbits (src/navigation.js), as the view times them (a
// render and a one-pixel read). Prints a markdown table.
//
//   node www/bench-frames.js [SCENE.glb ...]
//
// Without arguments: zoo-bunny from ../shared and the generated buildings
// of target/bench-inputs (scripts/bench.py scale makes them).
import { existsSync } from 'node:fs';
import { resolve } from 'node:path';
import { fileURLToPath } from 'node:url';

import { launchChromium } from '../js/test/browser.js';
import { startServer } from './server.js';

const repo = fileURLToPath(new URL('..', import.meta.url));
const shared = process.env.FAST_REJECT_SHARED ?? resolve(repo, '../shared');
const DEFAULT_SCENES = [
  resolve(shared, 'scenes/zoo-bunny/scene.glb'),
  resolve(repo, 'target/bench-inputs/distinct-10000/scene.glb'),
  resolve(repo, 'target/bench-inputs/families-10000-nodes/scene.glb'),
];
/** Orbits per scene; each drags for about DRAG_STEPS x 50 ms, then lets the view settle. */
const ORBITS = 3;
const DRAG_STEPS = 40;

/** The value `share` of the way up the sorted values (0.5: the median). */
const quantile = (values, share) => {
  const sorted = [...values].sort((a, b) => a - b);
  return sorted.length ? sorted[Math.min(Math.floor(share * sorted.length), sorted.length - 1)] : NaN;
};
const median = (values) => quantile(values, 0.5);

async function measure(page, file) {
  const started = Date.now();
  await page.setInputFiles('#scene-input', file);
  await page.waitForFunction(() => ['ready', 'error'].includes(globalThis.viewer?.status), null, { timeout: 600_000 });
  const loadMs = Date.now() - started;
  if ((await page.evaluate(() => globalThis.viewer.status)) !== 'ready') throw new Error(`${file}: the viewer did not load it`);
  // The frames from here on: the first light frames of the model count.
  const since = await page.evaluate(() => performance.now());
  const box = await page.locator('#viewport canvas').boundingBox();
  const x = box.x + box.width / 2;
  const y = box.y + box.height / 2;
  for (let orbit = 0; orbit < ORBITS; orbit += 1) {
    await page.mouse.move(x, y);
    await page.mouse.down();
    for (let step = 1; step <= DRAG_STEPS; step += 1) {
      await page.mouse.move(x + (orbit % 2 ? -6 : 6) * step, y + 2 * step);
      await page.waitForTimeout(50);
    }
    await page.mouse.up();
    // Settled: the full frame is drawn once the camera stops.
    await page.waitForFunction(() => globalThis.viewer.settled, null, { timeout: 120_000, polling: 100 });
    await page.waitForTimeout(300);
  }
  const frames = (await page.evaluate(() => globalThis.viewer.frameLog)).filter((f) => f.at > since);
  const full = frames.filter((f) => !f.light);
  const light = frames.filter((f) => f.light);
  return { loadMs, full, light, triangles: Math.max(...full.map((f) => f.triangles)) };
}

const scenes = process.argv.slice(2).length ? process.argv.slice(2) : DEFAULT_SCENES.filter((f) => existsSync(f));
const { server, origin } = await startServer({ port: 0, isolation: false });
const browser = await launchChromium(['--use-angle=swiftshader', '--enable-unsafe-swiftshader']);
try {
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  await page.goto(`${origin}/`);
  await page.waitForFunction(() => ['done', 'error'].includes(globalThis.viewer?.status), null, { timeout: 300_000 });
  console.log('| scene | triangles | load | full frame | light frames | light frame: median, 95%, max | triangles drawn, median |');
  console.log('|---|---:|---:|---:|---:|---:|---:|');
  for (const file of scenes) {
    const { loadMs, full, light, triangles } = await measure(page, file);
    const name = file.split('/').slice(-2, -1)[0];
    const times = light.map((f) => f.ms);
    const lightMs = light.length ? `${[0.5, 0.95, 1].map((q) => quantile(times, q).toFixed(0)).join(', ')} ms` : 'none';
    const drawn = light.length ? `${(median(light.map((f) => f.triangles)) / 1000).toFixed(0)} k` : '';
    console.log(
      `| ${name} | ${(triangles / 1e6).toFixed(2)} M | ${(loadMs / 1000).toFixed(1)} s | ${median(full.map((f) => f.ms)).toFixed(0)} ms | ${light.length} | ${lightMs} | ${drawn} |`,
    );
  }
} finally {
  await browser.close();
  server.close();
}
