// The package's JS API in Node (the plain build): bad input of every kind is
// a catchable Error with a readable message, and the module keeps working
// for the next call; freed handles refuse further use.
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { readFile } from 'node:fs/promises';
import { fileURLToPath } from 'node:url';
import { test } from 'node:test';

import { CancelledError, Scene, Template, findRepeats, init, memoryBytes, optionDefaults } from '../../pkg/index.js';
// The test probe, from the plain build's glue: the instance index.js loads.
import { threadsUsed } from '../../pkg/plain/fast_reject.js';

const shared = new URL('../../../shared/scenes/', import.meta.url);
const sceneBytes = await readFile(new URL('zoo-bunny/scene.glb', shared));
const templateBytes = await readFile(new URL('zoo-bunny/template.glb', shared));

test('the API refuses calls before init', () => {
  assert.throws(() => Scene.fromBytes(sceneBytes), /call `await init\(\)`/);
});

test('Node gets the plain build on one thread', async () => {
  // Asked for the threaded build, Node is told why not, not about headers;
  // a failed init leaves the next one free to load the plain build.
  await assert.rejects(init({ build: 'threads' }), (error) => {
    assert.match(error.message, /Web Workers, which Node lacks; in Node use the plain build/);
    assert.doesNotMatch(error.message, /COOP|cross-origin/);
    return true;
  });
  const info = await init();
  assert.equal(info.build, 'plain');
  assert.equal(info.threads, 1);
  assert.equal(threadsUsed(16), 1);
  assert.ok(info.memoryLimitBytes >= 2 ** 30);
});

test('the option defaults are the core schema and are valid options', async () => {
  await init();
  const defaults = optionDefaults();
  assert.deepEqual(Object.keys(defaults.scene), ['resolution']);
  assert.equal(defaults.match.descriptor, 'volume+harmonics');
  assert.equal(defaults.match.groupRadius, 1);
  assert.equal(defaults.match.wholeCopies, false);
  assert.equal(defaults.match.keepNearTwins, false);
  assert.equal(defaults.match.maxPartWork, 3e10);
  const scene = Scene.fromBytes(sceneBytes, { ...defaults.scene, resolution: 128 });
  const template = Template.fromBytes(templateBytes);
  assert.ok(Array.isArray(scene.match(template, defaults.match).instances));
  template.free();
  scene.free();
});

test('bad input is an Error and the module stays usable', async () => {
  await init();
  const cases = [
    [() => Scene.fromBytes(new Uint8Array([1, 2, 3, 4, 5])), /unrecognized mesh data/],
    [() => Scene.fromBytes(new Uint8Array(0)), /empty/],
    [() => Scene.fromBytes(new ArrayBuffer(0)), /empty/],
    [() => Scene.fromBytes('scene.glb'), /Uint8Array/],
    [() => Template.fromBytes(sceneBytes.subarray(0, 100)), /malformed glTF/],
    [() => Template.fromSelection([0, Number.NaN, 0], 1), /finite centre/],
    [() => Template.fromSelection([0, 0, 0], -1), /positive radius/],
    [() => Template.fromSelection([0, 0], 1), /centre \[x, y, z\]/],
    [() => Scene.fromBytes(sceneBytes, { resolution: 16384 }), /lower the resolution/],
    [() => Scene.fromBytes(sceneBytes, { resolution: 1e12 }), /resolution/],
    [() => Scene.fromBytes(sceneBytes, { format: 'dwg' }), /format/],
    // Scene and template options are as strict as match options.
    [() => Scene.fromBytes(sceneBytes, { resolutoin: 64 }), /unknown scene option 'resolutoin'; the options are resolution, format/],
    [() => Scene.fromBytes(sceneBytes, { resolution: 'high' }), /invalid option resolution/],
    [() => Template.fromBytes(templateBytes, { resolution: 64 }), /unknown template option 'resolution'/],
  ];
  for (const [call, message] of cases) {
    assert.throws(call, (error) => error instanceof Error && message.test(error.message), String(call));
  }
  const scene = Scene.fromBytes(sceneBytes, { resolution: 192 });
  const template = Template.fromBytes(templateBytes);
  for (const [options, message] of [
    [{ descriptor: 'sift' }, /descriptor/],
    [{ layers: Number.NaN }, /layers/],
    [{ harmonicsThreshold: -1 }, /invalid option harmonicsThreshold: must be a positive number/],
    [{ resolution: 16384 }, /lower the resolution/],
    [{ typo: 1 }, /unknown match option 'typo'/],
  ]) {
    assert.throws(() => scene.match(template, options), message);
  }
  assert.throws(() => scene.match(template, {}, () => false), /cancelled/);
  assert.throws(() => scene.match(template, {}, () => { throw new Error('stop now'); }), /stop now/);
  assert.throws(() => scene.match(template, {}, { onProgress: () => false }), /cancelled/);
  assert.throws(() => scene.match(template, {}, { onProgress: 3 }), /onProgress must be a function/);
  assert.throws(() => scene.match(template, {}, 'layers'), TypeError);
  // Progress counts the parts searched, to the end; layers still come.
  const counts = [];
  let layerCalls = 0;
  const counted = scene.match(template, {}, {
    onLayer: () => { layerCalls += 1; },
    onProgress: (progress) => { counts.push(progress); },
  });
  assert.ok(layerCalls >= counted.stages.length);
  assert.ok(counts.length >= 1);
  for (const [k, c] of counts.entries()) {
    assert.equal(c.step, 'parts');
    assert.ok(c.done >= (counts[k - 1]?.done ?? 0) && c.done <= c.total && c.total <= scene.parts, JSON.stringify(c));
  }
  // The total is told before the first part is searched.
  assert.equal(counts[0].done, 0);
  assert.equal(counts.at(-1).done, counts.at(-1).total);
  // The same handles still give a full search afterwards.
  const layers = [];
  const report = scene.match(template, {}, (stats) => { layers.push(stats); });
  assert.equal(scene.resolution, 192);
  // One callback per layer of every part searched; the report sums them.
  assert.ok(layers.length >= report.stages.length);
  for (const stage of report.stages) {
    const same = layers.filter((l) => l.descriptor === stage.descriptor && l.layer === stage.layer);
    assert.equal(same.reduce((sum, l) => sum + l.survivors, 0), stage.survivors);
  }
  assert.ok(report.instancePositions instanceof Float64Array);
  assert.equal(report.instancePositions.length, 3 * report.instances.length);
  assert.equal(report.highlightRadius, report.template.radius);
  // Each instance's pose: a 4x4 matrix that maps c_T to its position.
  for (const instance of report.instances) {
    const [t, c] = [instance.pose, report.template.center];
    assert.deepEqual(t[3], [0, 0, 0, 1]);
    const mapped = [0, 1, 2].map((r) => t[r][0] * c[0] + t[r][1] * c[1] + t[r][2] * c[2] + t[r][3]);
    mapped.forEach((v, k) => assert.ok(Math.abs(v - instance.position[k]) < 1e-9));
  }
  // The bunnies stand apart: each is a whole copy, fitted within rounding.
  for (const instance of report.instances) {
    assert.equal(instance.whole, true);
    assert.ok(instance.residual >= 0 && instance.residual < 1e-4 * report.template.radius, String(instance.residual));
  }
  assert.equal(scene.match(template, { wholeCopies: true }).instances.length, report.instances.length);
  assert.throws(() => scene.match(template, { wholeCopies: true, descriptor: 'curvature' }), /whole ?copies/i);
  assert.ok(memoryBytes() > 0);
  template.free();
  scene.free();
  assert.throws(() => scene.resolution, /freed/);
  assert.throws(() => scene.match(template), /freed/);
  scene.free(); // twice is harmless
});

test('matchGpu without an adapter (Node) searches on the CPU and finds what match finds', async () => {
  await init();
  const scene = Scene.fromBytes(sceneBytes);
  const template = Template.fromBytes(templateBytes);
  const cpu = scene.match(template);
  const layers = [];
  const report = await scene.matchGpu(template, {}, (stats) => { layers.push(stats); }, { allowSoftware: true });
  assert.equal(report.gpu, null);
  assert.equal(cpu.gpu, null);
  assert.deepEqual(report.instances.map((i) => i.position), cpu.instances.map((i) => i.position));
  assert.ok(layers.length >= report.stages.length);
  await assert.rejects(scene.matchGpu(template, { resolutoin: 64 }), /resolutoin/);
  await assert.rejects(scene.matchGpu(template, {}, () => false), /cancelled/);
  await assert.rejects(scene.matchGpu(template, {}, { onProgress: () => false }), /cancelled/);
  await assert.rejects(scene.matchGpu(null), TypeError);
  // The module is still usable.
  assert.equal(scene.match(template).instances.length, cpu.instances.length);
  template.free();
  scene.free();
});

test('a curvature search tells the steps of welding the mesh, then its vertices; a stop while welding cancels it', async () => {
  await init();
  const dir = new URL('twisted-homer/', shared);
  const scene = Scene.fromBytes(await readFile(new URL('scene.glb', dir)));
  const template = Template.fromBytes(await readFile(new URL('template.glb', dir)));
  const options = { descriptor: 'curvature' };
  try {
    const stopped = [];
    const stopAtTwo = (progress) => {
      stopped.push([progress.step, progress.done, progress.total]);
      return stopped.length < 2;
    };
    assert.throws(() => scene.match(template, options, { onProgress: stopAtTwo }), /cancelled/);
    assert.deepEqual(stopped, [['surface steps', 1, 6], ['surface steps', 2, 6]]);
    // The next search welds again, to the end, before the vertices.
    const steps = [];
    const report = scene.match(template, options, { onProgress: (progress) => void steps.push(progress) });
    assert.ok(report.instances.length > 0);
    const welding = steps.filter((p) => p.step === 'surface steps').map((p) => p.done);
    assert.deepEqual(welding, [1, 2, 3, 4, 5, 6]);
    const lastWeld = steps.findLastIndex((p) => p.step === 'surface steps');
    assert.ok(steps.slice(lastWeld + 1).length > 0 && steps.slice(lastWeld + 1).every((p) => p.step === 'candidates'));
  } finally {
    template.free();
    scene.free();
  }
});

test('findRepeats lists the parts a scene repeats, as the CLI does, and refuses bad input', async () => {
  await init();
  // The truck's wheel pairs: one part of two pieces (the wheels), twice.
  const truck = await readFile(new URL('real-truck-wheels/scene.glb', shared));
  const report = findRepeats(truck);
  assert.equal(report.families.length, 1);
  const [family] = report.families;
  assert.deepEqual([family.copies.length, family.triangles, family.pieces], [2, 768, 2]);
  assert.equal(family.center.length, 3);
  for (const copy of family.copies) {
    assert.equal(copy.pose.length, 4);
    assert.equal(copy.mirrored, false);
    assert.ok(copy.residual < 1e-6 * family.radius);
  }
  // The second pair stands one axle along x from the first.
  const [, second] = family.copies;
  assert.ok(Math.abs(second.pose[0][3]) > family.radius);
  assert.ok(report.timingsMs.repeats >= 0 && report.timingsMs.load >= 0);
  // The saw: its 24 rollers are the largest family.
  const saw = findRepeats(await readFile(new URL('real-saw-roller/scene.glb', shared)), { format: 'glb' });
  assert.equal(saw.families[0].copies.length, 24);
  for (const [call, message] of [
    [() => findRepeats(new Uint8Array([1, 2, 3, 4, 5])), /unrecognized mesh data/],
    [() => findRepeats(truck, { resolution: 64 }), /unknown repeats option 'resolution'; the options are format and instanced/],
    [() => findRepeats(truck, { instanced: 'yes' }), /invalid option instanced: '"yes"' is not 'nodes' or 'gpu-instancing'/],
    [() => findRepeats(truck, { format: 'dwg' }), /format/],
    [() => findRepeats('scene.glb'), /Uint8Array/],
  ]) {
    assert.throws(call, (error) => error instanceof Error && message.test(error.message), String(call));
  }
  // Progress: every step in order, reading to writing; a callback that
  // answers false, or throws, cancels.
  const told = [];
  findRepeats(truck, { instanced: 'nodes' }, { onProgress: (p) => told.push(p) });
  assert.deepEqual(told.map((p) => `${p.step} ${p.done}/${p.total}`), Array.from({ length: 8 }, (_, i) => `repeat steps ${i + 1}/8`));
  assert.throws(() => findRepeats(truck, {}, { onProgress: () => false }), CancelledError);
  assert.throws(
    () => findRepeats(truck, {}, { onProgress: () => { throw new Error('stop'); } }),
    (error) => error instanceof CancelledError && /the progress callback threw: stop/.test(error.message),
  );
  assert.throws(() => findRepeats(truck, {}, { onProgress: 3 }), TypeError);
  // The module still works.
  assert.equal(findRepeats(truck).families.length, 1);
});

test('findRepeats writes the instanced glTF the CLI writes, byte for byte, and the validator accepts it', async () => {
  await init();
  const { execFileSync } = await import('node:child_process');
  const { mkdtempSync, readFileSync } = await import('node:fs');
  const { tmpdir } = await import('node:os');
  const validator = (await import('gltf-validator')).default;
  const bin = new URL('../../target/release/fast-reject', import.meta.url).pathname;
  const path = new URL('real-saw-roller/scene.glb', shared).pathname;
  const dir = mkdtempSync(`${tmpdir()}/instanced-`);
  for (const instanced of ['nodes', 'gpu-instancing']) {
    const report = findRepeats(await readFile(path), { instanced });
    assert.ok(report.glb instanceof Uint8Array);
    assert.equal(new TextDecoder().decode(report.glb.subarray(0, 4)), 'glTF');
    assert.equal(report.written.bytes, report.glb.length);
    assert.equal(report.written.keptCopies, 0);
    assert.ok(report.timingsMs.write >= 0);
    const out = `${dir}/${instanced}.glb`;
    execFileSync(bin, ['repeats', path, '--out', out, ...(instanced === 'nodes' ? [] : ['--gpu-instancing'])]);
    assert.deepEqual(report.glb, new Uint8Array(readFileSync(out)), instanced);
    const { issues } = await validator.validateBytes(report.glb, { maxIssues: 0 });
    assert.deepEqual([issues.numErrors, issues.numWarnings], [0, 0], instanced);
  }
  // Without the option, no file.
  assert.equal(findRepeats(await readFile(path)).glb, undefined);
});

test('loading a scene tells its steps, reading first, and a false from onProgress cancels it', async () => {
  await init();
  const seen = [];
  const scene = Scene.fromBytes(sceneBytes, {}, { onProgress: (progress) => seen.push(progress) });
  try {
    assert.ok(seen.length >= 2, JSON.stringify(seen));
    assert.ok(seen.every((p, i) => p.step === 'scene steps' && p.done === i + 1 && p.total === seen.length));
  } finally {
    scene.free();
  }
  // Stopped at each step in turn: a CancelledError, and the module still loads.
  for (let stopAt = 1; stopAt <= seen.length; stopAt += 1) {
    assert.throws(() => Scene.fromBytes(sceneBytes, {}, { onProgress: ({ done }) => done < stopAt }), CancelledError);
  }
  const thrown = new RangeError('stop loading');
  assert.throws(
    () =>
      Scene.fromBytes(sceneBytes, {}, {
        onProgress: () => {
          throw thrown;
        },
      }),
    (error) => error instanceof CancelledError && error.cause === thrown,
  );
  assert.throws(() => Scene.fromBytes(sceneBytes, {}, { onProgress: 7 }), TypeError);
  Scene.fromBytes(sceneBytes).free();
});

test("the package's report is camelCase like its options; the bin's --json keeps the native CLI's keys", async () => {
  await init();
  const scene = Scene.fromBytes(sceneBytes, { resolution: 128 });
  const template = Template.fromBytes(templateBytes);
  const report = scene.match(template);
  template.free();
  scene.free();
  const keys = (value) =>
    value === null || typeof value !== 'object' || ArrayBuffer.isView(value)
      ? []
      : Object.entries(value).flatMap(([key, inner]) => (Array.isArray(value) ? keys(inner) : [key, ...keys(inner)]));
  assert.deepEqual(keys(report).filter((key) => key.includes('_')), []);
  assert.ok(report.grid.voxelSize > 0 && report.grid.skinVoxels > 0 && report.timingsMs.total > 0);
  // The timings keep their order: the viewer lists them as they come.
  assert.deepEqual(Object.keys(report.timingsMs), ['load', 'voxelize', 'surface', 'template', 'match', 'group', 'total']);
  const bin = fileURLToPath(new URL('../../pkg/bin/fast-reject.js', import.meta.url));
  const printed = JSON.parse(execFileSync(process.execPath, [bin, 'demo', '--json'], { encoding: 'utf8' }));
  assert.ok(printed.timings_ms.total > 0 && printed.grid.voxel_size > 0 && printed.wasm.memory_bytes > 0);
  assert.equal(printed.timingsMs, undefined);
});
