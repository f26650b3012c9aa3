// Headless Chromium, cross-origin isolated: the threaded build really runs
// on several threads and finds the same instances as the plain build.
import assert from 'node:assert/strict';
import { test } from 'node:test';

import { runInBrowser } from './browser.js';

test('threaded build in Chromium: two threads, same instances as plain', { timeout: 300_000 }, async () => {
  const [plain, threaded] = await runInBrowser([
    { build: 'plain', scene: 'zoo-bunny' },
    { build: 'threads', scene: 'zoo-bunny' },
  ]);
  assert.equal(threaded.crossOriginIsolated, true);
  assert.equal(plain.info.build, 'plain');
  assert.equal(plain.info.threads, 1);
  assert.equal(threaded.info.build, 'threads');
  assert.equal(threaded.info.threads, 2);
  // Work handed to the pool ran on both of its threads, not just one.
  assert.equal(threaded.threadsUsed, 2);
  assert.equal(plain.threadsUsed, 1);
  assert.ok(threaded.layers > 0 && threaded.layers === plain.layers);
  assert.ok(plain.instances.length > 0);
  assert.deepEqual(threaded.instances, plain.instances);
  console.log(
    `zoo-bunny in Chromium: plain ${plain.wallMs.toFixed(0)} ms, threaded (2) ${threaded.wallMs.toFixed(0)} ms`,
  );
});

test('threaded build near its memory cap: a large grid runs, a larger one is an Error', { timeout: 300_000 }, async () => {
  // The threaded build has 1 GiB of shared memory; the memory budget (half
  // of it, and no more than is free) counts everything a search builds,
  // with room to spare: zoo-bunny at 900 needs about 510 MiB by its
  // estimate (1100, which needs about 870, once ran in 536 MB natively).
  // templateVoxels 0 keeps the resolution asked for: by default a template
  // spanning over 96 voxels is searched on a coarser lattice.
  const kept = { templateVoxels: 0 };
  const [large] = await runInBrowser([{ build: 'threads', scene: 'zoo-bunny', resolution: 900, options: kept }]);
  assert.equal(large.info.memoryLimitBytes, 2 ** 30);
  assert.ok(large.instances.length > 0);
  assert.ok(large.memoryBytes < 2 ** 30);
  await assert.rejects(
    runInBrowser([{ build: 'threads', scene: 'zoo-bunny', resolution: 2048, options: kept }]),
    /lower the resolution/,
  );
});

test('WebGPU from the threaded build in a worker: the same layers and instances as the CPU', { timeout: 300_000 }, async () => {
  const [cpu, gpu] = await runInBrowser([
    { build: 'threads', scene: 'zoo-bunny' },
    { build: 'threads', scene: 'zoo-bunny', gpu: true },
  ]);
  assert.equal(cpu.gpu, null);
  assert.ok(gpu.gpu?.adapter, 'no WebGPU adapter in the worker');
  assert.equal(gpu.gpu.fallback, null);
  assert.deepEqual(gpu.stages, cpu.stages);
  assert.ok(cpu.instances.length > 0);
  assert.deepEqual(
    gpu.instances.map((i) => i.position),
    cpu.instances.map((i) => i.position),
  );
  console.log(
    `zoo-bunny in a worker: CPU (2 threads) ${cpu.wallMs.toFixed(0)} ms, WebGPU on ${gpu.gpu.adapter} ${gpu.wallMs.toFixed(0)} ms`,
  );
});

test('fast-reject/worker from the page: the threaded build, a cancel, then the same instances as plain', { timeout: 300_000 }, async () => {
  const [plain, worker] = await runInBrowser([
    { build: 'plain', scene: 'zoo-bunny' },
    { api: 'worker', scene: 'zoo-bunny' },
  ]);
  assert.equal(worker.crossOriginIsolated, true);
  assert.deepEqual(worker.info, { build: 'threads', threads: 2 });
  assert.equal(worker.cancelled, 'CancelledError');
  assert.equal(worker.layers, plain.layers);
  assert.ok(plain.instances.length > 0);
  assert.deepEqual(worker.instances, plain.instances);
  console.log(`zoo-bunny through SearchWorker (threads, 2): ${worker.wallMs.toFixed(0)} ms`);
});
