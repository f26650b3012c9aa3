// Light navigation: a model too heavy to redraw at an interactive rate on
// this machine is drawn lighter while the camera moves, as CAD and BIM
// viewers do. Its parts (connected pieces of surface) are merged into one
// mesh ordered with the parts holding a match first, then the larger before
// the smaller, and a moving frame draws only as many of them as a triangle
// budget allows. The budget is measured, not guessed: from how long the full
// model took to draw, then from each light frame. The full model is drawn
// again once the camera stops.
import * as THREE from 'three';

/**
 * The defaults of `LightNavigation.limits`: a full frame slower than
 * `heavyFrameMs` makes the model heavy; a light frame should take about
 * `lightFrameMs` and draws at least `minTriangles` (the matches always).
 */
const LIMITS = { heavyFrameMs: 60, lightFrameMs: 40, minTriangles: 20_000 };

/**
 * Every mesh's triangles under `root`, in world coordinates, as one
 * geometry, and the parts they form: `{ positions, normals, triangles,
 * parts }` with `parts` as `{ first, count, box }` (triangle ranges of
 * `triangles`, larger parts first). Corners at the same position join a
 * part whether or not the file shares their vertex, so that unwelded faces
 * still make one part.
 */
export function splitParts(root) {
  root.updateMatrixWorld(true);
  const pieces = [];
  let vertexTotal = 0;
  let triangleTotal = 0;
  root.traverse((node) => {
    const geometry = node.isMesh ? node.geometry : null;
    if (!geometry?.attributes?.position || !geometry.attributes.normal) return;
    const copies = node.isInstancedMesh ? node.count : 1;
    const vertices = geometry.attributes.position.count;
    const triangles = Math.floor((geometry.index ? geometry.index.count : vertices) / 3);
    for (let copy = 0; copy < copies; copy += 1) {
      const matrix = node.matrixWorld.clone();
      if (node.isInstancedMesh) {
        const instance = new THREE.Matrix4();
        node.getMatrixAt(copy, instance);
        matrix.multiply(instance);
      }
      pieces.push({ geometry, matrix, firstVertex: vertexTotal, triangles });
      vertexTotal += vertices;
      triangleTotal += triangles;
    }
  });

  const positions = new Float32Array(3 * vertexTotal);
  const normals = new Float32Array(3 * vertexTotal);
  const corners = new Uint32Array(3 * triangleTotal);
  const p = new THREE.Vector3();
  const normalMatrix = new THREE.Matrix3();
  let at = 0;
  for (const { geometry, matrix, firstVertex, triangles } of pieces) {
    const position = geometry.attributes.position;
    const normal = geometry.attributes.normal;
    normalMatrix.getNormalMatrix(matrix);
    const m = matrix.elements;
    const n = normalMatrix.elements;
    for (let v = 0; v < position.count; v += 1) {
      const x = position.getX(v);
      const y = position.getY(v);
      const z = position.getZ(v);
      const at = 3 * (firstVertex + v);
      positions[at] = m[0] * x + m[4] * y + m[8] * z + m[12];
      positions[at + 1] = m[1] * x + m[5] * y + m[9] * z + m[13];
      positions[at + 2] = m[2] * x + m[6] * y + m[10] * z + m[14];
      p.set(normal.getX(v), normal.getY(v), normal.getZ(v));
      const nx = n[0] * p.x + n[3] * p.y + n[6] * p.z;
      const ny = n[1] * p.x + n[4] * p.y + n[7] * p.z;
      const nz = n[2] * p.x + n[5] * p.y + n[8] * p.z;
      const length = Math.hypot(nx, ny, nz) || 1;
      normals[at] = nx / length;
      normals[at + 1] = ny / length;
      normals[at + 2] = nz / length;
    }
    const index = geometry.index;
    const indices = index?.array;
    for (let c = 0; c < 3 * triangles; c += 1) corners[at + c] = firstVertex + (indices ? indices[c] : c);
    at += 3 * triangles;
  }

  // Parts: corners joined by triangles, vertices at one position joined too.
  const parent = weldedVertices(positions);
  const find = (v) => {
    while (parent[v] !== v) {
      parent[v] = parent[parent[v]];
      v = parent[v];
    }
    return v;
  };
  for (let t = 0; t < triangleTotal; t += 1) {
    const a = find(corners[3 * t]);
    for (let k = 1; k < 3; k += 1) {
      const b = find(corners[3 * t + k]);
      if (a !== b) parent[b] = a;
    }
  }
  const partOf = new Int32Array(vertexTotal).fill(-1);
  const triangleParts = new Uint32Array(triangleTotal);
  let partCount = 0;
  for (let t = 0; t < triangleTotal; t += 1) {
    const root = find(corners[3 * t]);
    if (partOf[root] < 0) partOf[root] = partCount++;
    triangleParts[t] = partOf[root];
  }
  // Each part's triangle count and box (min then max, three numbers each).
  const counts = new Uint32Array(partCount);
  const bounds = new Float64Array(6 * partCount);
  for (let i = 0; i < partCount; i += 1) bounds.set([Infinity, Infinity, Infinity, -Infinity, -Infinity, -Infinity], 6 * i);
  for (let t = 0; t < triangleTotal; t += 1) {
    const b = 6 * triangleParts[t];
    counts[triangleParts[t]] += 1;
    for (let k = 0; k < 3; k += 1) {
      const v = 3 * corners[3 * t + k];
      for (let axis = 0; axis < 3; axis += 1) {
        const x = positions[v + axis];
        if (x < bounds[b + axis]) bounds[b + axis] = x;
        if (x > bounds[b + 3 + axis]) bounds[b + 3 + axis] = x;
      }
    }
  }
  const boxes = Array.from({ length: partCount }, (_, i) => ({
    box: new THREE.Box3().setFromArray(bounds.subarray(6 * i, 6 * i + 6)),
    count: counts[i],
  }));

  // Larger parts first, each part's triangles together.
  const order = boxes.map((_, i) => i);
  const sizes = boxes.map(({ box }) => box.min.distanceTo(box.max));
  order.sort((a, b) => sizes[b] - sizes[a]);
  const first = new Uint32Array(boxes.length);
  let next = 0;
  for (const i of order) {
    first[i] = next;
    next += boxes[i].count;
  }
  const fill = first.slice();
  const triangles = new Uint32Array(3 * triangleTotal);
  for (let t = 0; t < triangleTotal; t += 1) {
    const slot = 3 * fill[triangleParts[t]]++;
    triangles[slot] = corners[3 * t];
    triangles[slot + 1] = corners[3 * t + 1];
    triangles[slot + 2] = corners[3 * t + 2];
  }
  const parts = order.map((i) => ({ first: first[i], count: boxes[i].count, box: boxes[i].box }));
  return { positions, normals, triangles, parts };
}

/** Each vertex's first vertex at the same position (a union-find forest to start from). */
function weldedVertices(positions) {
  const count = positions.length / 3;
  const bits = new Uint32Array(positions.buffer, positions.byteOffset, positions.length);
  let size = 1;
  while (size < 2 * count) size *= 2;
  const table = new Int32Array(size).fill(-1);
  const parent = new Int32Array(count);
  for (let v = 0; v < count; v += 1) {
    const x = bits[3 * v];
    const y = bits[3 * v + 1];
    const z = bits[3 * v + 2];
    let slot = (Math.imul(x, 73856093) ^ Math.imul(y, 19349663) ^ Math.imul(z, 83492791)) & (size - 1);
    parent[v] = v;
    for (;;) {
      const other = table[slot];
      if (other < 0) {
        table[slot] = v;
        break;
      }
      if (bits[3 * other] === x && bits[3 * other + 1] === y && bits[3 * other + 2] === z) {
        parent[v] = other;
        break;
      }
      slot = (slot + 1) & (size - 1);
    }
  }
  return parent;
}

/**
 * The light mesh of a model and the budget its moving frames draw: made
 * once a full frame of the model is measured slower than `limits.heavyFrameMs`.
 */
export class LightNavigation {
  /** The merged mesh (null until the model proves heavy). */
  mesh = null;
  /** Triangles a light frame draws. */
  budget = 0;
  /** Whether moving frames are drawn light. */
  heavy = false;
  /** Whether the light mesh changed since it was last sent to the GPU (see `View`'s warm-up). */
  unsent = false;
  /** When a model is heavy and what a light frame may take (LIMITS; tests lower them). */
  limits = { ...LIMITS };
  #root;
  #material;
  #scene;
  #split = null;
  /** Running totals of the triangles of the parts in drawing order. */
  #ends = new Uint32Array();
  /** The triangles of the parts holding a match, which come first. */
  #matchedTriangles = 0;
  #matches = { points: new Float64Array(), radius: 0 };

  /** `root`'s light mesh is drawn in `material` and added to `scene` (world coordinates) once made. */
  constructor(root, material, scene) {
    this.#root = root;
    this.#material = material;
    this.#scene = scene;
  }

  /** Takes the time a full frame of the model took (ms): past `limits.heavyFrameMs`, moving frames turn light. */
  fullFrameTook(ms) {
    const { heavyFrameMs, lightFrameMs, minTriangles } = this.limits;
    this.heavy = ms > heavyFrameMs;
    if (!this.heavy) return;
    if (!this.mesh) this.#build();
    const total = this.#ends.at(-1) ?? 0;
    // Half the triangles' share of the target time, to start low: a light
    // frame still pays for the fragments of the parts it keeps, and the
    // light frames raise the budget more slowly than they lower it.
    if (this.budget === 0) this.budget = Math.max(minTriangles, Math.floor((0.5 * total * lightFrameMs) / Math.max(ms, 1)));
  }

  /** Takes the time a light frame took (ms) and sizes the next one's budget. */
  lightFrameTook(ms) {
    const { lightFrameMs, minTriangles } = this.limits;
    const total = this.#ends.at(-1) ?? 0;
    // Down fast, up slowly: a frame's time is noisy, and an overshoot is a stutter.
    const scale = Math.min(Math.max(lightFrameMs / Math.max(ms, 1), 0.6), 1.15);
    this.budget = Math.min(Math.max(Math.floor(this.budget * scale), minTriangles), total);
  }

  /** Puts the parts holding a match (within `radius` of a point of `points`) first. */
  setMatches(points, radius) {
    this.#matches = { points, radius };
    if (this.mesh) this.#arrange();
  }

  /** Draws the parts holding a match and, in order, those that fit the budget; returns the triangles drawn. */
  prepareFrame() {
    const ends = this.#ends;
    let lo = 0;
    let hi = ends.length;
    while (lo < hi) {
      const mid = (lo + hi) >> 1;
      if (ends[mid] <= this.budget) lo = mid + 1;
      else hi = mid;
    }
    // At least the matches and the first part, however large.
    const triangles = Math.max(lo > 0 ? ends[lo - 1] : (ends[0] ?? 0), this.#matchedTriangles);
    this.mesh.geometry.setDrawRange(0, 3 * triangles);
    return triangles;
  }

  dispose() {
    this.mesh?.geometry.dispose();
    this.mesh?.removeFromParent();
  }

  #build() {
    this.#split = splitParts(this.#root);
    const { positions, normals, triangles } = this.#split;
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
    geometry.setAttribute('normal', new THREE.BufferAttribute(normals, 3));
    geometry.setIndex(new THREE.BufferAttribute(new Uint32Array(triangles.length), 1));
    this.mesh = new THREE.Mesh(geometry, this.#material);
    this.mesh.name = 'light navigation';
    this.mesh.visible = false;
    this.mesh.frustumCulled = false;
    this.mesh.raycast = () => {};
    this.#scene.add(this.mesh);
    this.#arrange();
  }

  /** Writes the index in drawing order: the parts holding a match, then the rest, each larger first. */
  #arrange() {
    const { parts, triangles } = this.#split;
    const { points, radius } = this.#matches;
    const p = new THREE.Vector3();
    const holds = (part) => {
      for (let i = 0; i < points.length / 3; i += 1) {
        if (part.box.distanceToPoint(p.set(points[3 * i], points[3 * i + 1], points[3 * i + 2])) <= radius) return true;
      }
      return false;
    };
    const matched = [];
    const rest = [];
    for (const part of parts) (points.length > 0 && holds(part) ? matched : rest).push(part);
    const order = [...matched, ...rest];
    const index = this.mesh.geometry.index;
    const ends = new Uint32Array(order.length);
    let at = 0;
    order.forEach((part, i) => {
      index.array.set(triangles.subarray(3 * part.first, 3 * (part.first + part.count)), 3 * at);
      at += part.count;
      ends[i] = at;
    });
    this.#ends = ends;
    this.#matchedTriangles = matched.length > 0 ? ends[matched.length - 1] : 0;
    index.needsUpdate = true;
    this.unsent = true;
  }
}
