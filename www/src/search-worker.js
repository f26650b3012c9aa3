// The matcher's Web Worker: it owns the package's Scene and runs every search,
// so the page never blocks. The package picks the threaded build itself when
// the page is cross-origin isolated, and runs the cascade's layers on WebGPU
// where the browser gives a hardware adapter (Scene.matchGpu; the CPU
// otherwise, with the same instances). A search cannot be interrupted from
// outside while it runs, so the page cancels by terminating this worker and
// starting a fresh one.
//
// Messages in:  {type: 'init'}
//               {type: 'load', id, name, bytes, format}
//               {type: 'match', id, template, options}
//                 template: {kind: 'model', name, bytes, format} | {kind: 'selection', center, radius}
// Messages out: {type: 'ready', id, info} | {type: 'loaded', id, triangles, ms}
//               {type: 'layer', id, stats} | {type: 'result', id, report, wallMs}
//               {type: 'error', id, message}
import { Scene, Template, init, optionDefaults } from '/pkg/index.js';

let scene = null;

function fail(id, error) {
  postMessage({ type: 'error', id, message: String(error?.message ?? error) });
}

function load({ id, bytes, format }) {
  const start = performance.now();
  // The old scene stays until the new one has parsed: a broken file must not
  // cost the user the scene they had.
  const next = Scene.fromBytes(bytes, { format });
  scene?.free();
  scene = next;
  postMessage({ type: 'loaded', id, triangles: next.triangles, ms: performance.now() - start });
}

async function search({ id, template: spec, options }) {
  if (!scene) throw new Error('load a scene first');
  const template =
    spec.kind === 'selection'
      ? Template.fromSelection(spec.center, spec.radius)
      : Template.fromBytes(spec.bytes, { format: spec.format });
  try {
    const start = performance.now();
    const report = await scene.matchGpu(template, options, (stats) => {
      postMessage({ type: 'layer', id, stats });
    });
    postMessage({ type: 'result', id, report, wallMs: performance.now() - start });
  } finally {
    template.free();
  }
}

onmessage = async ({ data }) => {
  try {
    if (data.type === 'init') {
      // The defaults come with the build info: the page's fields start from them.
      postMessage({ type: 'ready', id: data.id, info: { ...(await init()), defaults: optionDefaults() } });
    } else if (data.type === 'load') {
      load(data);
    } else if (data.type === 'match') {
      await search(data);
    } else {
      throw new Error(`unknown message ${data.type}`);
    }
  } catch (error) {
    fail(data.id, error);
  }
};
