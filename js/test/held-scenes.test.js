// Scenes a page keeps alive, in a process of their own: each keeps its
// mesh (a search voxelizes the parts it needs and frees them), so enough
// large ones would fill the module's memory, and a failed allocation traps
// the module for good. The binding
// counts the live heap: a scene or a search that would not fit in what is
// free is refused with a typed error, the module stays usable, and freeing
// scenes makes room again.
import assert from 'node:assert/strict';
import { readFile } from 'node:fs/promises';
import { test } from 'node:test';

import { Scene, Template, init, memoryBytes } from '../../pkg/index.js';

/** A binary STL of `copies` unit tetrahedra side by side (the first at the origin). */
function tetrahedron(copies = 1) {
  const triangles = [];
  for (let i = 0; i < copies; i += 1) {
    const [o, x, y, z] = [[2 * i, 0, 0], [2 * i + 1, 0, 0], [2 * i, 1, 0], [2 * i, 0, 1]];
    triangles.push([o, y, x], [o, x, z], [o, z, y], [x, y, z]);
  }
  const view = new DataView(new ArrayBuffer(84 + 50 * triangles.length));
  view.setUint32(80, triangles.length, true);
  triangles.forEach((corners, i) => {
    corners.flat().forEach((c, k) => view.setFloat32(84 + 50 * i + 12 + 4 * k, c, true));
  });
  return new Uint8Array(view.buffer);
}

test('scenes held past the module memory are refused, never a trap', { timeout: 300_000 }, async (t) => {
  const info = await init();
  // 2^19 tetrahedra: a scene keeps about 50 MiB of mesh.
  const sceneBytes = tetrahedron(1 << 19);
  const template = Template.fromSelection([0, 0, 0], 0.6);
  const held = [];
  let refusal;
  try {
    while (held.length < 96 && !refusal) {
      let scene;
      try {
        scene = Scene.fromBytes(sceneBytes);
        held.push(scene);
      } catch (error) {
        assert.ok(!(error.cause instanceof WebAssembly.RuntimeError), `a trap: ${error.message}`);
        // The scene's budget, or the loaders' cap on the mesh (half that
        // budget), whichever the filling memory reaches first.
        const budget = /not enough memory/.test(error.message) && /budget of/.test(error.message) && !/ball tables/.test(error.message);
        if (budget || /^the mesh would have .* above the limit of /.test(error.message)) {
          refusal = error;
        } else {
          assert.match(error.message, /not enough memory/);
        }
      }
    }
    t.diagnostic(
      `${held.length} scenes held, module at ${Math.round(memoryBytes() / 2 ** 20)} of ${info.memoryLimitBytes / 2 ** 20} MiB: ${refusal?.message}`,
    );
    assert.ok(refusal, 'holding 32 large scenes was never refused');
    // The refusal says what the live scenes hold, and to free them.
    assert.match(refusal.message, /MiB are held now, by the scenes and templates alive and this call's input: free\(\) those no longer needed/);
    assert.ok(memoryBytes() <= info.memoryLimitBytes);
    // A file larger than what is left could not even be copied in: a
    // failed allocation there would trap, so it is refused first.
    const huge = new Uint8Array(1536 * 2 ** 20);
    assert.throws(() => Scene.fromBytes(huge), /does not fit in the module's free memory/);
    assert.throws(() => Template.fromBytes(huge), /does not fit in the module's free memory/);
  } finally {
    for (const scene of held) scene.free();
  }
  // With the scenes freed, the same module searches the demo.
  const demo = new URL('../../assets/demo/', import.meta.url);
  const scene = Scene.fromBytes(await readFile(new URL('scene.glb', demo)));
  const mug = Template.fromBytes(await readFile(new URL('template.glb', demo)));
  try {
    assert.equal(scene.match(mug).instances.length, 3);
  } finally {
    scene.free();
    mug.free();
    template.free();
  }
});
