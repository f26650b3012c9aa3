// Light navigation's parts and budget (src/navigation.js), in Node: three.js
// geometry needs no WebGL.
import assert from 'node:assert/strict';
import { test } from 'node:test';

import * as THREE from 'three';

import { LightNavigation, splitParts } from '../src/navigation.js';

/** Two squares of different sizes in one indexed geometry, sharing no vertex. */
function twoSquares() {
  const square = (size, x) => [x, 0, 0, x + size, 0, 0, x + size, size, 0, x, size, 0];
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.Float32BufferAttribute([...square(1, 0), ...square(3, 10)], 3));
  geometry.setIndex([0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7]);
  geometry.computeVertexNormals();
  return new THREE.Mesh(geometry);
}

/** A model: the squares; an unwelded box (no index, corners repeated) moved to x = 100; a tetrahedron drawn twice by instancing. */
function model() {
  const root = new THREE.Group();
  root.add(twoSquares());
  const box = new THREE.Mesh(new THREE.BoxGeometry(2, 2, 2).toNonIndexed());
  box.position.set(100, 0, 0);
  root.add(box);
  const tetrahedra = new THREE.InstancedMesh(new THREE.TetrahedronGeometry(0.5), null, 2);
  tetrahedra.setMatrixAt(0, new THREE.Matrix4().makeTranslation(0, 50, 0));
  tetrahedra.setMatrixAt(1, new THREE.Matrix4().makeTranslation(0, -50, 0));
  root.add(tetrahedra);
  return root;
}

const centre = (box) => box.getCenter(new THREE.Vector3()).toArray();

test('splitParts: connected pieces, unwelded faces joined, instances apart, in world coordinates, larger first', () => {
  const { positions, triangles, parts } = splitParts(model());
  // The box (diagonal 3.5), the large square (4.2), the small one (1.4), two tetrahedra (0.8).
  assert.equal(parts.length, 5);
  assert.deepEqual(
    parts.map((p) => p.count),
    [2, 12, 2, 4, 4],
  );
  const sizes = parts.map((p) => p.box.min.distanceTo(p.box.max));
  assert.deepEqual(sizes, [...sizes].sort((a, b) => b - a));
  assert.deepEqual(centre(parts[0].box), [11.5, 1.5, 0]);
  assert.deepEqual(centre(parts[1].box), [100, 0, 0]);
  const tetrahedra = parts.slice(3).map((p) => Math.round(centre(p.box)[1]));
  assert.deepEqual(tetrahedra.sort((a, b) => a - b), [-50, 50]);
  // Each part's triangles are one run, and every corner lies in its box.
  const p = new THREE.Vector3();
  let next = 0;
  for (const part of parts) {
    assert.equal(part.first, next);
    next += part.count;
    for (let c = 3 * part.first; c < 3 * (part.first + part.count); c += 1) {
      assert.ok(part.box.containsPoint(p.fromArray(positions, 3 * triangles[c])), `corner ${c} outside its part`);
    }
  }
  assert.equal(next, triangles.length / 3);
});

test('LightNavigation: light only when a full frame is slow; matches first and always drawn; the budget follows the light frames', () => {
  const scene = new THREE.Scene();
  const root = model();
  scene.add(root);
  const navigation = new LightNavigation(root, new THREE.MeshBasicMaterial(), scene);
  navigation.limits = { heavyFrameMs: 60, lightFrameMs: 45, minTriangles: 1 };
  navigation.fullFrameTook(10);
  assert.equal(navigation.heavy, false);
  assert.equal(navigation.mesh, null, 'a light model makes no light mesh');

  navigation.fullFrameTook(200);
  assert.equal(navigation.heavy, true);
  assert.ok(scene.children.includes(navigation.mesh));
  assert.equal(navigation.mesh.visible, false, 'drawn only in light frames');
  // Half of 24 triangles x 45 / 200 ms: 2.
  assert.equal(navigation.budget, 2);
  assert.equal(navigation.prepareFrame(), 2, 'the largest part fits');

  // A match in the small square: its part first, drawn whatever the budget.
  navigation.setMatches(Float64Array.of(0.5, 0.5, 0), 0.1);
  navigation.budget = 1;
  assert.equal(navigation.prepareFrame(), 2);
  const index = navigation.mesh.geometry.index.array;
  const positions = navigation.mesh.geometry.attributes.position.array;
  for (let c = 0; c < 6; c += 1) assert.ok(positions[3 * index[c]] <= 1, `corner ${c} of the first part is not the small square's`);
  navigation.budget = 4;
  assert.equal(navigation.prepareFrame(), 4, 'then the largest part');
  navigation.budget = 15;
  assert.equal(navigation.prepareFrame(), 4, 'the box does not fit in 15: whole parts only');

  // Slow light frames lower the budget, fast ones raise it, within the model.
  navigation.budget = 10;
  navigation.lightFrameTook(90);
  assert.equal(navigation.budget, 6);
  navigation.budget = 20;
  navigation.lightFrameTook(5);
  assert.equal(navigation.budget, 23);
  for (let i = 0; i < 20; i += 1) navigation.lightFrameTook(1);
  assert.equal(navigation.budget, 24);
  assert.equal(navigation.prepareFrame(), 24);

  // A fast full frame (isolated, say) turns light frames off again.
  navigation.fullFrameTook(30);
  assert.equal(navigation.heavy, false);
  navigation.dispose();
  assert.ok(!scene.children.includes(navigation.mesh));
});
