// The inside of a `SearchWorker` (worker.js): a Web Worker in the browser, a
// worker_threads Worker in Node. It owns the module and the loaded scene and
// answers one request at a time, in the order they came: an async search
// holds the scene until it ends, so a load arriving meanwhile waits for it.
//
// In:  {type: 'init', id, build, threads, backend}
//      {type: 'load', id, bytes, options}
//      {type: 'check', id, template: {bytes, format} | {center, radius}}
//      {type: 'plan', id, template, options}
//      {type: 'match', id, template, options}
//      {type: 'repeats', id, bytes, options}
// Out: {type: 'ready', id, info} | {type: 'loaded', id, scene} | {type: 'checked', id}
//      {type: 'planned', id, plan}
//      {type: 'layer', id, stats} | {type: 'progress', id, progress} | {type: 'result', id, report}
//      (a 'result' answers 'repeats' too)
//      {type: 'error', id, error: {name, message}}
import { Scene, Template, findRepeats, init, optionDefaults } from './index.js';

const isNode = typeof process !== 'undefined' && !!process.versions?.node;

let scene = null;
/** 'cpu', 'auto' (WebGPU on a hardware adapter) or 'gpu' (any adapter). */
let backend = 'auto';
let queue = Promise.resolve();

async function handle(message, send) {
  const { id } = message;
  try {
    if (message.type === 'init') {
      backend = message.backend;
      const info = await init({ build: message.build, threads: message.threads });
      send({ type: 'ready', id, info: { ...info, defaults: optionDefaults() } });
    } else if (message.type === 'load') {
      const start = performance.now();
      // The old scene stays until the new one has parsed: a broken file
      // must not cost the caller the scene they had.
      const onProgress = (progress) => send({ type: 'progress', id, progress });
      const next = Scene.fromBytes(message.bytes, message.options, { onProgress });
      scene?.free();
      scene = next;
      const { triangles, parts, resolution, voxelSize } = next;
      send({ type: 'loaded', id, scene: { triangles, parts, resolution, voxelSize, ms: performance.now() - start } });
    } else if (message.type === 'check') {
      makeTemplate(message.template).free();
      send({ type: 'checked', id });
    } else if (message.type === 'plan') {
      if (!scene) throw new Error('fast-reject: load a scene (loadScene) before planning a search of it');
      const template = makeTemplate(message.template);
      try {
        send({ type: 'planned', id, plan: scene.plan(template, message.options) });
      } finally {
        template.free();
      }
    } else if (message.type === 'match') {
      send({ type: 'result', id, report: await search(message, send) });
    } else if (message.type === 'repeats') {
      const onProgress = (progress) => send({ type: 'progress', id, progress });
      send({ type: 'result', id, report: findRepeats(message.bytes, message.options, { onProgress }) });
    } else {
      throw new Error(`fast-reject: the search worker got an unknown request '${message.type}'`);
    }
  } catch (error) {
    send({ type: 'error', id, error: { name: error?.name ?? 'Error', message: String(error?.message ?? error) } });
  }
}

async function search({ id, template: spec, options }, send) {
  if (!scene) throw new Error('fast-reject: load a scene (loadScene) before searching it');
  const template = makeTemplate(spec);
  try {
    const observe = {
      onLayer: (stats) => send({ type: 'layer', id, stats }),
      onProgress: (progress) => send({ type: 'progress', id, progress }),
    };
    if (backend === 'cpu') return scene.match(template, options, observe);
    return await scene.matchGpu(template, options, observe, { allowSoftware: backend === 'gpu' });
  } finally {
    template.free();
  }
}

function makeTemplate(spec) {
  return spec?.center
    ? Template.fromSelection(spec.center, spec.radius)
    : Template.fromBytes(spec?.bytes, { format: spec?.format });
}

if (isNode) {
  // A computed specifier: bundlers for the browser must not resolve it. No
  // top-level await: browser bundlers' default targets lack it.
  const threadsModule = 'node:worker_threads';
  import(/* @vite-ignore */ /* webpackIgnore: true */ threadsModule).then(({ parentPort }) => {
    const send = (message) => parentPort.postMessage(message);
    parentPort.on('message', (message) => {
      queue = queue.then(() => handle(message, send));
    });
  });
} else {
  const send = (message) => postMessage(message);
  onmessage = ({ data }) => {
    queue = queue.then(() => handle(data, send));
  };
}
