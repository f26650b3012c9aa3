// `fast-reject/worker` in Node (worker_threads): the same instances as the
// API on the calling thread, progress per part and per layer, every way of cancelling
// rejecting with a CancelledError at once, and a worker that keeps its scene
// through cancels and broken files.
import assert from 'node:assert/strict';
import { readFile } from 'node:fs/promises';
import { test } from 'node:test';

import { CancelledError, Scene, Template, init } from '../../pkg/index.js';
import { CancelledError as WorkerCancelledError, SearchWorker } from '../../pkg/worker.js';

const shared = new URL('../../../shared/scenes/', import.meta.url);
const sceneBytes = await readFile(new URL('zoo-bunny/scene.glb', shared));
const templateBytes = await readFile(new URL('zoo-bunny/template.glb', shared));
const positions = (instances) => instances.map((i) => i.position);
const demo = new URL('../../assets/demo/', import.meta.url);
const demoScene = await readFile(new URL('scene.glb', demo));
const demoTemplate = await readFile(new URL('template.glb', demo));

/** The instances the calling thread's API finds, the reference. */
async function onThisThread() {
  await init();
  const scene = Scene.fromBytes(sceneBytes);
  const template = Template.fromBytes(templateBytes);
  try {
    return scene.match(template);
  } finally {
    template.free();
    scene.free();
  }
}

test('one class for cancels, whichever entry point threw it', () => {
  assert.equal(WorkerCancelledError, CancelledError);
});

test('a search in the worker finds what the calling thread finds, with progress per part and per layer', async () => {
  const reference = await onThisThread();
  const search = new SearchWorker();
  try {
    const info = await search.ready();
    assert.equal(info.build, 'plain');
    assert.equal(info.defaults.match.descriptor, 'volume+harmonics');
    const scene = await search.loadScene(sceneBytes);
    assert.equal(scene.parts, 11);
    assert.ok(scene.triangles > 0 && scene.resolution === 512);
    const layers = [];
    const counts = [];
    const report = await search.match({ bytes: templateBytes }, {}, {
      onLayer: (stats) => void layers.push(stats),
      onProgress: (progress) => void counts.push(progress),
    });
    // Parts done of those searched, to the end.
    assert.ok(counts.length >= 1 && counts.every((c) => c.step === 'parts' && c.done <= c.total && c.total <= 11));
    assert.equal(counts.at(-1).done, counts.at(-1).total);
    assert.ok(reference.instances.length > 0);
    assert.deepEqual(positions(report.instances), positions(reference.instances));
    assert.ok(report.instancePositions instanceof Float64Array);
    assert.ok(layers.length >= report.stages.length && layers.every((l) => l.candidates >= l.survivors));
    // The CPU backend, chosen, is the same search; a selection sphere too.
    const cpu = new SearchWorker({ backend: 'cpu' });
    await cpu.loadScene(sceneBytes);
    const again = await cpu.match({ bytes: new Uint8Array(templateBytes) });
    assert.deepEqual(positions(again.instances), positions(report.instances));
    const [x, y, z] = report.instances[0].position;
    const picked = await cpu.match({ center: [x, y, z], radius: report.template.radius });
    assert.ok(picked.instances.length >= report.instances.length);
    cpu.terminate();
  } finally {
    search.terminate();
  }
});

test('a plan judges the search before it runs: the parts it searches, the least time, none for curvature', async () => {
  await init();
  const scene = Scene.fromBytes(sceneBytes);
  const template = Template.fromBytes(templateBytes);
  const search = new SearchWorker({ backend: 'cpu' });
  try {
    const here = scene.plan(template);
    assert.ok(here.distinctParts >= 1 && here.distinctParts <= here.parts && here.parts <= scene.parts, JSON.stringify(here));
    assert.ok(here.skinVoxels > 0 && here.leastWork > 0 && here.leastSeconds > 0 && here.overLimit === false);
    assert.equal(scene.plan(template, { descriptor: 'curvature' }), null);
    assert.equal(scene.plan(template, { maxPartWork: here.leastWork / 2 }).overLimit, true);
    assert.throws(() => scene.plan({}), /needs a Template/);
    await assert.rejects(search.plan({ bytes: templateBytes }), /load a scene/);
    await search.loadScene(sceneBytes);
    assert.deepEqual(await search.plan({ bytes: templateBytes }), here);
    // The search goes through the parts the plan named.
    const totals = [];
    await search.match({ bytes: templateBytes }, {}, { onProgress: ({ step, total }) => void totals.push([step, total]) });
    assert.deepEqual(totals.at(-1), ['parts', here.distinctParts]);
  } finally {
    search.terminate();
    template.free();
    scene.free();
  }
});

test('every way of cancelling rejects with a CancelledError, and the scene stays loaded', async () => {
  const search = new SearchWorker({ backend: 'cpu' });
  try {
    await search.loadScene(sceneBytes);
    // false from the callback.
    await assert.rejects(search.match({ bytes: templateBytes }, {}, { onLayer: () => false }), CancelledError);
    await assert.rejects(search.match({ bytes: templateBytes }, {}, { onProgress: () => false }), CancelledError);
    // A throw: kept as the cause, not flattened into the message only.
    const mine = new RangeError('stop here');
    await assert.rejects(
      search.match({ bytes: templateBytes }, {}, {
        onLayer: () => {
          throw mine;
        },
      }),
      (error) => error instanceof CancelledError && error.cause === mine && /stop here/.test(error.message),
    );
    // An AbortSignal, aborted before and during the search.
    await assert.rejects(
      search.match({ bytes: templateBytes }, {}, { signal: AbortSignal.abort('before') }),
      (error) => error instanceof CancelledError && error.cause === 'before',
    );
    const controller = new AbortController();
    let layersAfterAbort = 0;
    const running = search.match({ bytes: templateBytes }, {}, {
      signal: controller.signal,
      onLayer: () => {
        if (controller.signal.aborted) layersAfterAbort += 1;
        else controller.abort('during');
      },
    });
    await assert.rejects(running, (error) => error instanceof CancelledError && error.cause === 'during');
    // cancel(): the running search and the one queued behind it.
    const first = search.match({ bytes: templateBytes });
    const second = search.match({ bytes: templateBytes });
    search.cancel();
    await assert.rejects(first, CancelledError);
    await assert.rejects(second, CancelledError);
    // The worker was replaced and has the scene again.
    const report = await search.match({ bytes: templateBytes });
    assert.equal(report.instances.length, 4);
    // A request cancelled by the same task that made it, on a worker that
    // is up and idle, is cancelled too (not posted to the next worker).
    const made = search.match({ bytes: templateBytes });
    search.cancel();
    await assert.rejects(made, CancelledError);
    assert.equal((await search.match({ bytes: templateBytes })).instances.length, 4);
    assert.equal(layersAfterAbort, 0, 'the cancelled worker still reported layers');
  } finally {
    search.terminate();
  }
});

test('bad input rejects with a readable Error and keeps the loaded scene', async () => {
  const search = new SearchWorker({ backend: 'cpu' });
  try {
    await assert.rejects(search.match({ bytes: templateBytes }), /load a scene/);
    await search.loadScene(sceneBytes);
    await assert.rejects(search.loadScene(new Uint8Array(64)), (error) => {
      return error instanceof Error && !(error instanceof CancelledError) && /unrecognized mesh data/.test(error.message);
    });
    await assert.rejects(search.match({ bytes: new Uint8Array(10) }), /unrecognized mesh data/);
    await assert.rejects(search.checkTemplate({ bytes: new Uint8Array(10) }), /unrecognized mesh data/);
    await assert.rejects(search.checkTemplate({ center: [0, Number.NaN, 0], radius: 1 }), /finite|NaN/);
    await search.checkTemplate({ bytes: templateBytes, format: 'glb' });
    await assert.rejects(search.match({ bytes: templateBytes }, { resolutoin: 64 }), /resolutoin/);
    await assert.rejects(search.match({ bytes: 'scene.glb' }), TypeError);
    await assert.rejects(search.match({ bytes: templateBytes }, {}, { onLayer: 3 }), TypeError);
    await assert.rejects(search.match({ bytes: templateBytes }, {}, { onProgress: 3 }), /onProgress must be a function/);
    assert.throws(() => new SearchWorker({ backend: 'webgpu' }), /backend/);
    // Still the zoo: the broken file replaced nothing.
    assert.equal((await search.match({ bytes: templateBytes })).instances.length, 4);
  } finally {
    search.terminate();
  }
  await assert.rejects(search.match({ bytes: templateBytes }), /terminated/);
  await assert.rejects(search.ready(), /terminated/);
});

test('the calling thread API: a cancel is a CancelledError with the thrown value as its cause', async () => {
  await init();
  const scene = Scene.fromBytes(sceneBytes, { resolution: 128 });
  const template = Template.fromBytes(templateBytes);
  try {
    assert.throws(() => scene.match(template, {}, () => false), CancelledError);
    const mine = new Error('from the callback');
    assert.throws(
      () =>
        scene.match(template, {}, () => {
          throw mine;
        }),
      (error) => error instanceof CancelledError && error.cause === mine && error.code === 'cancelled',
    );
    await assert.rejects(scene.matchGpu(template, {}, () => false), CancelledError);
    // Not a cancel: a bad option is a plain Error, naming the option as
    // JavaScript spells it.
    assert.throws(
      () => scene.match(template, { volumeThreshold: -1 }),
      (error) => !(error instanceof CancelledError) && /invalid option volumeThreshold: must be a positive number/.test(error.message),
    );
  } finally {
    template.free();
    scene.free();
  }
});

test('options that cannot be sent to the worker reject with a TypeError naming them; the worker still searches', async () => {
  const search = new SearchWorker({ backend: 'cpu' });
  const names = (pattern) => (error) => error instanceof TypeError && pattern.test(error.message);
  try {
    await search.loadScene(demoScene);
    // A function, a getter that throws, a Proxy whose trap throws: none may
    // reach postMessage (a DataCloneError there was left unhandled).
    const getter = {
      get groupRadius() {
        throw new Error('no radius here');
      },
    };
    const proxy = new Proxy(
      {},
      {
        ownKeys() {
          throw new Error('no keys here');
        },
      },
    );
    await assert.rejects(search.match({ bytes: demoTemplate }, { groupRadius: () => 1 }), names(/groupRadius.*a function/));
    await assert.rejects(search.match({ bytes: demoTemplate }, getter), names(/groupRadius: no radius here/));
    await assert.rejects(search.match({ bytes: demoTemplate }, proxy), names(/match options: no keys here/));
    await assert.rejects(search.match({ bytes: demoTemplate, format: () => 'glb' }), names(/format/));
    await assert.rejects(search.loadScene(demoScene, { resolution: () => 64 }), names(/resolution.*a function/));
    await assert.rejects(search.loadScene(demoScene, { [Symbol('x')]: 1, format: Symbol('glb') }), names(/format.*a symbol/));
    assert.throws(() => new SearchWorker({ threads: () => 2 }), names(/threads/));
    // The same worker, with the scene it had.
    assert.equal((await search.match({ bytes: demoTemplate })).instances.length, 3);
  } finally {
    search.terminate();
  }
});

test('the worker finds the repeated parts the calling thread finds, keeps its scene, and cancels', async () => {
  const search = new SearchWorker({ backend: 'cpu' });
  try {
    await search.loadScene(sceneBytes);
    const told = [];
    const report = await search.findRepeats(demoScene, {}, { onProgress: (p) => told.push(p) });
    // Every step told in order, the last at the end.
    assert.deepEqual(told.map((p) => p.done), Array.from({ length: told.length }, (_, i) => i + 1));
    assert.ok(told.every((p) => p.step === 'repeat steps' && p.total === told.length), JSON.stringify(told));
    // The demo's three mugs: one part, three copies.
    assert.deepEqual(
      report.families.map((f) => f.copies.length),
      [3],
    );
    await init();
    const { findRepeats } = await import('../../pkg/index.js');
    assert.deepEqual(report.families, findRepeats(demoScene).families);
    await assert.rejects(search.findRepeats(new Uint8Array(64)), /unrecognized mesh data/);
    await assert.rejects(search.findRepeats(demoScene, { resolution: 64 }), /the options are format and instanced/);
    // A progress callback that answers false cancels.
    await assert.rejects(search.findRepeats(demoScene, {}, { onProgress: () => false }), WorkerCancelledError);
    const aborted = new AbortController();
    aborted.abort();
    await assert.rejects(search.findRepeats(demoScene, {}, { signal: aborted.signal }), WorkerCancelledError);
    // The zoo is still loaded.
    assert.equal((await search.match({ bytes: templateBytes })).instances.length, 4);
  } finally {
    search.terminate();
  }
});

test('loading a scene in the worker tells its steps; a cancelled load keeps the scene before it', async () => {
  const search = new SearchWorker({ backend: 'cpu' });
  try {
    const seen = [];
    await search.loadScene(demoScene, {}, { onProgress: (progress) => seen.push(progress) });
    assert.ok(seen.length >= 2, JSON.stringify(seen));
    assert.ok(seen.every((p, i) => p.step === 'scene steps' && p.done === i + 1 && p.total === seen.length));
    const demoFound = (await search.match({ bytes: demoTemplate })).instances.length;
    // A false from onProgress, and an abort, while zoo-bunny loads.
    await assert.rejects(search.loadScene(sceneBytes, {}, { onProgress: () => false }), CancelledError);
    const controller = new AbortController();
    await assert.rejects(
      search.loadScene(sceneBytes, {}, { signal: controller.signal, onProgress: () => controller.abort('enough') }),
      (error) => error instanceof CancelledError && error.cause === 'enough',
    );
    // The demo is still the loaded scene.
    assert.equal((await search.match({ bytes: demoTemplate })).instances.length, demoFound);
    assert.ok(demoFound > 0);
  } finally {
    search.terminate();
  }
});
