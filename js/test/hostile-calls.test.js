// Hostile calls through the npm package (the plain build in Node), from the
// issue "Reliability and security, round two": options whose Proxy traps
// throw, free() while a search holds the handle, the `fast-reject` bin
// writing to a closed or full stdout. Each ends in a typed Error (or a
// result), leaves no handle borrowed and no memory held, and the same
// module then still finds the demo's three mugs.
import assert from 'node:assert/strict';
import { spawn } from 'node:child_process';
import { openSync, closeSync } from 'node:fs';
import { readFile } from 'node:fs/promises';
import { fileURLToPath } from 'node:url';
import { before, test } from 'node:test';

import { Scene, Template, init } from '../../pkg/index.js';
// The plain build's glue: the instance index.js loads.
import { freeBytes } from '../../pkg/plain/fast_reject.js';

const demo = new URL('../../assets/demo/', import.meta.url);
const [sceneBytes, templateBytes] = await Promise.all([
  readFile(new URL('scene.glb', demo)),
  readFile(new URL('template.glb', demo)),
]);
const bin = fileURLToPath(new URL('../../pkg/bin/fast-reject.js', import.meta.url));
const CONTROL = /[\u0000-\u001f\u007f-\u009f]/;

/** The demo search on a new scene and template, freed after: the module still works. */
function findsTheMugs() {
  const scene = Scene.fromBytes(sceneBytes);
  const template = Template.fromBytes(templateBytes);
  try {
    assert.equal(scene.match(template).instances.length, 3);
  } finally {
    template.free();
    scene.free();
  }
}

/**
 * The live heap is back where it was: what a case allocated was released.
 * The module counts live bytes exactly; a leaked demo scene holds 200 KB.
 */
function released(baseline, what) {
  const held = baseline - freeBytes();
  assert.ok(held < 4096, `${what}: ${held} bytes still live`);
}

before(async () => {
  await init();
  // Allocations made once (the panic hook, the GPU's lookup) are not a leak.
  findsTheMugs();
  const scene = Scene.fromBytes(sceneBytes);
  const template = Template.fromBytes(templateBytes);
  await scene.matchGpu(template);
  template.free();
  scene.free();
});

test('match options whose Proxy traps throw are a TypeError; the scene still searches and is freed', async () => {
  const baseline = freeBytes();
  const scene = Scene.fromBytes(sceneBytes);
  const template = Template.fromBytes(templateBytes);
  const throwing = (trap, target = { groupRadius: 1 }) =>
    new Proxy(target, {
      [trap]() {
        throw new Error(`the ${trap} trap says no\u001b[2J`);
      },
    });
  const { proxy: revoked, revoke } = Proxy.revocable({}, {});
  revoke();
  const cases = [
    ['ownKeys', throwing('ownKeys')],
    ['getOwnPropertyDescriptor', throwing('getOwnPropertyDescriptor')],
    ['get', throwing('get')],
    ['revoked', revoked],
  ];
  const refused = (error, what) => {
    assert.ok(error instanceof TypeError, `${what}: not a TypeError: ${error}`);
    assert.match(error.message, /cannot read (the match options|match option groupRadius)/, what);
    assert.doesNotMatch(error.message, CONTROL, `${what}: the message carries control characters`);
    return true;
  };
  for (const [what, options] of cases) {
    assert.throws(() => scene.match(template, options), (e) => refused(e, `match, ${what}`));
    await assert.rejects(scene.matchGpu(template, options), (e) => refused(e, `matchGpu, ${what}`));
  }
  // Options of the handles' constructors, read the same way.
  assert.throws(() => Scene.fromBytes(sceneBytes, throwing('ownKeys')), TypeError);
  assert.throws(() => Template.fromBytes(templateBytes, throwing('get', { format: 'glb' })), /cannot read template option format/);
  // A value the module cannot take is named.
  assert.throws(() => scene.match(template, { groupRadius: () => 1 }), /invalid match option groupRadius: .*a function/);
  // The same scene still searches, and is freed.
  assert.equal(scene.match(template).instances.length, 3);
  template.free();
  scene.free();
  released(baseline, 'the scene after the hostile options');
  findsTheMugs();
});

test('free() while matchGpu is pending: the search ends, its memory is released after it, the module still searches', async () => {
  const baseline = freeBytes();
  const scene = Scene.fromBytes(sceneBytes);
  const template = Template.fromBytes(templateBytes);
  const pending = scene.matchGpu(template);
  scene.free();
  template.free();
  assert.throws(() => scene.resolution, /this Scene was freed/);
  assert.throws(() => template.isSelection, /this Template was freed/);
  const report = await pending;
  assert.equal(report.instances.length, 3);
  released(baseline, 'the scene freed during matchGpu');

  // free() from the progress callback of a blocking match: the same.
  const again = Scene.fromBytes(sceneBytes);
  const mug = Template.fromBytes(templateBytes);
  let layers = 0;
  const result = again.match(mug, {}, () => {
    layers += 1;
    again.free();
    mug.free();
  });
  assert.ok(layers > 0);
  assert.equal(result.instances.length, 3);
  assert.throws(() => again.resolution, /this Scene was freed/);
  released(baseline, 'the scene freed from its progress callback');
  findsTheMugs();
});

/** Runs the bin with `stdout` (a stdio entry); its exit code and stderr. */
function runBin(args, stdout, { closeStdout = false } = {}) {
  return new Promise((resolve, reject) => {
    const child = spawn(process.execPath, [bin, ...args], { stdio: ['ignore', stdout, 'pipe'] });
    // No reader left: the child's first write gets EPIPE (`| head -c1` exits as early).
    if (closeStdout) child.stdout.destroy();
    let stderr = '';
    child.stderr.on('data', (chunk) => {
      stderr += chunk;
    });
    child.on('error', reject);
    child.on('close', (code) => resolve({ code, stderr }));
  });
}

test('the bin on a closed or full stdout: one line on stderr, exit code 1; usage errors stay 2', async () => {
  for (const [what, run] of [
    ['closed pipe', () => runBin(['demo', '--json'], 'pipe', { closeStdout: true })],
    ['closed pipe, the table', () => runBin(['demo'], 'pipe', { closeStdout: true })],
    [
      '/dev/full',
      async () => {
        const full = openSync('/dev/full', 'w');
        try {
          return await runBin(['demo', '--json'], full);
        } finally {
          closeSync(full);
        }
      },
    ],
  ]) {
    const { code, stderr } = await run();
    assert.equal(code, 1, `${what}: exit code ${code}, stderr: ${stderr}`);
    assert.match(stderr, /^error: cannot write the output: .*(EPIPE|ENOSPC)[^\n]*\n$/, `${what}: ${stderr}`);
  }
  // A usage error quoting the caller's text: exit code 2, the text escaped.
  const { code, stderr } = await runBin(['match', 'scene.glb', '--select', '1,2,3,\u001b[2J'], 'ignore');
  assert.equal(code, 2, stderr);
  assert.match(stderr, /^error: --select takes a number, got '\\u\{1b\}\[2J'\n/);
  assert.doesNotMatch(stderr, /\u001b/);
  findsTheMugs();
});
