// What a trap leaves behind, in a process of its own (a trap breaks the
// module for good). No hostile input traps the module (hostile.test.js), but
// keeping scenes alive still can: each scene keeps its voxel grids once
// searched, and the memory budget counts one scene at a time, so at 1024
// voxels the 13th or so scene's first search runs out of the module's 4 GiB
// and its allocation traps. After that every call says the module cannot be
// used any more, getters included, and `free()` (which callers run in
// `finally`) does not call into the broken module: there wasm-bindgen would
// throw "attempted to take ownership of Rust value while it was borrowed"
// for the handles the trapped search held, in place of the error that says
// what happened.
import assert from 'node:assert/strict';
import { test } from 'node:test';

import { Scene, Template, init, memoryBytes } from '../../pkg/index.js';

/** A binary STL of the unit tetrahedron (corner at the origin). */
function tetrahedron() {
  const [o, x, y, z] = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]];
  const triangles = [[o, y, x], [o, x, z], [o, z, y], [x, y, z]];
  const view = new DataView(new ArrayBuffer(84 + 50 * triangles.length));
  view.setUint32(80, triangles.length, true);
  triangles.forEach((corners, i) => {
    corners.flat().forEach((c, k) => view.setFloat32(84 + 50 * i + 12 + 4 * k, c, true));
  });
  return new Uint8Array(view.buffer);
}

test('after a trap, every call says so and free() never hides it', { timeout: 300_000 }, async (t) => {
  const info = await init();
  const sceneBytes = tetrahedron();
  // A radius of the scene's size, 1024 voxels: the search is refused (ball
  // tables) after voxelizing the scene, whose grids the scene then keeps.
  const template = Template.fromSelection([0, 0, 0], 1);
  const other = Template.fromSelection([0, 0, 0], 0.5);
  const held = [];
  let trapped;
  let last;
  try {
    // Each scene keeps about 270 MiB: 32 are past any module's memory.
    while (held.length < 32 && !trapped) {
      const scene = Scene.fromBytes(sceneBytes, { resolution: 1024 });
      held.push(scene);
      try {
        scene.match(template);
      } catch (error) {
        last = error;
        if (error.cause instanceof WebAssembly.RuntimeError) trapped = error;
      } finally {
        // The search's handles, freed where callers free them: were free()
        // to call in after the trap, this would throw over the real error.
        if (trapped) template.free();
      }
    }
  } catch (error) {
    assert.fail(`free() threw after the trap: ${error.message}`);
  }
  if (!trapped) {
    t.skip(`${held.length} scenes held no longer trap (${last?.message}): find another trap to test free() with`);
    for (const handle of [...held, template, other]) handle.free();
    return;
  }
  const limit = `${info.memoryLimitBytes / 2 ** 20} MiB`;
  t.diagnostic(`${held.length} scenes at resolution 1024 held, module limit ${limit}: ${trapped.message}`);
  assert.match(trapped.message, /internal error .*the module cannot be used any more/);
  // Every later call, getters included, says why.
  const broken = /the module cannot be used any more/;
  assert.throws(() => held[0].resolution, broken);
  assert.throws(() => held[0].match(other), broken);
  assert.throws(() => Scene.fromBytes(sceneBytes), broken);
  assert.throws(() => Template.fromSelection([0, 0, 0], 1), broken);
  assert.throws(() => memoryBytes(), broken);
  // The scene whose search trapped, and every other, frees quietly, twice too.
  for (const scene of held) {
    assert.doesNotThrow(() => scene.free());
    assert.doesNotThrow(() => scene.free());
  }
  assert.doesNotThrow(() => template.free());
  assert.doesNotThrow(() => other.free());
  assert.throws(() => held[0].resolution, /was freed/);
});
