// Runs the package in headless Chromium (playwright-core driving the system
// Chromium) from the viewer's server (www/server.js), which sends the
// COOP/COEP headers a threaded page needs. Used by the browser test, the
// benchmark and the viewer's end-to-end test (launchChromium).
import { resolve } from 'node:path';
import { fileURLToPath } from 'node:url';

import { chromium } from 'playwright-core';

import { startServer } from '../../www/server.js';

const repo = fileURLToPath(new URL('../../', import.meta.url));
/** URL prefixes and the folders they serve. */
const ROOTS = {
  '/pkg/': resolve(repo, 'pkg'),
  '/page/': resolve(repo, 'js/test/page'),
  '/scenes/': resolve(repo, '../shared/scenes'),
  // Scenes made by the generators (scripts/bench.py writes them there).
  '/scenes/generated/': resolve(repo, 'target/bench-inputs'),
};
/** Headless Chromium on a closed network (see ../shared/TOOLCHAIN.md). */
const CHROMIUM_FLAGS = [
  '--no-sandbox',
  '--disable-dev-shm-usage',
  '--disable-background-networking',
  '--disable-component-update',
  '--disable-sync',
  '--no-first-run',
  // WebGPU on SwiftShader, Chromium's software adapter (Scene.matchGpu's
  // tests; the page only uses it when told to allow a software adapter).
  '--enable-unsafe-webgpu',
  '--use-webgpu-adapter=swiftshader',
];

/** The system Chromium (or $CHROMIUM), headless, with `extraArgs` besides the quiet flags. */
export function launchChromium(extraArgs = []) {
  return chromium.launch({
    executablePath: process.env.CHROMIUM ?? '/usr/bin/chromium',
    args: [...CHROMIUM_FLAGS, ...extraArgs],
  });
}

/**
 * Opens the page and runs `jobs` (see page/worker.js), each in a fresh
 * worker; returns their results. `threads` is the threaded build's pool
 * size; `afterLaunch` runs once Chromium is up (the benchmark raises its
 * priority there).
 */
export async function runInBrowser(jobs, { threads = 2, afterLaunch } = {}) {
  const { server, origin } = await startServer({ port: 0, roots: ROOTS });
  const browser = await launchChromium();
  try {
    await afterLaunch?.();
    const page = await browser.newPage();
    const errors = [];
    page.on('pageerror', (error) => errors.push(error));
    await page.goto(`${origin}/page/index.html`);
    const results = [];
    for (const job of jobs) {
      results.push(await page.evaluate((job) => globalThis.runJob(job), { threads, ...job }));
    }
    if (errors.length) throw errors[0];
    return results;
  } finally {
    await browser.close();
    server.close();
  }
}
