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
