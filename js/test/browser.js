// Runs the package in headless Chromium (playwright-core driving the system
// Chromium) from a local server that sends the COOP/COEP headers a threaded
// page needs. Used by the browser test and by the benchmark.
import { readFile } from 'node:fs/promises';
import { createServer } from 'node:http';
import { extname, normalize, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';

import { chromium } from 'playwright-core';

const repo = fileURLToPath(new URL('../../', import.meta.url));
/** URL prefixes and the folders they serve. */
const ROOTS = {
  '/pkg/': resolve(repo, 'pkg'),
  '/page/': resolve(repo, 'js/test/page'),
  '/scenes/': resolve(repo, '../shared/scenes'),
};
const TYPES = {
  '.html': 'text/html',
  '.js': 'text/javascript',
  '.wasm': 'application/wasm',
  '.glb': 'model/gltf-binary',
  '.json': 'application/json',
};
const CHROMIUM_FLAGS = [
  '--no-sandbox',
  '--disable-dev-shm-usage',
  '--disable-background-networking',
  '--disable-component-update',
  '--disable-sync',
  '--no-first-run',
];

/** A static server on 127.0.0.1 (a random port) with cross-origin isolation headers. */
export async function startServer() {
  const server = createServer(async (request, response) => {
    const path = decodeURIComponent(new URL(request.url, 'http://x').pathname);
    const prefix = Object.keys(ROOTS).find((p) => path.startsWith(p));
    const file = prefix && normalize(resolve(ROOTS[prefix], '.' + path.slice(prefix.length - 1)));
    if (!file || !file.startsWith(ROOTS[prefix])) {
      response.writeHead(404).end();
      return;
    }
    try {
      const body = await readFile(file);
      response.writeHead(200, {
        'Content-Type': TYPES[extname(file)] ?? 'application/octet-stream',
        'Cross-Origin-Opener-Policy': 'same-origin',
        'Cross-Origin-Embedder-Policy': 'require-corp',
        'Cache-Control': 'no-store',
      });
      response.end(body);
    } catch {
      response.writeHead(404).end();
    }
  });
  await new Promise((done) => server.listen(0, '127.0.0.1', done));
  return { server, origin: `http://127.0.0.1:${server.address().port}` };
}

/**
 * Opens the page and runs `jobs` (see page/worker.js), each in a fresh
 * worker; returns their results. `threads` is the threaded build's pool
 * size; `afterLaunch` runs once Chromium is up (the benchmark raises its
 * priority there).
 */
export async function runInBrowser(jobs, { threads = 2, afterLaunch } = {}) {
  const { server, origin } = await startServer();
  const browser = await chromium.launch({
    executablePath: process.env.CHROMIUM ?? '/usr/bin/chromium',
    args: CHROMIUM_FLAGS,
  });
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
