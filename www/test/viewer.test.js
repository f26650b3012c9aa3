// End-to-end tests of the viewer: the real page in headless Chromium
// (playwright-core driving the system Chromium), served by www/server.js
// once cross-origin isolated (the threaded build) and once not (the plain
// build). Needs pkg/ (scripts/build-wasm.sh) and ../shared.
//   cd www && node --test test/
import assert from 'node:assert/strict';
import { mkdir, readFile } from 'node:fs/promises';
import { resolve } from 'node:path';
import { test } from 'node:test';
import { fileURLToPath } from 'node:url';
import { inflateSync } from 'node:zlib';

import { launchChromium } from '../../js/test/browser.js';
import { startServer } from '../server.js';

const repo = fileURLToPath(new URL('../../', import.meta.url));
const shared = process.env.FAST_REJECT_SHARED ?? resolve(repo, '../shared');
const screenshots = process.env.VIEWER_SCREENSHOTS ?? resolve(repo, 'target/viewer');
const zooBunny = resolve(shared, 'scenes/zoo-bunny');

// WebGL on the CPU: headless Chromium on a machine without a GPU.
const WEBGL_FLAGS = ['--use-angle=swiftshader', '--enable-unsafe-swiftshader'];

/** Opens the viewer; the caller must `close()`. */
async function openViewer({ isolation }) {
  const { server, origin } = await startServer({ port: 0, isolation });
  const browser = await launchChromium(WEBGL_FLAGS);
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  const problems = [];
  page.on('pageerror', (error) => problems.push(`page error: ${error.message}`));
  page.on('console', (message) => {
    if (message.type() === 'error') problems.push(`console error: ${message.text()}`);
    // Nothing the page or its workers print should warn of misuse.
    if (message.type() === 'warning' && /deprecated/.test(message.text())) problems.push(`console warning: ${message.text()}`);
  });
  await page.goto(`${origin}/`);
  return {
    page,
    problems,
    async close() {
      await browser.close();
      server.close();
    },
  };
}

/**
 * Waits until the viewer reports `status`; fails at once with the page's
 * message when it reports an error or shows a message instead (callers
 * dismiss old messages first).
 */
async function waitForStatus(page, status, timeout = 180_000) {
  await page.waitForFunction(
    (wanted) => ['error', wanted].includes(globalThis.viewer?.status) || !!globalThis.viewer?.lastMessage,
    status,
    { timeout, polling: 100 },
  );
  const { now, message } = await page.evaluate(() => ({ now: globalThis.viewer.status, message: globalThis.viewer.lastMessage }));
  if (now !== status || message) {
    assert.fail(`the viewer says '${message}' (status ${now}) while the test waits for '${status}'`);
  }
}

function apply(transform, p) {
  return [0, 1, 2].map((r) => transform[r][0] * p[0] + transform[r][1] * p[1] + transform[r][2] * p[2] + transform[r][3]);
}

async function truth(dir) {
  return JSON.parse(await readFile(resolve(dir, 'truth.json'), 'utf8'));
}

/** Every truth instance found and nothing else, as ../shared/bench/evaluate.py scores it. */
function assertMatchesTruth(report, truthJson, label) {
  const tolerance = (truthJson.tolerance ?? 0.2) * (truthJson.template_radius ?? 1);
  const targets = truthJson.instances.map((t) => apply(t.transform, report.template.center));
  const positions = report.instances.map((i) => i.position);
  for (const [j, target] of targets.entries()) {
    assert.ok(
      positions.some((p) => Math.hypot(p[0] - target[0], p[1] - target[1], p[2] - target[2]) < tolerance),
      `${label}: truth instance ${j} not found`,
    );
  }
  for (const p of positions) {
    assert.ok(
      targets.some((t) => Math.hypot(p[0] - t[0], p[1] - t[1], p[2] - t[2]) < tolerance),
      `${label}: false positive at ${p}`,
    );
  }
}

for (const isolation of [true, false]) {
  const mode = isolation ? 'threads' : 'single-threaded';
  test(`viewer (${mode}): the demo on load, then a selection sphere on zoo-bunny`, async () => {
    const viewer = await openViewer({ isolation });
    const { page } = viewer;
    try {
      // The demo is searched on load.
      await waitForStatus(page, 'done');
      const build = await page.evaluate(() => globalThis.viewer.build);
      assert.equal(build.build, isolation ? 'threads' : 'plain');
      if (isolation) assert.ok(build.threads >= 2, `threads: ${build.threads}`);
      const badge = await page.locator('#threads-badge').textContent();
      assert.match(badge, isolation ? /threaded: \d+ threads/ : /single-threaded \(not cross-origin isolated\)/);
      // Headless Chromium has no hardware adapter: the layers ran on the
      // CPU (matchGpu's fallback), and the readout says so.
      assert.match(await page.locator('#webgpu-badge').textContent(), /WebGPU: (software only|not available)/);
      assert.match(await page.locator('#total-time').textContent(), /CPU only/);
      assert.equal(await page.evaluate(() => globalThis.viewer.report.gpu), null);
      // The grid the search used is shown where it is not the box's, and
      // the layer order's note stays out of the default view.
      const used = await page.evaluate(() => ({
        grid: globalThis.viewer.report.grid.resolution,
        asked: Number(document.getElementById('resolution').value),
        hidden: document.getElementById('resolution-used').hidden,
        text: document.getElementById('resolution-used').textContent,
      }));
      assert.equal(used.hidden, used.grid === used.asked, JSON.stringify(used));
      if (!used.hidden) assert.match(used.text, new RegExp(`used ${used.grid} \\(`));
      assert.doesNotMatch(await page.locator('#total-time').textContent(), /Layers ran/);

      // The demo lies on the xy plane: the view orbits around z.
      assert.equal(await page.evaluate(() => globalThis.viewer.up), 'z');
      const demoTruth = await truth(resolve(repo, 'assets/demo'));
      const demo = await page.evaluate(() => globalThis.viewer.report);
      assertMatchesTruth(demo, demoTruth, 'demo');
      assert.equal(await page.evaluate(() => globalThis.viewer.highlighted), demoTruth.instances.length);
      assert.equal(await page.locator('#instance-list li').count(), demoTruth.instances.length);
      // One row per layer, summed over the demo's parts.
      const layerKeys = new Set(demo.stages.map((s) => `${s.descriptor} ${s.layer}`));
      assert.equal(await page.locator('#layer-table tbody tr').count(), layerKeys.size);
      const first = demo.stages[0];
      const summed = demo.stages
        .filter((s) => s.descriptor === first.descriptor && s.layer === first.layer)
        .reduce((sum, s) => sum + s.candidates, 0);
      const shown = await page.locator('#layer-table tbody tr').first().locator('td').nth(2).textContent();
      assert.equal(Number(shown.replace(/\D/g, '')), summed, shown);

      // A threshold change re-runs the search: nothing is that close, then the three again.
      await page.fill('#harmonics-threshold', '0.01');
      await page.locator('#harmonics-threshold').dispatchEvent('change');
      await page.waitForFunction(() => globalThis.viewer.status === 'done' && globalThis.viewer.report.instances.length === 0, null, {
        timeout: 60_000,
      });
      assert.equal(await page.evaluate(() => globalThis.viewer.highlighted), 0);
      await page.fill('#harmonics-threshold', '0.8');
      await page.locator('#harmonics-threshold').dispatchEvent('change');
      await page.waitForFunction(() => globalThis.viewer.status === 'done' && globalThis.viewer.report?.instances.length === 3, null, {
        timeout: 60_000,
      });

      // A shared scene through the file input.
      await page.setInputFiles('#scene-input', resolve(zooBunny, 'scene.glb'));
      await waitForStatus(page, 'ready');
      assert.equal(await page.evaluate(() => globalThis.viewer.sceneName), 'scene.glb');
      assert.equal(await page.evaluate(() => globalThis.viewer.highlighted), 0);

      // Click on a bunny to place the selection sphere there: the view is
      // framed on the scene, so a bunny's centre projects onto its body.
      const bunnies = (await truth(zooBunny)).instances.map((t) => [t.transform[0][3], t.transform[1][3], t.transform[2][3]]);
      await page.click('label:has(input[value="selection"])');
      let picked = null;
      for (const centre of bunnies) {
        const { x, y } = await page.evaluate((p) => globalThis.viewer.project(p), centre);
        await page.mouse.click(x, y);
        const selection = await page.evaluate(() => globalThis.viewer.selection);
        if (selection && Math.hypot(...selection.center.map((v, i) => v - centre[i])) < 1) {
          picked = selection;
          break;
        }
      }
      assert.ok(picked, 'no click landed on a bunny');
      // Shift + wheel sizes the sphere (and does not zoom).
      const before = await page.evaluate(() => globalThis.viewer.selection.radius);
      await page.keyboard.down('Shift');
      await page.mouse.wheel(0, 120);
      await page.keyboard.up('Shift');
      await page.waitForFunction((r) => globalThis.viewer.selection.radius < r, before, { timeout: 5000 });
      await page.evaluate(() => globalThis.viewer.setSelectionRadius(0.6));
      assert.equal(await page.locator('#radius-value').textContent(), '0.6');
      await page.click('#search-button');
      await waitForStatus(page, 'done');
      const report = await page.evaluate(() => globalThis.viewer.report);
      // The parts that can hold a copy were counted to the end.
      const progress = await page.evaluate(() => globalThis.viewer.progress);
      assert.ok(progress?.step === 'parts' && progress.total >= 1 && progress.done === progress.total, JSON.stringify(progress));
      // Every bunny holds one match, and nothing else does (models have radius 1).
      for (const [j, centre] of bunnies.entries()) {
        assert.ok(
          report.instances.some((i) => Math.hypot(...i.position.map((v, k) => v - centre[k])) < 1),
          `bunny ${j} was not matched: ${JSON.stringify(report.instances)}`,
        );
      }
      for (const instance of report.instances) {
        assert.ok(
          bunnies.some((c) => Math.hypot(...instance.position.map((v, k) => v - c[k])) < 1),
          `a match off every bunny: ${instance.position}`,
        );
      }
      assert.equal(await page.evaluate(() => globalThis.viewer.highlighted), report.instances.length);
      await mkdir(screenshots, { recursive: true });
      await page.screenshot({ path: resolve(screenshots, `viewer-${mode}.png`) });
      // Flying to a match from the list singles it out; a bunny in the open
      // needs nothing cut away.
      await page.locator('#instance-list li button').nth(1).click();
      await page.waitForTimeout(900);
      assert.ok(await page.locator('#instance-list li button').nth(1).evaluate((b) => b.classList.contains('focused')));
      assert.equal(await page.evaluate(() => globalThis.viewer.cutaway), false);
      await page.screenshot({ path: resolve(screenshots, `viewer-${mode}-focus.png`) });
      assert.deepEqual(viewer.problems, []);
    } finally {
      await viewer.close();
    }
  });
}

for (const isolation of [false, true]) {
  const mode = isolation ? 'threads' : 'single-threaded';
  test(`viewer (${mode}): cancel stops a long search at once and the page stays usable`, async () => {
    const viewer = await openViewer({ isolation });
    const { page } = viewer;
    try {
      await waitForStatus(page, 'done');
      await page.setInputFiles('#scene-input', resolve(zooBunny, 'scene.glb'));
      await waitForStatus(page, 'ready');
      // Curvature on the whole zoo takes tens of seconds; announced as
      // long past 2 s left, once its pace is known.
      await page.evaluate(() => {
        globalThis.viewer.longSearchSeconds = 2;
      });
      await page.selectOption('#descriptor', 'curvature');
      await page.setInputFiles('#template-input', resolve(zooBunny, 'template.glb'));
      await waitForStatus(page, 'searching');
      await page.waitForFunction(() => /^This search will take about .* more: [\d,]+ vertices/.test(globalThis.viewer.lastMessage ?? ''), null, {
        timeout: 60_000,
        polling: 100,
      });
      assert.equal(await page.evaluate(() => globalThis.viewer.status), 'searching');
      assert.equal(await page.locator('#message-action').textContent(), 'Cancel the search');
      // The search worker, and with threads the pool's workers too.
      const running = page.workers();
      assert.ok(running.length >= (isolation ? 3 : 1), `${running.length} workers run the search`);
      const closed = Promise.all(running.map((worker) => new Promise((done) => worker.once('close', done))));
      // In one mode the notice's own button cancels, in the other the bar's.
      await page.click(isolation ? '#message-action' : '#cancel-button');
      await waitForStatus(page, 'cancelled', 2000);
      // Every worker that ran the search is gone, not left computing.
      await Promise.race([
        closed,
        new Promise((_, fail) => setTimeout(() => fail(new Error('search workers are still alive after cancel')), 5000)),
      ]);
      assert.ok(await page.locator('#cancel-button').isDisabled());

      // The page goes on working: the same scene, the fast descriptor.
      await page.selectOption('#descriptor', 'volume+harmonics');
      await page.click('#search-button');
      await waitForStatus(page, 'done');
      const report = await page.evaluate(() => globalThis.viewer.report);
      assertMatchesTruth(report, await truth(zooBunny), 'zoo-bunny after a cancel');
      assert.deepEqual(viewer.problems, []);
    } finally {
      await viewer.close();
    }
  });
}

test('viewer: curvature on twisted-homer, over every vertex and with the sampled first pass', async () => {
  const viewer = await openViewer({ isolation: true });
  const { page } = viewer;
  const twistedHomer = resolve(shared, 'scenes/twisted-homer');
  try {
    await waitForStatus(page, 'done');
    await page.setInputFiles('#scene-input', resolve(twistedHomer, 'scene.glb'));
    await waitForStatus(page, 'ready');
    await page.selectOption('#descriptor', 'curvature');
    assert.ok(await page.locator('#curvature-spacing').isVisible(), 'the sampling input shows with curvature');
    // No pose, so no whole copies: the box is off, and a check left on is not sent.
    assert.ok(await page.locator('#whole-copies').isDisabled(), 'whole copies is off with curvature');
    assert.ok(await page.locator('#keep-near-twins').isDisabled(), 'keep near twins is off with curvature');
    await page.setInputFiles('#template-input', resolve(twistedHomer, 'template.glb'));
    await waitForStatus(page, 'done');
    const every = await page.evaluate(() => globalThis.viewer.report);
    assertMatchesTruth(every, await truth(twistedHomer), 'twisted-homer, every vertex');
    assert.deepEqual(
      every.stages.map((s) => s.descriptor),
      Array(6).fill('curvature'),
    );

    // Sampling re-runs the search as two passes, with the same matches.
    await page.fill('#curvature-spacing', '0.5');
    await page.locator('#curvature-spacing').dispatchEvent('change');
    await page.waitForFunction(() => globalThis.viewer.status === 'done' && globalThis.viewer.report?.stages.length === 12, null, {
      timeout: 120_000,
    });
    const sampled = await page.evaluate(() => globalThis.viewer.report);
    assert.deepEqual(
      sampled.stages.map((s) => s.descriptor),
      [...Array(6).fill('curvature-sample'), ...Array(6).fill('curvature')],
    );
    assert.deepEqual(
      sampled.instances.map((i) => i.position),
      every.instances.map((i) => i.position),
    );
    assert.equal(await page.locator('#layer-table tbody tr').count(), 12);
    assert.equal(await page.evaluate(() => document.getElementById('progress-bar').value), 1);
    assert.deepEqual(viewer.problems, []);
  } finally {
    await viewer.close();
  }
});

test('viewer: a broken or unsupported file gives a message and keeps the scene', async () => {
  const viewer = await openViewer({ isolation: false });
  const { page } = viewer;
  try {
    await waitForStatus(page, 'done');
    const before = await page.evaluate(() => ({ scene: globalThis.viewer.sceneName, highlighted: globalThis.viewer.highlighted }));
    const sceneBytes = await readFile(resolve(zooBunny, 'scene.glb'));
    const cases = [
      { name: 'broken.glb', mimeType: 'model/gltf-binary', buffer: Buffer.from('glTF this is not a binary glTF file') },
      { name: 'truncated.glb', mimeType: 'model/gltf-binary', buffer: sceneBytes.subarray(0, sceneBytes.length >> 1) },
      { name: 'notes.txt', mimeType: 'text/plain', buffer: Buffer.from('hello') },
      { name: 'empty.stl', mimeType: 'model/stl', buffer: Buffer.alloc(0) },
      { name: 'garbage.ply', mimeType: 'application/octet-stream', buffer: Buffer.from('ply\nformat nonsense\n') },
    ];
    for (const file of cases) {
      await page.evaluate(() => globalThis.viewer.dismissMessage());
      await page.setInputFiles('#scene-input', file);
      await page.locator('#message').waitFor({ state: 'visible', timeout: 30_000 });
      const message = await page.locator('#message-text').textContent();
      assert.match(message, new RegExp(file.name.replace('.', '\\.')), `${file.name}: ${message}`);
      assert.match(message, /unchanged|not a supported|empty/, `${file.name}: ${message}`);
      const after = await page.evaluate(() => ({ scene: globalThis.viewer.sceneName, highlighted: globalThis.viewer.highlighted }));
      assert.deepEqual(after, before, `${file.name} changed the scene`);
      assert.equal(await page.evaluate(() => globalThis.viewer.status), 'done');
    }
    // Still usable: the demo searches again.
    await page.click('#search-button');
    await waitForStatus(page, 'done');
    assert.equal(await page.evaluate(() => globalThis.viewer.highlighted), before.highlighted);
    // Console errors are expected here (three.js logs parse failures); page errors are not.
    assert.deepEqual(viewer.problems.filter((p) => p.startsWith('page error')), []);
  } finally {
    await viewer.close();
  }
});

/** The filtered pixel bytes of a PNG (its IDAT chunks inflated): a one-colour image has only a few distinct values. */
function pixelBytes(png) {
  const chunks = [];
  for (let at = 8; at < png.length; ) {
    const length = png.readUInt32BE(at);
    if (png.toString('latin1', at + 4, at + 8) === 'IDAT') chunks.push(png.subarray(at + 8, at + 8 + length));
    at += 12 + length;
  }
  return inflateSync(Buffer.concat(chunks));
}

/** Drops `files` ({name, base64}) on the view, at `at` ({clientX, clientY}; the left edge when absent). */
async function dropFiles(page, files, at = {}) {
  const dataTransfer = await page.evaluateHandle((files) => {
    const transfer = new DataTransfer();
    for (const f of files) transfer.items.add(new File([Uint8Array.from(atob(f.base64), (c) => c.charCodeAt(0))], f.name));
    return transfer;
  }, files);
  await page.dispatchEvent('#viewport', 'drop', { dataTransfer, ...at });
}

/** A .glb split into a .gltf and its .bin, as exporters often write them. */
function splitGlb(glb, binName) {
  const jsonLength = glb.readUInt32LE(12);
  const json = JSON.parse(glb.subarray(20, 20 + jsonLength).toString('utf8'));
  const binStart = 20 + jsonLength;
  const bin = glb.subarray(binStart + 8, binStart + 8 + glb.readUInt32LE(binStart));
  json.buffers[0].uri = binName;
  return { gltf: Buffer.from(JSON.stringify(json)), bin };
}

test('viewer: scenes in every format, by the file input and by drag and drop', async () => {
  const viewer = await openViewer({ isolation: false });
  const { page } = viewer;
  try {
    await waitForStatus(page, 'done');
    // A .gltf dropped together with its .bin, then searched for the demo mug.
    const { gltf, bin } = splitGlb(await readFile(resolve(repo, 'assets/demo/scene.glb')), 'demo-scene.bin');
    const files = [
      { name: 'demo-scene.gltf', base64: gltf.toString('base64') },
      { name: 'demo-scene.bin', base64: bin.toString('base64') },
    ];
    await dropFiles(page, files);
    await waitForStatus(page, 'ready');
    assert.equal(await page.evaluate(() => globalThis.viewer.sceneName), 'demo-scene.gltf');
    // The demo's own mug went with the demo scene: opening a template searches.
    assert.equal(await page.locator('#template-name').textContent(), 'none');
    await page.setInputFiles('#template-input', resolve(repo, 'assets/demo/template.glb'));
    await waitForStatus(page, 'done');
    const demoTruth = await truth(resolve(repo, 'assets/demo'));
    assertMatchesTruth(await page.evaluate(() => globalThis.viewer.report), demoTruth, 'demo as .gltf + .bin');

    // The up axis can be chosen by hand.
    await page.selectOption('#up-axis', 'y');
    assert.equal(await page.evaluate(() => globalThis.viewer.up), 'y');
    await page.selectOption('#up-axis', 'auto');
    assert.equal(await page.evaluate(() => globalThis.viewer.up), 'z');

    // A .gltf without its .bin says what is missing.
    await page.setInputFiles('#scene-input', { name: 'alone.gltf', mimeType: 'model/gltf+json', buffer: gltf });
    await page.locator('#message').waitFor({ state: 'visible' });
    assert.match(await page.locator('#message-text').textContent(), /demo-scene\.bin together with alone\.gltf/);
    await page.evaluate(() => globalThis.viewer.dismissMessage());

    // OBJ, PLY and STL through the file input.
    const tetrahedron = [
      'solid tetrahedron',
      ...[
        [[0, 0, 0], [0, 1, 0], [1, 0, 0]],
        [[0, 0, 0], [1, 0, 0], [0, 0, 1]],
        [[0, 0, 0], [0, 0, 1], [0, 1, 0]],
        [[1, 0, 0], [0, 1, 0], [0, 0, 1]],
      ].map((t) => `facet normal 0 0 0\nouter loop\n${t.map((v) => `vertex ${v.join(' ')}`).join('\n')}\nendloop\nendfacet`),
      'endsolid tetrahedron',
    ].join('\n');
    const models = [
      resolve(shared, 'models/cow.obj'),
      resolve(shared, 'models/horse.ply'),
      { name: 'tetrahedron.stl', mimeType: 'model/stl', buffer: Buffer.from(tetrahedron) },
    ];
    for (const model of models) {
      await page.setInputFiles('#scene-input', model);
      await waitForStatus(page, 'ready');
      const name = typeof model === 'string' ? model.split('/').pop() : model.name;
      assert.equal(await page.evaluate(() => globalThis.viewer.sceneName), name);
      // A single model stands on y, as OBJ and PLY files usually do.
      if (name === 'cow.obj') assert.equal(await page.evaluate(() => globalThis.viewer.up), 'y');
    }
    assert.deepEqual(viewer.problems, []);
  } finally {
    await viewer.close();
  }
});

test('viewer: clicks — model mode keeps its template, an early click picks what a late one does, a double-click focuses, a moved sphere marks the matches stale', async () => {
  const viewer = await openViewer({ isolation: false });
  const { page } = viewer;
  const selectionAt = async (point) => {
    const { x, y } = await page.evaluate((p) => globalThis.viewer.project(p), point);
    await page.mouse.click(x, y);
    return page.evaluate(() => globalThis.viewer.selection);
  };
  try {
    await waitForStatus(page, 'done');
    // A click on a mug in model mode: no sphere, the file template stays.
    const mug = (await page.evaluate(() => globalThis.viewer.report)).instances[0].position;
    assert.equal(await selectionAt(mug), null);
    assert.ok(await page.locator('input[name="template-kind"][value="model"]').isChecked());
    assert.match(await page.locator('#template-name').textContent(), /demo mug/);
    await page.click('#search-button');
    await waitForStatus(page, 'done');
    assert.equal((await page.evaluate(() => globalThis.viewer.report)).instances.length, 3);
    assert.equal((await page.evaluate(() => globalThis.viewer.options)).keepNearTwins, undefined);
    // Keeping near twins searches again with the option; the demo's mugs
    // are exact, so the same three are found.
    await page.check('#keep-near-twins');
    await page.waitForFunction(() => globalThis.viewer.options?.keepNearTwins === true, null, { timeout: 30_000 });
    await waitForStatus(page, 'done');
    assert.equal((await page.evaluate(() => globalThis.viewer.report)).instances.length, 3);
    await page.uncheck('#keep-near-twins');
    await page.waitForFunction(() => globalThis.viewer.options?.keepNearTwins === undefined, null, { timeout: 30_000 });
    await waitForStatus(page, 'done');

    // Selection mode, and clicks on the bunnies of zoo-bunny once the page
    // has settled. The mouse hints say what a click does there.
    assert.ok(await page.locator('#selection-mouse-hints').isHidden());
    await page.click('label:has(input[value="selection"])');
    assert.ok(await page.locator('#selection-mouse-hints').isVisible());
    await page.setInputFiles('#scene-input', resolve(zooBunny, 'scene.glb'));
    await waitForStatus(page, 'ready');
    await page.waitForTimeout(1000);
    const bunnies = (await truth(zooBunny)).instances.map((t) => [t.transform[0][3], t.transform[1][3], t.transform[2][3]]);
    const spots = [];
    for (const centre of bunnies) spots.push(await page.evaluate((p) => globalThis.viewer.project(p), centre));
    const late = [];
    for (const { x, y } of spots) {
      await page.mouse.click(x, y);
      late.push(await page.evaluate(() => globalThis.viewer.selection));
    }
    assert.ok(late.every(Boolean), 'a click on a bunny placed no sphere');
    // Another scene, then zoo-bunny again, clicked at the same spots the
    // instant it is ready, before anything is drawn (the view frames a
    // scene the same way each time): the same points.
    await page.setInputFiles('#scene-input', resolve(repo, 'assets/demo/scene.glb'));
    await waitForStatus(page, 'ready');
    await page.evaluate((spots) => {
      const observer = new MutationObserver(() => {
        if (document.body.dataset.status !== 'ready') return;
        observer.disconnect();
        const canvas = document.querySelector('#viewport canvas');
        globalThis.earlyPicks = spots.map(({ x, y }) => {
          const at = { clientX: x, clientY: y, button: 0, bubbles: true, pointerId: 1, pointerType: 'mouse', isPrimary: true };
          canvas.dispatchEvent(new PointerEvent('pointerdown', at));
          canvas.dispatchEvent(new PointerEvent('pointerup', at));
          canvas.dispatchEvent(new MouseEvent('click', { ...at, detail: 1 }));
          return globalThis.viewer.selection;
        });
      });
      observer.observe(document.body, { attributes: true, attributeFilter: ['data-status'] });
    }, spots);
    await page.setInputFiles('#scene-input', resolve(zooBunny, 'scene.glb'));
    await waitForStatus(page, 'ready');
    const early = await page.evaluate(() => globalThis.earlyPicks);
    for (const [j, pick] of early.entries()) {
      assert.ok(pick, `bunny ${j}: the early click placed no sphere`);
      assert.ok(Math.hypot(...pick.center.map((v, i) => v - late[j].center[i])) < 1e-6, `bunny ${j}: early ${pick.center}, late ${late[j].center}`);
    }
    await page.mouse.click(spots.at(-1).x, spots.at(-1).y);
    // The last click was on a bunny: search it, then move the sphere.
    const placed = await page.evaluate(() => globalThis.viewer.selection);
    await page.click('#search-button');
    await waitForStatus(page, 'done');
    assert.ok(await page.locator('#results-stale').isHidden());
    // A double-click elsewhere turns the view; the sphere stays put.
    const { x, y } = await page.evaluate((p) => globalThis.viewer.project(p), bunnies[0]);
    const distance = await page.evaluate(() => globalThis.viewer.cameraDistance);
    await page.mouse.dblclick(x, y);
    // The flight takes 700 ms of frames, and a loaded machine draws few.
    await page.waitForTimeout(900);
    await page.waitForFunction(() => !globalThis.viewer.flying, null, { timeout: 30_000 });
    assert.deepEqual(await page.evaluate(() => globalThis.viewer.selection), placed);
    assert.ok(Math.abs((await page.evaluate(() => globalThis.viewer.cameraDistance)) - distance) < distance * 1e-3);
    assert.ok(await page.locator('#results-stale').isHidden());
    // A click that moves it says the matches shown are the old ones.
    const { x: cx, y: cy } = await page.evaluate((p) => globalThis.viewer.project(p), bunnies[1]);
    await page.mouse.click(cx, cy);
    assert.notDeepEqual(await page.evaluate(() => globalThis.viewer.selection), placed);
    assert.ok(await page.locator('#results-stale').isVisible());
    await page.click('#search-button');
    await waitForStatus(page, 'done');
    assert.ok(await page.locator('#results-stale').isHidden());
    assert.deepEqual(viewer.problems, []);
  } finally {
    await viewer.close();
  }
});

test('viewer: templates — a broken one keeps the previous, one dropped on the view searches, with names, ghosts, export, fit view and x-ray', async () => {
  const viewer = await openViewer({ isolation: false });
  const { page } = viewer;
  try {
    await waitForStatus(page, 'done');
    // A broken template file: named in the message, the mug stays.
    await page.setInputFiles('#template-input', { name: 'broken.glb', mimeType: 'model/gltf-binary', buffer: Buffer.from('glTF nonsense') });
    await page.locator('#message').waitFor({ state: 'visible', timeout: 30_000 });
    const message = await page.locator('#message-text').textContent();
    assert.match(message, /broken\.glb/);
    assert.match(message, /still demo mug/);
    assert.match(await page.locator('#template-name').textContent(), /demo mug/);
    await page.evaluate(() => globalThis.viewer.dismissMessage());
    await page.click('#search-button');
    await waitForStatus(page, 'done');
    assert.equal((await page.evaluate(() => globalThis.viewer.report)).instances.length, 3);
    // The demo mug's poses carry the ghosts.
    assert.equal(await page.evaluate(() => globalThis.viewer.ghosts), 3);
    // A search judged longer than the page allows asks first, and runs on a yes.
    await page.evaluate(() => {
      globalThis.viewer.longSearchSeconds = 0;
    });
    await page.click('#search-button');
    await page.waitForFunction(() => globalThis.viewer.status === 'asked', null, { timeout: 60_000, polling: 100 });
    assert.match(
      await page.evaluate(() => globalThis.viewer.lastMessage),
      /^This search will take about \d+ s or more: \d+ different parts of the scene are large enough to hold the template/,
    );
    assert.equal(await page.locator('#match-count').textContent(), '');
    assert.equal(await page.locator('#message-action').textContent(), 'Search anyway');
    await page.click('#message-action');
    await waitForStatus(page, 'done');
    assert.equal((await page.evaluate(() => globalThis.viewer.report)).instances.length, 3);
    await page.evaluate(() => {
      globalThis.viewer.longSearchSeconds = 30;
    });

    // zoo-bunny, and its template dropped on the view's right half.
    await page.setInputFiles('#scene-input', resolve(zooBunny, 'scene.glb'));
    await waitForStatus(page, 'ready');
    assert.equal(await page.locator('#template-name').textContent(), 'none');
    assert.ok(await page.locator('#template-preview').isHidden());
    const template = (await readFile(resolve(zooBunny, 'template.glb'))).toString('base64');
    const box = await page.locator('#viewport').boundingBox();
    await dropFiles(page, [{ name: 'bunny.glb', base64: template }], { clientX: box.x + box.width * 0.75, clientY: box.y + box.height / 2 });
    await waitForStatus(page, 'done');
    assert.equal(await page.locator('#template-name').textContent(), 'bunny.glb');
    // Its preview is drawn: the canvas holds more than its background.
    assert.ok(await page.locator('#template-preview').isVisible());
    const preview = pixelBytes(await page.locator('#template-preview').screenshot());
    assert.ok(new Set(preview).size > 32, 'the template preview is blank');
    assert.equal(await page.evaluate(() => globalThis.viewer.sceneName), 'scene.glb');
    const report = await page.evaluate(() => globalThis.viewer.report);
    assertMatchesTruth(report, await truth(zooBunny), 'zoo-bunny, dropped template');
    // The readout leaves out the scene's load, paid once when it was opened.
    const searching = (report.timingsMs.total - report.timingsMs.load).toFixed(0);
    assert.match(await page.locator('#total-time').textContent(), new RegExp(`^${searching} ms searching`));
    assert.ok(report.timingsMs.load > 0);
    // Each match is named after the glTF node it lies in, and drawn as the template at its pose.
    const names = await page.evaluate(() => globalThis.viewer.names);
    assert.equal(names.length, 4);
    for (const name of names) assert.match(name, /^stanford-bunny/);
    assert.match(await page.locator('#instance-list li').first().textContent(), /stanford-bunny.*score.*distance.*support \d+ · whole copy/);
    assert.equal(await page.evaluate(() => globalThis.viewer.ghosts), 4);
    await page.uncheck('#show-ghosts');
    assert.equal(await page.evaluate(() => globalThis.viewer.ghosts), 0);
    await page.check('#show-ghosts');

    // The report as a file, with the names.
    const [download] = await Promise.all([page.waitForEvent('download'), page.click('#export-button')]);
    const exported = JSON.parse(await readFile(await download.path(), 'utf8'));
    assert.equal(download.suggestedFilename(), 'scene-matches.json');
    assert.equal(exported.scene, 'scene.glb');
    assert.equal(exported.template.file, 'bunny.glb');
    assert.deepEqual(exported.template.center, report.template.center);
    assert.equal(exported.options.descriptor, 'volume+harmonics');
    // Only the options that applied: no curvature box in a voxel search.
    assert.ok('volumeThreshold' in exported.options && 'harmonicsThreshold' in exported.options, JSON.stringify(exported.options));
    assert.ok(!('curvatureThreshold' in exported.options) && !('curvatureSpacing' in exported.options), JSON.stringify(exported.options));
    assert.deepEqual(exported.instances.map((i) => i.name), names);
    assert.deepEqual(exported.instances.map((i) => i.position), report.instances.map((i) => i.position));
    assert.equal(exported.instances[0].pose.length, 4);

    // Fit view, by key and by button, after flying to a match.
    const camera = () => page.evaluate(() => ({ distance: globalThis.viewer.cameraDistance, target: globalThis.viewer.cameraTarget }));
    const near = (a, b, scale) => a.every((v, i) => Math.abs(v - b[i]) < scale * 1e-6);
    const framed = await camera();
    const first = report.instances[0].position;
    for (const fit of [() => page.keyboard.press('f'), () => page.click('#fit-button')]) {
      await page.locator('#instance-list li button').first().click();
      // The flight lasts 0.7 s of rendered frames.
      await page.waitForFunction(
        (p) => globalThis.viewer.cameraTarget.every((v, i) => Math.abs(v - p[i]) < 1e-9 + 1e-6 * Math.abs(p[i])),
        first,
        { timeout: 10_000 },
      );
      await fit();
      const fitted = await camera();
      assert.ok(near(fitted.target, framed.target, framed.distance) && Math.abs(fitted.distance - framed.distance) < framed.distance * 1e-6);
    }
    // X-ray by key; a screenshot shows the ghosts through the scene.
    await page.keyboard.press('x');
    assert.equal(await page.evaluate(() => globalThis.viewer.xray), true);
    assert.ok(await page.locator('#xray').isChecked());
    await mkdir(screenshots, { recursive: true });
    await page.screenshot({ path: resolve(screenshots, 'viewer-xray-ghosts.png') });
    await page.keyboard.press('x');
    assert.equal(await page.evaluate(() => globalThis.viewer.xray), false);
    assert.deepEqual(viewer.problems, []);
  } finally {
    await viewer.close();
  }
});

/** The colour a match is drawn in (orange, or yellow when focused), told from the clay and the background. */
const isMatchColour = ([r, , b]) => r > 120 && r - b > 60;

/** Scene point `p` in the coordinates of the template placed by the row-major 4x4 `pose`. */
function intoTemplate(pose, p) {
  const d = [0, 1, 2].map((r) => p[r] - pose[r][3]);
  return [0, 1, 2].map((c) => pose[0][c] * d[0] + pose[1][c] * d[1] + pose[2][c] * d[2]);
}

/** The box of a .glb's first POSITION accessor (its min and max, as glTF requires them). */
function glbBox(glb) {
  const json = JSON.parse(glb.subarray(20, 20 + glb.readUInt32LE(12)).toString('utf8'));
  const accessor = json.accessors[json.meshes[0].primitives[0].attributes.POSITION];
  return { min: accessor.min, max: accessor.max };
}

test('viewer: matches inside an assembly — isolate shows every one, a click through x-ray lands on one, the cut-away clears the way to one flown to', async () => {
  const saw = resolve(shared, 'scenes/real-saw-roller');
  const viewer = await openViewer({ isolation: true });
  const { page } = viewer;
  try {
    await waitForStatus(page, 'done');
    await page.setInputFiles('#scene-input', resolve(saw, 'scene.glb'));
    await waitForStatus(page, 'ready');
    const templateGlb = await readFile(resolve(saw, 'template.glb'));
    // Every value the progress bar takes during the search, and the text beside it.
    await page.evaluate(() => {
      globalThis.barValues = [];
      const bar = document.getElementById('progress-bar');
      new MutationObserver(() => globalThis.barValues.push({ value: bar.value, text: document.getElementById('progress-text').textContent })).observe(
        bar,
        { attributes: true, attributeFilter: ['value'] },
      );
    });
    await page.setInputFiles('#template-input', { name: 'roller.glb', mimeType: 'model/gltf-binary', buffer: templateGlb });
    await waitForStatus(page, 'done');
    // The bar starts from 0 and only rises to 1: no jump back between the
    // layers of the first part and the count of parts.
    const bar = await page.evaluate(() => globalThis.barValues);
    const fromZero = bar.slice(bar.findLastIndex((b) => b.value === 0));
    assert.ok(fromZero.length >= 5, `the bar moved ${fromZero.length} times`);
    for (let k = 1; k < fromZero.length; k += 1) {
      assert.ok(fromZero[k].value >= fromZero[k - 1].value, `the bar fell from ${JSON.stringify(fromZero[k - 1])} to ${JSON.stringify(fromZero[k])}`);
    }
    assert.equal(fromZero.at(-1).value, 1);
    assert.ok(fromZero.some((b) => /^Searched \d+ of \d+ parts/.test(b.text)), 'parts done of total are told');
    const report = await page.evaluate(() => globalThis.viewer.report);
    const sawTruth = await truth(saw);
    assertMatchesTruth(report, sawTruth, 'real-saw-roller');
    const centres = report.instances.map((i) => i.position);
    // From outside, the centre's pixel; isolated, any pixel next to it (a
    // needle roller seen end-on is a few pixels wide, and its centre's
    // pixel may fall on the background beside it).
    const seen = async (spread = 0) => {
      const colours = await page.evaluate(([points, spread]) => globalThis.viewer.coloursAt(points, { spread }), [centres, spread]);
      return spread > 0 ? colours.filter((square) => square.some(isMatchColour)).length : colours.filter(isMatchColour).length;
    };
    // The rollers sit inside the housing: from outside, few show.
    const outside = await seen();
    assert.ok(outside < centres.length / 2, `${outside} of ${centres.length} rollers show through the housing`);
    await page.keyboard.press('i');
    assert.equal(await page.evaluate(() => globalThis.viewer.isolate), true);
    assert.equal(await seen(1), centres.length, 'isolate shows every match');
    await mkdir(screenshots, { recursive: true });
    await page.screenshot({ path: resolve(screenshots, 'viewer-isolate-rollers.png') });
    await page.keyboard.press('i');

    // A click on a roller's centre: on the housing in front of it, but
    // through x-ray on a roller (its point falls in the template's box at
    // a roller's pose; another roller may stand in front).
    const box = glbBox(templateGlb);
    const slack = 0.02 * sawTruth.template_radius;
    const onRoller = (pose, p) => intoTemplate(pose, p).every((v, a) => v >= box.min[a] - slack && v <= box.max[a] + slack);
    await page.click('label:has(input[value="selection"])');
    const landings = async () => {
      let on = 0;
      let last = { x: -100, y: -100 };
      for (const k of centres.keys()) {
        const at = await page.evaluate((p) => globalThis.viewer.project(p), centres[k]);
        // Two quick clicks a few pixels apart are a double-click.
        if (Math.hypot(at.x - last.x, at.y - last.y) < 10) await page.waitForTimeout(700);
        last = at;
        await page.mouse.click(at.x, at.y);
        const picked = await page.evaluate(() => globalThis.viewer.selection?.center ?? null);
        if (picked && report.instances.some((other) => onRoller(other.pose, picked))) on += 1;
      }
      return on;
    };
    const plain = await landings();
    assert.ok(plain < centres.length / 2, `${plain} clicks land on a roller without x-ray`);
    await page.keyboard.press('x');
    // A roller is a few pixels wide from here: a click at its centre's
    // pixel may pass beside one seen nearly end-on.
    const through = await landings();
    assert.ok(through >= centres.length - 2 && through > plain, `${through} clicks land on a roller through x-ray, ${plain} without`);
    await page.keyboard.press('x');
    await page.click('label:has(input[value="model"])');

    // Flown to from the list: the housing hides the roller from there, so
    // the cut-away turns on by itself, and the match is in sight.
    assert.equal(await page.evaluate(() => globalThis.viewer.cutaway), false);
    // Frames are slow on software WebGL: two flights.
    for (const k of [7, 20]) {
      await page.locator('#instance-list li button').nth(k).click();
      assert.equal(await page.evaluate(() => globalThis.viewer.cutaway), true);
      assert.equal(await page.locator('#cutaway').isChecked(), true);
      await page.waitForFunction(
        (p) => globalThis.viewer.cameraTarget.every((v, i) => Math.abs(v - p[i]) < 1e-9 + 1e-6 * Math.abs(p[i])),
        centres[k],
        { timeout: 60_000 },
      );
      const [colour] = await page.evaluate((p) => globalThis.viewer.coloursAt([p]), centres[k]);
      assert.ok(isMatchColour(colour), `match ${k} is hidden after flying to it with the cut-away: ${colour}`);
    }
    await page.screenshot({ path: resolve(screenshots, 'viewer-cutaway-roller.png') });
    assert.deepEqual(viewer.problems, []);
  } finally {
    await viewer.close();
  }
});

test('viewer: repeated parts — found without a template, a part lights up every copy, the instanced file is saved', async () => {
  const viewer = await openViewer({ isolation: true });
  const { page } = viewer;
  try {
    await waitForStatus(page, 'done');
    await page.setInputFiles('#scene-input', resolve(shared, 'scenes/real-saw-roller/scene.glb'));
    await waitForStatus(page, 'ready');
    await page.click('#repeats-button');
    await page.waitForFunction(() => !!globalThis.viewer.repeats || !!globalThis.viewer.lastMessage, null, { timeout: 120_000, polling: 100 });
    assert.equal(await page.evaluate(() => globalThis.viewer.lastMessage), null);
    // Every step was told, the last one at the end.
    const told = await page.evaluate(() => globalThis.viewer.repeatsProgress);
    assert.ok(told && told.done === told.total && told.total >= 7, JSON.stringify(told));
    const found = await page.evaluate(() => ({
      copies: globalThis.viewer.repeats.families.map((f) => f.copies.length),
      bytes: globalThis.viewer.repeats.written.bytes,
    }));
    // The saw's 24 rollers are among its repeated parts, one list entry each.
    assert.ok(found.copies.includes(24), String(found.copies));
    assert.equal(await page.locator('#family-list button').count(), found.copies.length);
    assert.match(await page.locator('#repeats-summary').textContent(), /parts repeat, \d+ copies in all .* The instanced file: .* MB, from 4\.3 MB/);
    const rollers = found.copies.indexOf(24);
    await page.locator('#family-list button').nth(rollers).click();
    assert.equal(await page.evaluate(() => globalThis.viewer.highlighted), 24);
    await mkdir(screenshots, { recursive: true });
    await page.screenshot({ path: resolve(screenshots, 'viewer-repeats-rollers.png') });
    const [download] = await Promise.all([page.waitForEvent('download'), page.click('#save-instanced-button')]);
    assert.equal(download.suggestedFilename(), 'scene-instanced.glb');
    const saved = await readFile(await download.path());
    assert.equal(saved.subarray(0, 4).toString(), 'glTF');
    assert.equal(saved.length, found.bytes);
    // Another scene forgets the parts of this one.
    await page.setInputFiles('#scene-input', resolve(shared, 'scenes/real-truck-wheels/scene.glb'));
    await waitForStatus(page, 'ready');
    assert.equal(await page.evaluate(() => globalThis.viewer.repeats), null);
    assert.equal(await page.locator('#family-list button').count(), 0);
    assert.deepEqual(viewer.problems, []);
  } finally {
    await viewer.close();
  }
});

test('viewer: a heavy model is drawn light while the camera moves, its matches always, and whole once it stops', async () => {
  const viewer = await openViewer({ isolation: false });
  const { page } = viewer;
  try {
    await waitForStatus(page, 'done');
    // Here every model is heavy and a light frame draws as little as it
    // may: the matched mugs, and of the rest only the largest part.
    await page.evaluate(() => {
      globalThis.viewer.navigationLimits = { heavyFrameMs: 0, lightFrameMs: 0, minTriangles: 1 };
    });
    const since = await page.evaluate(() => performance.now());
    const box = await page.locator('#viewport canvas').boundingBox();
    const x = box.x + box.width / 2;
    const y = box.y + box.height / 2;
    await page.mouse.move(x, y);
    await page.mouse.down();
    for (let step = 1; step <= 20; step += 1) {
      await page.mouse.move(x + 5 * step, y + step);
      await page.waitForTimeout(50);
    }
    await page.mouse.up();
    await page.waitForFunction(() => globalThis.viewer.settled, null, { timeout: 60_000, polling: 100 });
    const frames = (await page.evaluate(() => globalThis.viewer.frameLog)).filter((f) => f.at > since);
    const light = frames.filter((f) => f.light);
    const full = frames.filter((f) => !f.light);
    assert.ok(light.length >= 3, `${light.length} light frames while the camera moved`);
    assert.equal(frames.at(-1).light, false, 'the last frame draws the whole model');
    const whole = full.at(-1).triangles;
    assert.ok(light.every((f) => f.triangles < whole), `light frames draw ${light.map((f) => f.triangles)} of ${whole} triangles`);
    assert.deepEqual(await page.evaluate(() => globalThis.viewer.navigation.heavy), true);

    // From where the orbit left the camera: every mug lit in the light
    // frame too, and the shapes beside them drawn only in the full one.
    const demo = await truth(resolve(repo, 'assets/demo'));
    const mugs = demo.instances.map((t) => [t.transform[0][3], t.transform[1][3], t.transform[2][3]]);
    const shapes = [
      [2.6, 0, 0],
      [0, 2.6, 0],
      [5.2, 2.6, 0],
      [0, 5.2, 0],
      [2.6, 5.2, 0],
      [5.2, 5.2, 0],
    ];
    const background = ([r, g, b]) => Math.abs(r - 0x20) + Math.abs(g - 0x24) + Math.abs(b - 0x2b) < 12;
    const drawn = (squares) => squares.filter((square) => square.some((c) => !background(c))).length;
    const lit = (squares) => squares.filter((square) => square.some(isMatchColour)).length;
    const colours = (points, light, spread) =>
      page.evaluate(([points, light, spread]) => globalThis.viewer.coloursAt(points, { spread, light }), [points, light, spread]);
    assert.equal(lit(await colours(mugs, true, 3)), mugs.length, 'every match is drawn in a light frame');
    assert.equal(lit(await colours(mugs, false, 3)), mugs.length);
    // A shape may be hollow at its centre (a ring): the square around it is wider.
    assert.equal(drawn(await colours(shapes, false, 10)), shapes.length, 'the full frame draws every shape');
    assert.ok(drawn(await colours(shapes, true, 10)) <= 1, 'a light frame at its least draws one part besides the matches');
    assert.deepEqual(viewer.problems, []);
  } finally {
    await viewer.close();
  }
});
