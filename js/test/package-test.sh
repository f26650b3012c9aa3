#!/usr/bin/env bash
# `npm pack` of pkg/, installed into a scratch project as a user would:
# Node resolves its `exports` and runs it, tsc type-checks a program against
# its types (the JS entry included; a wrong call must be rejected), and Vite
# bundles it for the browser with both wasm builds as assets.
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

echo "-- tsc checks a program against the package's types"
cat > src/main.ts <<'TS'
import { init, Scene, Template, type MatchReport, type LayerStats, type MatchOptions, type SceneOptions } from 'fast-reject';

export async function find(sceneBytes: Uint8Array, templateBytes: ArrayBuffer): Promise<MatchReport> {
  const info = await init({ build: 'auto' });
  const build: 'plain' | 'threads' = info.build;
  const scene = Scene.fromBytes(sceneBytes, { format: 'glb', resolution: 256 });
  const template = build === 'plain' ? Template.fromBytes(templateBytes) : Template.fromSelection([0, 0, 0], 1);
  const report = scene.match(template, { descriptor: 'volume', verifyThreshold: 0.9 }, (s: LayerStats) => s.survivors > 0);
  const xyz: Float64Array = report.instancePositions;
  const first: number = report.instances[0]?.position[0] ?? xyz[0];
  // A curvature search has no grid, a voxel one no surface.
  const candidates: number = report.grid?.skin_voxels ?? report.surface?.vertices ?? 0;
  const agreement: number | null = report.instances[0]?.score ?? null;
  console.log(first, report.timings_ms.match, candidates, agreement);
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

echo "-- Vite bundles it for the browser"
cat > index.html <<'HTML'
<!doctype html><script type="module" src="/src/main.ts"></script>
HTML
node "$tools/vite/bin/vite.js" build --logLevel warn
wasm_assets=$(find dist -name '*.wasm' | wc -l)
if ((wasm_assets != 2)); then
  echo "expected both wasm builds among the bundle's assets, found $wasm_assets" >&2
  find dist >&2
  exit 1
fi
echo "ok: bundle with $(find dist -name '*.js' | wc -l) script(s) and $wasm_assets wasm assets"
