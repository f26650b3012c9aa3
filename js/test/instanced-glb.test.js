// `fast-reject repeats --out` (the native command) writes instanced glTF
// that the Khronos glTF validator accepts with no error and no warning,
// placing copies by nodes and by EXT_mesh_gpu_instancing, on the shared
// real scenes. The validator cannot check that extension itself: it says
// so, and calls the accessors only the extension reads unused (infos).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { mkdtempSync, readFileSync, statSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import validator from 'gltf-validator';

const root = new URL('../../', import.meta.url).pathname;
const bin = process.env.FAST_REJECT_BIN ?? join(root, 'target/release/fast-reject');
const shared = process.env.FAST_REJECT_SHARED ?? join(root, '../shared');
const out = mkdtempSync(join(tmpdir(), 'instanced-'));

for (const scene of ['real-saw-roller', 'real-truck-wheels', 'real-t12-knee']) {
  for (const gpu of [false, true]) {
    test(`${scene}, ${gpu ? 'EXT_mesh_gpu_instancing' : 'a node per copy'}: valid glTF`, async () => {
      const input = join(shared, 'scenes', scene, 'scene.glb');
      const file = join(out, `${scene}${gpu ? '-gpu' : ''}.glb`);
      const args = ['repeats', input, '--json', '--out', file, ...(gpu ? ['--gpu-instancing'] : [])];
      const report = JSON.parse(execFileSync(bin, args, { encoding: 'utf8' }));
      assert.ok(report.families.length > 0, `${scene}: no repeated part`);
      assert.equal(report.written.bytes, statSync(file).size);
      const result = await validator.validateBytes(new Uint8Array(readFileSync(file)), { maxIssues: 0 });
      const { numErrors, numWarnings, messages } = result.issues;
      const shown = messages.filter((m) => m.severity < 2).slice(0, 8).map((m) => `${m.code} ${m.pointer ?? ''} ${m.message}`);
      assert.equal(numErrors, 0, shown.join('\n'));
      assert.equal(numWarnings, 0, shown.join('\n'));
      const infos = new Set(messages.filter((m) => m.severity === 2).map((m) => m.code));
      for (const code of infos) {
        assert.ok(gpu && ['UNSUPPORTED_EXTENSION', 'UNUSED_OBJECT'].includes(code), `${scene}: ${code}`);
      }
      console.log(`${scene}${gpu ? ' (gpu instancing)' : ''}: ${statSync(input).size} bytes in, ${report.written.bytes} out, `
        + `${report.written.meshes} meshes, ${report.written.nodes} placements`);
    });
  }
}

// Nodes a glTF matrix cannot hold as they are (scaled to nothing, flattened,
// sheared by a parent's non-uniform scale) and instances read from
// EXT_mesh_gpu_instancing: written valid, every matrix a turn and a scale,
// by the CLI and by the package alike (target/hostile: scripts/test-wasm.sh).
const hostile = join(root, 'target/hostile');

/** Fails for a node matrix with sheared or zero-length axes. */
function assertTurnsAndScales(glb, what) {
  const view = new DataView(glb.buffer, glb.byteOffset);
  const json = JSON.parse(new TextDecoder().decode(glb.subarray(20, 20 + view.getUint32(12, true))));
  for (const [n, node] of (json.nodes ?? []).entries()) {
    if (!node.matrix) continue;
    const axes = [0, 1, 2].map((c) => node.matrix.slice(4 * c, 4 * c + 3));
    const length = (a) => Math.hypot(...a);
    assert.ok(axes.every((a) => length(a) > 0), `${what}: node ${n} is singular`);
    for (const [i, j] of [[0, 1], [0, 2], [1, 2]]) {
      const cos = axes[i].reduce((s, x, k) => s + x * axes[j][k], 0) / (length(axes[i]) * length(axes[j]));
      assert.ok(Math.abs(cos) < 1e-5, `${what}: node ${n} is sheared`);
    }
  }
}

for (const name of ['boxes-hidden-flat-sheared.gltf', 'boxes-gpu-instanced.gltf']) {
  test(`${name}: the CLI and the package write valid nodes`, async () => {
    const { init, findRepeats } = await import('../../pkg/index.js');
    await init();
    const input = join(hostile, name);
    for (const gpu of [false, true]) {
      const file = join(out, `${name}${gpu ? '-gpu' : ''}.glb`);
      execFileSync(bin, ['repeats', input, '--out', file, ...(gpu ? ['--gpu-instancing'] : [])]);
      const written = new Uint8Array(readFileSync(file));
      const report = findRepeats(readFileSync(input), { instanced: gpu ? 'gpu-instancing' : 'nodes' });
      assert.deepEqual(report.glb, written, `${name}: the package writes what the CLI writes`);
      assert.equal(report.families[0].copies.length, 3);
      assertTurnsAndScales(written, name);
      const { issues } = await validator.validateBytes(written, { maxIssues: 0 });
      const shown = issues.messages.filter((m) => m.severity < 2).map((m) => `${m.code} ${m.pointer ?? ''} ${m.message}`);
      assert.deepEqual([issues.numErrors, issues.numWarnings], [0, 0], shown.join('\n'));
    }
  });
}
