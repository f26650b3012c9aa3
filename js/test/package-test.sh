#!/usr/bin/env bash
# `npm pack` of pkg/, installed into a scratch project as a user would:
# Node resolves its `exports` and runs it, tsc type-checks a program against
# its types (the JS entry included; a wrong call must be rejected), Vite
# bundles it for the browser with both wasm builds as assets, the README's
# worker example runs as written in Node and, bundled by Vite, in headless
# Chromium, and a search runs under the Vite dev server, in an esbuild
# bundle made by the README's recipe, and under webpack's dev server and build.
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
tools=$repo/js/node_modules
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
tarball=$(cd "$repo/pkg" && npm pack --silent --pack-destination "$scratch" | tail -n 1)
mkdir -p "$scratch/app/src"
cd "$scratch/app"
cat > package.json <<JSON
{ "name": "scratch-app", "private": true, "type": "module",
  "dependencies": { "fast-reject": "file:../$tarball" } }
JSON
npm install --no-audit --no-fund --loglevel=error

echo "-- Node imports the installed package"
node --input-type=module -e "
  import { init, Scene } from 'fast-reject';
  const info = await init();
  if (info.build !== 'plain') throw new Error('expected the plain build in Node, got ' + info.build);
  try { Scene.fromBytes(new Uint8Array(8)); throw new Error('garbage was accepted'); }
  catch (e) { if (!/unrecognized mesh data/.test(e.message)) throw e; }
  console.log('ok:', JSON.stringify(info));
"
# The bin, with the demo scene the tarball carries.
node_modules/.bin/fast-reject demo --json | node -e "
  const report = JSON.parse(require('fs').readFileSync(0, 'utf8'));
  if (report.instances.length !== 3) throw new Error('the demo has 3 mugs, found ' + report.instances.length);
  console.log('ok: fast-reject demo found 3 instances');
"

echo "-- the README's worker example, as written, in Node"
# The first js block after the marker, from the README the tarball ships.
awk '/<!-- example: worker -->/ { found = 1; next }
     found && /^```js/ { inside = 1; next }
     inside && /^```/ { exit }
     inside { print }' node_modules/fast-reject/README.md > src/example.js
test -s src/example.js || { echo "no worker example in the package README" >&2; exit 1; }
cat > node-example.mjs <<'JS'
import { readFile } from 'node:fs/promises';
import { findCopies } from './src/example.js';
const demo = 'node_modules/fast-reject/demo/';
const [scene, template] = await Promise.all([readFile(demo + 'scene.glb'), readFile(demo + 'template.glb')]);
const copies = await findCopies(scene, template);
if (copies?.length !== 3) throw new Error('the demo has 3 mugs, the example found ' + copies?.length);
const controller = new AbortController();
controller.abort();
if ((await findCopies(scene, template, controller.signal)) !== null) throw new Error('an aborted search was not cancelled');
console.log('ok: the example found 3 mugs, and an aborted search returned null');
// No terminate(): the idle worker must let Node exit.
JS
timeout 120 node node-example.mjs

echo "-- tsc checks a program against the package's types"
cat > src/main.ts <<'TS'
import { init, Scene, Template, CancelledError, type MatchReport, type LayerStats, type MatchOptions, type SceneOptions, type SearchProgress } from 'fast-reject';
import { SearchWorker, type SceneInfo, type WorkerInfo } from 'fast-reject/worker';

export async function inWorker(sceneBytes: ArrayBuffer, signal: AbortSignal): Promise<number> {
  const search = new SearchWorker({ backend: 'cpu', build: 'auto' });
  const info: WorkerInfo = await search.ready();
  const loaded: SceneInfo = await search.loadScene(sceneBytes, { resolution: info.defaults.scene.resolution });
  try {
    const report = await search.match({ center: [0, 0, 0], radius: loaded.voxelSize * 40 }, { layers: 4 }, {
      signal,
      onLayer: (layer) => layer.survivors > 0,
      onProgress: ({ step, done, total }) => step !== 'parts' || done <= total,
    });
    return report.instances.length;
  } catch (error) {
    if (error instanceof CancelledError && error.code === 'cancelled') return 0;
    throw error;
  } finally {
    search.terminate();
    // @ts-expect-error: the backends are 'auto', 'cpu' and 'gpu'
    new SearchWorker({ backend: 'webgpu' });
    // @ts-expect-error: a template is a file or a sphere, not both
    void search.match({ bytes: sceneBytes, center: [0, 0, 0], radius: 1 });
    // @ts-expect-error: a centre has three coordinates
    void search.match({ center: [0, 0], radius: 1 });
  }
}

export async function find(sceneBytes: Uint8Array, templateBytes: ArrayBuffer): Promise<MatchReport> {
  const info = await init({ build: 'auto' });
  const build: 'plain' | 'threads' = info.build;
  const scene = Scene.fromBytes(sceneBytes, { format: 'glb', resolution: 256 });
  const template = build === 'plain' ? Template.fromBytes(templateBytes) : Template.fromSelection([0, 0, 0], 1);
  const report = scene.match(template, { descriptor: 'volume', verifyThreshold: 0.9 }, (s: LayerStats) => s.survivors > 0);
  const xyz: Float64Array = report.instancePositions;
  const first: number = report.instances[0]?.position[0] ?? xyz[0];
  // A curvature search has no grid, a voxel one no surface.
  const candidates: number = report.grid?.skinVoxels ?? report.surface?.vertices ?? 0;
  const agreement: number | null = report.instances[0]?.score ?? null;
  console.log(first, report.timingsMs.match, candidates, agreement);
  scene.match(template, {}, { onProgress: (p: SearchProgress) => p.done <= p.total });
  // @ts-expect-error: a step is 'parts', 'windows' or 'candidates'
  const wrongStep: SearchProgress = { step: 'layers', done: 0, total: 1 };
  void wrongStep;
  const onGpu: MatchReport = await scene.matchGpu(template, {}, undefined, { allowSoftware: false });
  const adapter: string | null = onGpu.gpu?.adapter ?? null;
  console.log(adapter, onGpu.gpu?.fallback);
  scene.free();
  template.free();
  // @ts-expect-error: a resolution is a number
  Scene.fromBytes(sceneBytes, { resolution: 'high' });
  // @ts-expect-error: descriptors are a union of names, not any string
  const misspelt: MatchOptions = { descriptor: 'curvatur' };
  // @ts-expect-error: an unknown option is a type error (and a runtime one)
  const unknown: SceneOptions = { resolutoin: 64 };
  void misspelt;
  void unknown;
  // @ts-expect-error: a centre has three coordinates
  Template.fromSelection([0, 0], 1);
  Template.fromSelection(new Float64Array(3), 1);
  // @ts-expect-error: handles come from the factories only
  new Scene();
  return report;
}
TS
cat > tsconfig.json <<'JSON'
{ "compilerOptions": { "target": "es2022", "module": "esnext", "moduleResolution": "bundler",
    "strict": true, "noEmit": true, "lib": ["es2022", "dom"], "skipLibCheck": false },
  "include": ["src"] }
JSON
node "$tools/typescript/bin/tsc" -p tsconfig.json
# The same check with Node's own resolution of the exports map.
node "$tools/typescript/bin/tsc" -p tsconfig.json --module nodenext --moduleResolution nodenext

echo "-- Vite bundles it for the browser, with the README's worker example"
cat > src/browser.js <<'JS'
import { findCopies } from './example.js';
import { find } from './main.ts';

const bytes = (url) => fetch(url).then((response) => response.arrayBuffer()).then((data) => new Uint8Array(data));
// Kept in the bundle: the API used on the page's own thread.
globalThis.findOnPage = find;
globalThis.exampleResult = Promise.all([bytes('/demo/scene.glb'), bytes('/demo/template.glb')]).then(
  async ([scene, template]) => {
    const found = await findCopies(scene, template);
    const controller = new AbortController();
    const cancelled = findCopies(scene, template, controller.signal);
    setTimeout(() => controller.abort(), 0);
    return { found: found?.length ?? null, cancelled: await cancelled, isolated: globalThis.crossOriginIsolated };
  },
);
JS
cat > index.html <<'HTML'
<!doctype html><script type="module" src="/src/browser.js"></script>
HTML
mkdir -p public/demo
cp node_modules/fast-reject/demo/*.glb public/demo/
# What the README says Vite needs.
echo "export default { worker: { format: 'es' } };" > vite.config.js
node "$tools/vite/bin/vite.js" build --logLevel warn
wasm_assets=$(find dist -name '*.wasm' | wc -l)
if ((wasm_assets != 2)); then
  echo "expected both wasm builds among the bundle's assets, found $wasm_assets" >&2
  find dist >&2
  exit 1
fi
echo "ok: bundle with $(find dist -name '*.js' | wc -l) script(s) and $wasm_assets wasm assets"

# The bundle in headless Chromium, served cross-origin isolated as the
# README asks: the worker runs the example, then a search aborted at once.
cat > browser-example.mjs <<JS
import { launchChromium } from '$repo/js/test/browser.js';
import { startServer } from '$repo/www/server.js';
const { server, origin } = await startServer({ port: 0, roots: { '/': '$scratch/app/dist' } });
const browser = await launchChromium();
try {
  const page = await browser.newPage();
  const errors = [];
  page.on('pageerror', (error) => errors.push(error));
  await page.goto(origin + '/index.html');
  const result = await page.evaluate(() => globalThis.exampleResult);
  if (errors.length) throw errors[0];
  if (result.found !== 3 || result.cancelled !== null || !result.isolated) throw new Error(JSON.stringify(result));
  console.log('ok: the bundled example found 3 mugs in Chromium, and the aborted search returned null');
} finally {
  await browser.close();
  server.close();
}
JS
timeout 300 node browser-example.mjs

echo "-- the Vite dev server, cross-origin isolated, as the README configures it"
# The README's config, and a plugin that breaks the pool's worker script on
# demand: where the pool cannot start, 'auto' must run the plain build and
# say why, and 'threads' must fail with a ThreadPoolError, both within
# seconds rather than hang.
awk '/^\/\/ vite.config.js/ { found = 1; next } found && /^```/ { exit } found' \
  node_modules/fast-reject/README.md > readme.config.js
cat > vite.config.js <<'JS'
import config from './readme.config.js';

// A pool worker's script fails to load (its fetch is the one whose
// destination is a worker); the same file imported as a module still loads.
function breakThePool(server) {
  server.middlewares.use((request, response, next) => {
    if (!/workerHelpers/.test(request.url) || request.headers['sec-fetch-dest'] !== 'worker') return next();
    response.statusCode = 500;
    response.end('broken on purpose');
  });
}
if (process.env.BREAK_POOL) config.plugins = [{ name: 'break-the-pool', configureServer: breakThePool }];
export default config;
JS
cat > src/dev.js <<'JS'
import { SearchWorker, ThreadPoolError } from 'fast-reject/worker';

const bytes = (url) => fetch(url).then((response) => response.arrayBuffer()).then((data) => new Uint8Array(data));
globalThis.devResult = (async () => {
  const build = new URLSearchParams(location.search).get('build') ?? 'auto';
  const started = performance.now();
  const search = new SearchWorker({ build });
  try {
    const info = await search.ready();
    const [scene, template] = await Promise.all([bytes('/demo/scene.glb'), bytes('/demo/template.glb')]);
    await search.loadScene(scene);
    const report = await search.match({ bytes: template });
    return { build: info.build, fallback: info.fallback, found: report.instances.length, seconds: (performance.now() - started) / 1000 };
  } catch (error) {
    return { error: error.name, poolError: error instanceof ThreadPoolError, message: error.message, seconds: (performance.now() - started) / 1000 };
  } finally {
    search.terminate();
  }
})();
JS
echo '<!doctype html><script type="module" src="/src/dev.js"></script>' > dev.html
cat > dev-server.mjs <<JS
import { spawn } from 'node:child_process';
import { launchChromium } from '$repo/js/test/browser.js';

/** Starts the Vite dev server; resolves with its URL and the process. */
function startVite(env) {
  const vite = spawn(process.execPath, ['$tools/vite/bin/vite.js', '--port', '5273'], { env: { ...process.env, ...env }, stdio: ['ignore', 'pipe', 'inherit'] });
  return new Promise((resolve, reject) => {
    let out = '';
    vite.stdout.on('data', (data) => {
      out += data;
      const url = out.replace(/\x1b\[[0-9;]*m/g, '').match(/Local:\s+(http\S+)/);
      if (url) resolve({ vite, url: url[1] });
    });
    vite.on('exit', (code) => reject(new Error('vite exited with ' + code + ': ' + out)));
  });
}

async function run(env, build) {
  const { vite, url } = await startVite(env);
  const browser = await launchChromium();
  try {
    const page = await browser.newPage();
    await page.goto(new URL('dev.html?build=' + build, url).href);
    return await page.evaluate(() => globalThis.devResult);
  } finally {
    await browser.close();
    vite.kill();
  }
}

const fine = await run({}, 'auto');
if (fine.build !== 'threads' || fine.found !== 3 || fine.fallback !== null) throw new Error('dev server: ' + JSON.stringify(fine));
console.log('ok: under the Vite dev server the threaded build found 3 mugs in ' + fine.seconds.toFixed(1) + ' s');
const fallback = await run({ BREAK_POOL: '1' }, 'auto');
if (fallback.build !== 'plain' || fallback.found !== 3 || !/did not start/.test(fallback.fallback) || fallback.seconds > 15) {
  throw new Error('broken pool, auto: ' + JSON.stringify(fallback));
}
console.log('ok: with the pool broken, auto ran the plain build after ' + fallback.seconds.toFixed(1) + ' s: ' + fallback.fallback);
const refused = await run({ BREAK_POOL: '1' }, 'threads');
if (!refused.poolError || refused.seconds > 15) throw new Error('broken pool, threads: ' + JSON.stringify(refused));
console.log('ok: with the pool broken, threads failed with a ThreadPoolError after ' + refused.seconds.toFixed(1) + ' s');
JS
timeout 300 node dev-server.mjs

echo "-- esbuild, as the README says: its own server (plain), then served cross-origin isolated (threads)"
awk '/^### esbuild/ { found = 1; next }
     found && /^```sh/ { inside = 1; next }
     inside && /^```/ { exit }
     inside { print }' node_modules/fast-reject/README.md > esbuild-recipe.sh
test -s esbuild-recipe.sh || { echo "no esbuild recipe in the package README" >&2; exit 1; }
rm -rf dist
cp src/dev.js src/app.js
PATH="$tools/.bin:$PATH" bash -euo pipefail esbuild-recipe.sh
mkdir -p dist/demo
cp node_modules/fast-reject/demo/*.glb dist/demo/
echo '<!doctype html><script type="module" src="/app.js"></script>' > dist/dev.html
cat > esbuild-check.mjs <<JS
import * as esbuild from '$tools/esbuild/lib/main.js';
import { launchChromium } from '$repo/js/test/browser.js';
import { startServer } from '$repo/www/server.js';

async function visit(origin) {
  const browser = await launchChromium();
  try {
    const page = await browser.newPage();
    await page.goto(origin + '/dev.html');
    return await page.evaluate(() => globalThis.devResult);
  } finally {
    await browser.close();
  }
}
// esbuild's dev server, rebuilding the bundle on each request.
const context = await esbuild.context({ entryPoints: ['src/app.js'], bundle: true, format: 'esm', outdir: 'dist', logLevel: 'warning' });
const { port } = await context.serve({ servedir: 'dist', host: '127.0.0.1' });
const served = await visit('http://127.0.0.1:' + port);
await context.dispose();
if (served.build !== 'plain' || served.found !== 3 || served.fallback !== null) throw new Error('esbuild serve: ' + JSON.stringify(served));
console.log('ok: under esbuild serve the plain build found 3 mugs in ' + served.seconds.toFixed(1) + ' s');
const { server, origin } = await startServer({ port: 0, roots: { '/': '$scratch/app/dist' } });
try {
  const isolated = await visit(origin);
  if (isolated.build !== 'threads' || isolated.found !== 3) throw new Error('esbuild bundle, isolated: ' + JSON.stringify(isolated));
  console.log('ok: the esbuild bundle, served cross-origin isolated, ran the threaded build and found 3 mugs in ' + isolated.seconds.toFixed(1) + ' s');
} finally {
  server.close();
}
JS
timeout 300 node esbuild-check.mjs

echo "-- webpack: its defaults (the plain build, saying why), then the README's config under its dev server and built (threads)"
awk '/^\/\/ webpack.config.js/ { found = 1; next } found && /^```/ { exit } found' \
  node_modules/fast-reject/README.md > webpack-readme.config.js
test -s webpack-readme.config.js || { echo "no webpack config in the package README" >&2; exit 1; }
echo '<!doctype html><script type="module" src="/main.js"></script>' > public/webpack.html
cat > webpack-check.mjs <<JS
import webpack from '$tools/webpack/lib/index.js';
import WebpackDevServer from '$tools/webpack-dev-server/lib/Server.js';
import { cpSync } from 'node:fs';
import { startServer } from '$repo/www/server.js';
import { launchChromium } from '$repo/js/test/browser.js';
import readme from './webpack-readme.config.js';

/** The page's search under webpack's dev server, built with \`config\` around the test's entry. */
async function serve(config) {
  const compiler = webpack({
    ...config,
    mode: 'development',
    entry: './src/dev.js',
    output: { ...config.output, filename: 'main.js', path: '$scratch/app/webpack-dist' },
    infrastructureLogging: { level: 'error' },
    stats: 'errors-only',
  });
  const devServer = config.devServer ?? {};
  const statics = [...(devServer.static ?? []), { directory: 'public', publicPath: '/' }];
  const server = new WebpackDevServer({ ...devServer, host: '127.0.0.1', port: 5275, static: statics, hot: false, client: false }, compiler);
  await server.start();
  const browser = await launchChromium();
  try {
    const page = await browser.newPage();
    await page.goto('http://127.0.0.1:5275/webpack.html');
    return await page.evaluate(() => globalThis.devResult);
  } finally {
    await browser.close();
    await server.stop();
  }
}

// webpack's defaults on a cross-origin isolated page: the pool is tried, and fails.
const defaults = await serve({ devServer: { headers: readme.devServer.headers } });
if (defaults.build !== 'plain' || defaults.found !== 3 || !/failed to start|did not start/.test(defaults.fallback) || defaults.seconds > 15) {
  throw new Error('webpack defaults: ' + JSON.stringify(defaults));
}
console.log('ok: with webpack defaults, auto ran the plain build after ' + defaults.seconds.toFixed(1) + ' s: ' + defaults.fallback);
const threads = await serve(readme);
if (threads.build !== 'threads' || threads.found !== 3 || threads.fallback !== null) throw new Error('webpack, README config: ' + JSON.stringify(threads));
console.log('ok: under webpack serve with the README config the threaded build found 3 mugs in ' + threads.seconds.toFixed(1) + ' s');

// webpack build with the README's config, the package's files copied beside the bundle as it says.
const dist = '$scratch/app/webpack-build';
const { devServer, ...built } = readme;
await new Promise((resolve, reject) => {
  webpack({ ...built, mode: 'production', entry: './src/dev.js', output: { ...built.output, filename: 'main.js', path: dist } }).run(
    (error, stats) => (error || stats.hasErrors() ? reject(error ?? new Error(stats.toString('errors-only'))) : resolve()),
  );
});
for (const file of ['search-thread.js', 'index.js', 'errors.js', 'plain', 'threads']) {
  cpSync('node_modules/fast-reject/' + file, dist + '/' + file, { recursive: true });
}
cpSync('public', dist, { recursive: true });
const { server, origin } = await startServer({ port: 0, roots: { '/': dist } });
const browser = await launchChromium();
try {
  const page = await browser.newPage();
  await page.goto(origin + '/webpack.html');
  const bundled = await page.evaluate(() => globalThis.devResult);
  if (bundled.build !== 'threads' || bundled.found !== 3) throw new Error('webpack build: ' + JSON.stringify(bundled));
  console.log('ok: the webpack build, served cross-origin isolated, ran the threaded build and found 3 mugs in ' + bundled.seconds.toFixed(1) + ' s');
} finally {
  await browser.close();
  server.close();
}
JS
timeout 300 node webpack-check.mjs
