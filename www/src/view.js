// The 3D view: three.js rendering of the scene in one clay material whose
// shader colours the surface inside each match's ball (the matched region,
// not a marker), the template placed at each match's pose (a ghost), the
// selection sphere, picking, names, framing, flights, and the ways to see
// matches inside an assembly: x-ray, isolate, a cut-away in front of the
// point orbited, and screen markers that keep the smallest match in sight.
// It renders on demand, not every frame, and draws a heavy model lighter
// while the camera moves (navigation.js).
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { RoomEnvironment } from 'three/addons/environments/RoomEnvironment.js';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OBJLoader } from 'three/addons/loaders/OBJLoader.js';
import { PLYLoader } from 'three/addons/loaders/PLYLoader.js';
import { STLLoader } from 'three/addons/loaders/STLLoader.js';

import { LightNavigation } from './navigation.js';

/** Matches the shader can colour at once (a texture row of balls). */
export const MAX_HIGHLIGHTS = 2048;

const CLAY = 0xc8c2b8;
const MATCH = new THREE.Color(0xff8a1f);
const GHOST = 0x4fd1ff;
/** Opacity of the scene's surface outside the matches in x-ray mode. */
const XRAY_OPACITY = 0.18;
const FOCUS = new THREE.Color(0xffe14d);
/** Screen markers: this many pixels across, whatever the distance. */
const MARKER_PIXELS = 14;
/** The cut-away clears this much more than the match's ball in front of the point orbited. */
const CUT_MARGIN = 1.15;
/**
 * A posed match covers the template's box at its pose, grown by this share
 * of the template's radius: a copy's surface lies a little off the box
 * where the pose or the meshing is off by a little.
 */
const BOX_MARGIN = 0.03;
/** A heavy model is drawn full again once the camera has stood still this long (ms). */
const SETTLE_MS = 250;
/** The orbit's damping per 60th of a second: applied per elapsed time, so that slow frames do not drag the glide on. */
const DAMPING = 0.05;
/** A light frame is drawn at this share of the canvas's pixels in each direction (then scaled up). */
const LIGHT_RESOLUTION = 0.5;
/** Frames kept in the frame log. */
const FRAME_LOG = 1000;

/** Parses mesh bytes into a three.js object in file coordinates (as the package reads them). */
export async function parseModel({ name, format, bytes }) {
  const buffer = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
  let object;
  try {
    if (format === 'glb' || format === 'gltf') {
      const data = format === 'gltf' ? withoutMaterials(bytes) : buffer;
      object = (await new GLTFLoader().parseAsync(data, '')).scene;
    } else if (format === 'obj') {
      object = new OBJLoader().parse(new TextDecoder().decode(bytes));
    } else if (format === 'ply') {
      object = new THREE.Mesh(new PLYLoader().parse(buffer));
    } else if (format === 'stl') {
      object = new THREE.Mesh(new STLLoader().parse(buffer));
    } else {
      throw new Error(`unknown format ${format}`);
    }
  } catch (error) {
    throw new Error(`${name} could not be read as ${format.toUpperCase()}: ${error?.message ?? error}`);
  }
  let triangles = 0;
  object.traverse((node) => {
    if (node.isMesh && node.geometry?.attributes?.position) {
      const geometry = node.geometry;
      if (!geometry.attributes.normal) geometry.computeVertexNormals();
      triangles += (geometry.index ? geometry.index.count : geometry.attributes.position.count) / 3;
    }
  });
  if (triangles === 0) throw new Error(`${name} holds no triangles to show.`);
  object.name = name;
  return object;
}

/** A .gltf's JSON without materials and images: the view draws its own, and missing textures must not fail the load. */
function withoutMaterials(bytes) {
  const json = JSON.parse(new TextDecoder().decode(bytes));
  delete json.materials;
  delete json.textures;
  delete json.images;
  delete json.samplers;
  for (const mesh of json.meshes ?? []) for (const primitive of mesh.primitives ?? []) delete primitive.material;
  return JSON.stringify(json);
}

export class View {
  #renderer;
  #camera;
  #controls;
  #scene = new THREE.Scene();
  #root = null;
  #material;
  #highlights;
  #selection;
  #sceneRadius = 1;
  /** 'y' or 'z': the scene's vertical axis, which orbiting turns around. */
  #up = 'y';
  #frameRequested = false;
  #flight = null;
  #pointerDown = null;
  /** World boxes of the scene's meshes, with the names they are shown by. */
  #parts = [];
  /** The template's meshes in its own coordinates, for the ghosts. */
  #template = null;
  /** The template's box in its own coordinates, for posed matches. */
  #templateBox = null;
  /** That box grown by BOX_MARGIN: what the shader tests (its uniforms are these corners). */
  #matchBox = new THREE.Box3();
  #ghosts = new THREE.Group();
  /** Each match's centre and the radius of its ball, as last set. */
  #matchPoints = new Float64Array();
  #matchRadius = 0;
  /** Each match's scene-to-template matrix where it has a pose (and the view a template), else null. */
  #matchInverses = [];
  #isolate = false;
  #cutaway = false;
  /** Clips what lies in front of the point orbited (the cut-away). */
  #cut = new THREE.Plane();
  #markers;
  /** The heavy model's lighter drawing while the camera moves (null without a model). */
  #navigation = null;
  /** Limits set on the view, kept for the next model's light navigation. */
  #navigationLimits = {};
  /** When the camera last moved (performance.now()). */
  #movedAt = -Infinity;
  #settleTimer = 0;
  /** Whether a full frame is due once the camera has stood still SETTLE_MS. */
  #settlePending = false;
  /** When the last frame was drawn (performance.now()), for the damping. */
  #drawnAt = 0;
  /** The last timed frames: `{ at, light, ms, triangles }`. */
  #frameLog = [];

  /**
   * `onPick(point)` gets the surface point under a click (not a drag, not
   * the second click of a double-click); `onFocus(point)` the one under a
   * double-click.
   */
  constructor(container, { onPick = () => {}, onFocus = () => {}, onWheelRadius = () => {} } = {}) {
    // Multisampling costs a software rasterizer four to six times the frame.
    const renderer = new THREE.WebGLRenderer({ antialias: hardwareWebgl() });
    renderer.localClippingEnabled = true;
    renderer.toneMapping = THREE.NeutralToneMapping;
    container.append(renderer.domElement);
    this.#renderer = renderer;
    this.#setResolution(1);

    this.#scene.background = new THREE.Color(0x20242b);
    const pmrem = new THREE.PMREMGenerator(renderer);
    this.#scene.environment = pmrem.fromScene(new RoomEnvironment(), 0.04).texture;
    this.#scene.environmentIntensity = 0.7;
    pmrem.dispose();

    this.#camera = new THREE.PerspectiveCamera(40, 1, 0.01, 100);
    const headlight = new THREE.DirectionalLight(0xffffff, 1.6);
    headlight.position.set(0.4, 0.8, 1);
    this.#camera.add(headlight);
    this.#scene.add(this.#camera);

    this.#makeControls();

    this.#highlights = highlightTexture();
    this.#material = clayMaterial(this.#highlights, poseTexture(), this.#matchBox);
    this.#markers = screenMarkers();
    this.#scene.add(this.#markers);
    this.#selection = selectionSphere();
    this.#selection.visible = false;
    this.#scene.add(this.#selection);
    this.#scene.add(this.#ghosts);

    const canvas = renderer.domElement;
    canvas.addEventListener('pointerdown', (event) => {
      this.#pointerDown = event.button === 0 ? { x: event.clientX, y: event.clientY } : null;
    });
    canvas.addEventListener('click', (event) => {
      const down = this.#pointerDown;
      this.#pointerDown = null;
      if (!down || Math.hypot(event.clientX - down.x, event.clientY - down.y) > 4) return;
      if (event.detail > 1) return; // the second click of a double-click
      const point = this.pick(event.clientX, event.clientY);
      if (point) onPick(point);
    });
    canvas.addEventListener('dblclick', (event) => {
      const point = this.pick(event.clientX, event.clientY);
      if (point) onFocus(point);
    });
    // Shift + wheel sizes the selection sphere; the plain wheel zooms. This
    // listener runs before OrbitControls' and keeps the event from it.
    canvas.addEventListener(
      'wheel',
      (event) => {
        if (!event.shiftKey) return;
        event.preventDefault();
        event.stopImmediatePropagation();
        const delta = event.deltaY || event.deltaX;
        onWheelRadius(Math.exp(-Math.sign(delta) * 0.08));
      },
      { capture: true, passive: false },
    );
    new ResizeObserver(() => this.#resize(container)).observe(container);
    this.#resize(container);
  }

  /** OrbitControls read the camera's up vector once, when they are made. */
  #makeControls() {
    this.#controls?.dispose();
    this.#camera.up.set(0, this.#up === 'y' ? 1 : 0, this.#up === 'z' ? 1 : 0);
    this.#controls = new OrbitControls(this.#camera, this.#renderer.domElement);
    this.#controls.enableDamping = true;
    this.#controls.dampingFactor = DAMPING;
    this.#controls.addEventListener('change', () => this.requestRender());
  }

  /** The vertical axis ('y' or 'z'); the view is framed again. */
  get up() {
    return this.#up;
  }

  set up(axis) {
    if (axis !== 'y' && axis !== 'z') throw new Error(`up axis must be 'y' or 'z', got ${axis}`);
    this.#up = axis;
    this.#makeControls();
    this.frame();
  }

  /**
   * The vertical axis a scene most likely has: glTF says y, but a layout
   * spread over the xy plane (a scene of objects on a ground, as CAD and
   * scanning tools write them) is z up.
   */
  guessUp(object = this.#root) {
    if (!object) return 'y';
    const size = new THREE.Box3().setFromObject(object).getSize(new THREE.Vector3());
    return size.z < 0.45 * Math.min(size.x, size.y) ? 'z' : 'y';
  }

  /** The scene's bounding radius (for sensible slider ranges). */
  get sceneRadius() {
    return this.#sceneRadius;
  }

  /** Shows `object` instead of the current scene and frames it (with `up` as its vertical axis). */
  setModel(object, up = this.#up) {
    if (this.#root) {
      this.#scene.remove(this.#root);
      this.#root.traverse((node) => node.geometry?.dispose());
    }
    this.#navigation?.dispose();
    this.#navigation = new LightNavigation(object, this.#material, this.#scene);
    Object.assign(this.#navigation.limits, this.#navigationLimits);
    object.traverse((node) => {
      if (node.isMesh) node.material = this.#material;
      else if (node.isPoints || node.isLine) node.visible = false;
    });
    this.#root = object;
    this.#scene.add(object);
    // Picking and names need the nodes' world matrices now, not at the
    // first render.
    object.updateMatrixWorld(true);
    this.#parts = namedParts(object);
    this.setGhosts([]);
    this.setMatches(new Float64Array(), 0);
    this.setMatchPoses([]);
    this.setSelection(null);
    this.#up = up;
    this.#makeControls();
    this.frame();
  }

  /** Puts the whole scene in view: the box's corners fit both fields of view. */
  frame() {
    if (!this.#root) return;
    const box = new THREE.Box3().setFromObject(this.#root);
    const sphere = box.getBoundingSphere(new THREE.Sphere());
    const radius = Math.max(sphere.radius, 1e-6);
    this.#sceneRadius = radius;
    // Looking down at about 35 degrees, from the front and a little aside.
    const back = (this.#up === 'y' ? new THREE.Vector3(0.45, 0.75, 1) : new THREE.Vector3(0.45, -1, 0.75)).normalize();
    const right = this.#camera.up.clone().cross(back).normalize();
    const up = back.clone().cross(right);
    const tanV = Math.tan(THREE.MathUtils.degToRad(this.#camera.fov / 2));
    const tanH = tanV * this.#camera.aspect;
    let distance = 0;
    for (let i = 0; i < 8; i += 1) {
      const corner = new THREE.Vector3(
        i & 1 ? box.max.x : box.min.x,
        i & 2 ? box.max.y : box.min.y,
        i & 4 ? box.max.z : box.min.z,
      ).sub(sphere.center);
      const depth = corner.dot(back);
      distance = Math.max(distance, depth + Math.abs(corner.dot(right)) / tanH, depth + Math.abs(corner.dot(up)) / tanV);
    }
    distance *= 1.08;
    this.#camera.position.copy(sphere.center).addScaledVector(back, distance);
    this.#camera.near = radius * 0.002;
    this.#camera.far = distance + radius * 20;
    this.#camera.updateProjectionMatrix();
    this.#controls.target.copy(sphere.center);
    this.#controls.maxDistance = distance * 8;
    this.#controls.update();
    this.requestRender();
  }

  /** Colours the ball of `radius` around every `positions` triple; `focus` picks one out. */
  setMatches(positions, radius, focus = -1) {
    const count = Math.min(positions.length / 3, MAX_HIGHLIGHTS);
    const data = this.#highlights.image.data;
    for (let i = 0; i < count; i += 1) {
      data.set([positions[3 * i], positions[3 * i + 1], positions[3 * i + 2], radius], 4 * i);
    }
    this.#highlights.needsUpdate = true;
    const uniforms = this.#material.userData.uniforms;
    uniforms.matchCount.value = count;
    uniforms.focusIndex.value = focus;
    this.#matchPoints = Float64Array.from(positions.slice(0, 3 * count));
    this.#matchRadius = radius;
    this.#navigation?.setMatches(this.#matchPoints, radius);
    placeMarkers(this.#markers, this.#matchPoints, focus);
    this.requestRender();
    return count;
  }

  /**
   * Each match's pose (row-major 4x4, template to scene) or null, in the
   * order of the matches: with the template model set, a posed match
   * covers the template's box at its pose within its ball, so the colour,
   * isolate and picks take the copy's own surface and not a neighbour's
   * that enters the ball. Without a pose, the whole ball counts.
   */
  setMatchPoses(poses) {
    const texture = this.#material.userData.uniforms.matchPoses.value;
    const data = texture.image.data;
    data.fill(0);
    const inverse = new THREE.Matrix4();
    this.#matchInverses = [];
    const box = this.#templateBox;
    poses.slice(0, MAX_HIGHLIGHTS).forEach((rows, i) => {
      if (!rows || !box) {
        this.#matchInverses.push(null);
        return;
      }
      inverse.set(...rows.flat()).invert();
      const e = inverse.elements; // column-major
      for (let r = 0; r < 3; r += 1) data.set([e[r], e[4 + r], e[8 + r], e[12 + r]], 4 * (r * MAX_HIGHLIGHTS + i));
      data[4 * (3 * MAX_HIGHLIGHTS + i)] = 1;
      this.#matchInverses.push(inverse.clone());
    });
    texture.needsUpdate = true;
    if (box) this.#matchBox.copy(box).expandByScalar(BOX_MARGIN * box.getBoundingSphere(new THREE.Sphere()).radius);
    this.#applyIsolate();
    this.requestRender();
  }

  /** Whether scene point `p` (a Vector3) lies in a match as the shader colours it. */
  #inMatch(p) {
    const r2 = this.#matchRadius * this.#matchRadius;
    const local = new THREE.Vector3();
    const c = this.#matchPoints;
    for (let i = 0; i < c.length / 3; i += 1) {
      const dx = p.x - c[3 * i];
      const dy = p.y - c[3 * i + 1];
      const dz = p.z - c[3 * i + 2];
      if (dx * dx + dy * dy + dz * dz > r2) continue;
      const inverse = this.#matchInverses[i];
      if (!inverse) return true;
      if (this.#matchBox.containsPoint(local.copy(p).applyMatrix4(inverse))) return true;
    }
    return false;
  }

  /**
   * Isolate: only the matches are drawn. Meshes that hold no match are
   * hidden, and on the rest only the fragments in a match are kept, so
   * that a match inside an assembly drawn as one mesh shows too.
   */
  set isolate(on) {
    this.#isolate = on;
    this.#applyIsolate();
  }

  get isolate() {
    return this.#isolate;
  }

  #applyIsolate() {
    const on = this.#isolate && this.#matchPoints.length > 0;
    this.#material.userData.uniforms.isolateMatches.value = on ? 1 : 0;
    const p = new THREE.Vector3();
    const c = this.#matchPoints;
    for (const part of this.#parts) {
      let holds = !on;
      for (let i = 0; !holds && i < c.length / 3; i += 1) {
        p.set(c[3 * i], c[3 * i + 1], c[3 * i + 2]);
        holds = part.box.distanceToPoint(p) <= this.#matchRadius;
      }
      part.node.visible = holds;
    }
    this.requestRender();
  }

  /** Cut-away: what lies in front of the point orbited, nearer the camera than a match's ball, is not drawn. */
  set cutaway(on) {
    this.#cutaway = on;
    this.#material.clippingPlanes = on ? [this.#cut] : null;
    this.#material.needsUpdate = true;
    this.requestRender();
  }

  get cutaway() {
    return this.#cutaway;
  }

  /** The cut-away's plane, facing away from the camera, a ball's radius in front of the point orbited. */
  #placeCut() {
    const target = this.#controls.target;
    const normal = target.clone().sub(this.#camera.position).normalize();
    const clear = (this.#matchRadius > 0 ? this.#matchRadius : 0.05 * this.#sceneRadius) * CUT_MARGIN;
    this.#cut.setFromNormalAndCoplanarPoint(normal, target.clone().addScaledVector(normal, -clear));
  }

  /** Whether the screen markers are drawn. */
  set markersVisible(visible) {
    this.#markers.visible = visible;
    this.requestRender();
  }

  get markersVisible() {
    return this.#markers.visible;
  }

  /**
   * The colours drawn at scene points' pixels, as [r, g, b] (0-255) each,
   * from one frame without the ghosts, markers and selection sphere: tests
   * read whether a match can be seen from here. With `spread` > 0, each
   * point gives the colours of the square of pixels within `spread` of its
   * own, as a part a few pixels wide may leave its centre's pixel to what
   * lies beside it. With `light`, the frame is the light one drawn while
   * the camera moves (of a heavy model; else the full one).
   */
  coloursAt(points, { spread = 0, light = false } = {}) {
    const hidden = [this.#ghosts, this.#markers, this.#selection].filter((o) => o.visible);
    for (const o of hidden) o.visible = false;
    this.#setResolution(1);
    this.#camera.updateMatrixWorld();
    if (this.#cutaway) this.#placeCut();
    const render = () => this.#renderer.render(this.#scene, this.#camera);
    if (light && this.#navigation?.mesh) {
      this.#navigation.prepareFrame();
      this.#withLightMesh(render);
    } else {
      render();
    }
    for (const o of hidden) o.visible = true;
    const canvas = this.#renderer.domElement;
    const rect = canvas.getBoundingClientRect();
    const gl = this.#renderer.getContext();
    const colours = points.map((point) => {
      const { x, y } = this.project(point);
      const px = Math.round(((x - rect.left) / rect.width) * canvas.width);
      const py = canvas.height - 1 - Math.round(((y - rect.top) / rect.height) * canvas.height);
      const side = 2 * spread + 1;
      const out = new Uint8Array(4 * side * side);
      gl.readPixels(px - spread, py - spread, side, side, gl.RGBA, gl.UNSIGNED_BYTE, out);
      const square = Array.from({ length: side * side }, (_, i) => [out[4 * i], out[4 * i + 1], out[4 * i + 2]]);
      return spread > 0 ? square : square[0];
    });
    this.requestRender();
    return colours;
  }

  /** How many matches are coloured now. */
  get highlighted() {
    return this.#material.userData.uniforms.matchCount.value;
  }

  /** Shows the selection sphere, or hides it for null. */
  setSelection(selection) {
    this.#selection.visible = !!selection;
    if (selection) {
      this.#selection.position.fromArray(selection.center);
      this.#selection.scale.setScalar(selection.radius);
    }
    this.requestRender();
  }

  /** The surface point under a client position, as [x, y, z], or null. */
  pick(clientX, clientY) {
    if (!this.#root) return null;
    // The camera may have moved (framed, flown) since the last render.
    this.#camera.updateMatrixWorld();
    const rect = this.#renderer.domElement.getBoundingClientRect();
    const ndc = new THREE.Vector2(((clientX - rect.left) / rect.width) * 2 - 1, -((clientY - rect.top) / rect.height) * 2 + 1);
    const raycaster = new THREE.Raycaster();
    raycaster.setFromCamera(ndc, this.#camera);
    if (this.#cutaway) this.#placeCut();
    // What is drawn: visible, not cut away, and in a match when isolated.
    // Through x-ray the first match on the ray wins over the faint surface
    // in front of it.
    const hits = raycaster
      .intersectObject(this.#root, true)
      .filter((h) => h.object.visible && (!this.#cutaway || this.#cut.distanceToPoint(h.point) >= 0));
    const matchHit = this.#isolate || this.xray ? hits.find((h) => this.#inMatch(h.point)) : undefined;
    const hit = this.#isolate ? matchHit : (matchHit ?? hits[0]);
    return hit ? hit.point.toArray() : null;
  }

  /**
   * The name of the part a match at `point` lies in: the glTF node (or
   * mesh) with the smallest box around the point, or null when the file
   * names none.
   */
  nameAt(point) {
    const p = new THREE.Vector3().fromArray(point);
    let best = null;
    for (const part of this.#parts) {
      if (!part.name || !part.box.containsPoint(p)) continue;
      if (!best || part.volume < best.volume) best = part;
    }
    return best?.name ?? null;
  }

  /** The template model to place at the matches (its meshes in file coordinates), or null. */
  setTemplate(object) {
    this.setGhosts([]);
    if (!object) {
      this.#template = null;
      this.#templateBox = null;
      return;
    }
    object.updateMatrixWorld(true);
    const meshes = [];
    object.traverse((node) => {
      if (node.isMesh && node.geometry?.attributes?.position) meshes.push({ geometry: node.geometry, matrix: node.matrixWorld.clone() });
    });
    this.#template = meshes;
    this.#templateBox = new THREE.Box3().setFromObject(object);
  }

  /** Draws the template at every pose (row-major 4x4, template to scene), as a translucent ghost. */
  setGhosts(poses) {
    for (const ghost of this.#ghosts.children) ghost.dispose();
    this.#ghosts.clear();
    if (!this.#template || poses.length === 0) {
      this.requestRender();
      return;
    }
    const material = new THREE.MeshBasicMaterial({ color: GHOST, wireframe: true, transparent: true, opacity: 0.16, depthWrite: false });
    const pose = new THREE.Matrix4();
    const placed = new THREE.Matrix4();
    for (const { geometry, matrix } of this.#template) {
      const ghost = new THREE.InstancedMesh(geometry, material, poses.length);
      poses.forEach((rows, i) => {
        pose.set(...rows.flat());
        ghost.setMatrixAt(i, placed.multiplyMatrices(pose, matrix));
      });
      ghost.raycast = () => {};
      ghost.frustumCulled = false;
      this.#ghosts.add(ghost);
    }
    this.requestRender();
  }

  /** How many matches the template is drawn at (0 when it is not). */
  get ghostCount() {
    return this.#ghosts.visible ? (this.#ghosts.children[0]?.count ?? 0) : 0;
  }

  /** Whether the ghosts are drawn. */
  set ghostsVisible(visible) {
    this.#ghosts.visible = visible;
    this.requestRender();
  }

  /** X-ray: the scene's surface outside the matches turns faint, so that a match inside other material shows. */
  set xray(on) {
    this.#material.transparent = on;
    this.#material.depthWrite = !on;
    this.#material.userData.uniforms.surfaceOpacity.value = on ? XRAY_OPACITY : 1;
    this.#material.needsUpdate = true;
    this.requestRender();
  }

  get xray() {
    return this.#material.transparent;
  }

  /** The point the camera orbits, as [x, y, z]. */
  get target() {
    return this.#controls.target.toArray();
  }

  /** The camera's distance to the point it orbits. */
  distanceToTarget() {
    return this.#camera.position.distanceTo(this.#controls.target);
  }

  /** Client coordinates of a scene point (tests click through this). */
  project(point) {
    this.#camera.updateMatrixWorld();
    const rect = this.#renderer.domElement.getBoundingClientRect();
    const v = new THREE.Vector3().fromArray(point).project(this.#camera);
    return { x: rect.left + ((v.x + 1) / 2) * rect.width, y: rect.top + ((1 - v.y) / 2) * rect.height };
  }

  /**
   * Flies the camera to look at `point` from `distance`, keeping the
   * direction of view. Returns whether, from there, the drawn model hides
   * the point: a surface outside every match lies in front of it, farther
   * from it than the cut-away would leave.
   */
  flyTo(point, distance) {
    const target = new THREE.Vector3().fromArray(point);
    const direction = this.#camera.position.clone().sub(this.#controls.target).normalize();
    const toPosition = target.clone().addScaledVector(direction, distance);
    this.#flight = {
      start: performance.now(),
      fromTarget: this.#controls.target.clone(),
      fromPosition: this.#camera.position.clone(),
      toTarget: target,
      toPosition,
    };
    this.requestRender();
    return this.#hides(toPosition, target);
  }

  /** Whether what is drawn opaque between `from` and `point` hides it (see flyTo). */
  #hides(from, point) {
    // Isolated or in x-ray, nothing outside a match stands in the way.
    if (!this.#root || this.#isolate || this.xray) return false;
    const ray = point.clone().sub(from);
    const clear = (this.#matchRadius > 0 ? this.#matchRadius : 0.05 * this.#sceneRadius) * CUT_MARGIN;
    const far = ray.length() - clear;
    if (far <= 0) return false;
    const raycaster = new THREE.Raycaster(from, ray.normalize(), 0, far);
    return raycaster.intersectObject(this.#root, true).some((hit) => hit.object.visible && !this.#inMatch(hit.point));
  }

  /** Whether the camera is still flying to a point. */
  get flying() {
    return this.#flight !== null;
  }

  requestRender() {
    if (this.#frameRequested) return;
    this.#frameRequested = true;
    requestAnimationFrame(() => this.#render());
  }

  #render() {
    this.#frameRequested = false;
    let moving = false;
    if (this.#flight) {
      const f = this.#flight;
      const t = Math.min((performance.now() - f.start) / 700, 1);
      const s = t * t * (3 - 2 * t);
      this.#controls.target.lerpVectors(f.fromTarget, f.toTarget, s);
      this.#camera.position.lerpVectors(f.fromPosition, f.toPosition, s);
      if (t >= 1) this.#flight = null;
      moving = true;
    }
    // With damping, update() reports motion until the orbit settles.
    const now = performance.now();
    const sixtieths = Math.min(Math.max((now - this.#drawnAt) / (1000 / 60), 1), 30);
    this.#controls.dampingFactor = 1 - (1 - DAMPING) ** sixtieths;
    this.#drawnAt = now;
    if (this.#controls.update()) moving = true;
    if (this.#cutaway) this.#placeCut();
    if (moving) this.#movedAt = now;
    const navigation = this.#navigation;
    const settling = !!navigation?.heavy && now - this.#movedAt < SETTLE_MS;
    if (navigation?.heavy && (moving || settling)) this.#drawLight();
    else this.#drawFull();
    if (moving || this.#flight) {
      this.requestRender();
    } else if (settling) {
      clearTimeout(this.#settleTimer);
      this.#settlePending = true;
      this.#settleTimer = setTimeout(() => {
        this.#settlePending = false;
        this.requestRender();
      }, SETTLE_MS);
    }
  }

  /** Draws the whole model, timed: the time tells whether moving frames must be light. */
  #drawFull() {
    this.#setResolution(1);
    const timed = this.#timedRender();
    if (timed && this.#root) this.#navigation?.fullFrameTook(timed.ms);
    this.#logFrame(false, timed);
    if (this.#navigation?.heavy && this.#navigation.unsent) this.#sendLight();
  }

  /**
   * Sends the light mesh to the GPU while the camera stands still, so that
   * the first moving frame does not pay for it: a render that clears
   * nothing and draws nothing of it (drawing to the canvas, not to a
   * target, needs no other shader), right after the full frame.
   */
  #sendLight() {
    const renderer = this.#renderer;
    this.#navigation.mesh.geometry.setDrawRange(0, 0);
    renderer.autoClear = false;
    this.#withLightMesh(() => renderer.render(this.#scene, this.#camera), { alone: true });
    renderer.autoClear = true;
    this.#navigation.unsent = false;
  }

  /** Draws the parts of the light mesh its budget allows, timed to size the next budget. */
  #drawLight() {
    const navigation = this.#navigation;
    navigation.prepareFrame();
    this.#setResolution(LIGHT_RESOLUTION);
    const timed = this.#withLightMesh(() => this.#timedRender());
    if (timed) navigation.lightFrameTook(timed.ms);
    this.#logFrame(true, timed);
  }

  /**
   * What `draw` returns, drawn with the light mesh in the model's place
   * (`alone`: with nothing else shown either), the model shown again after.
   */
  #withLightMesh(draw, { alone = false } = {}) {
    const mesh = this.#navigation.mesh;
    const others = alone ? [this.#root, this.#ghosts, this.#markers, this.#selection] : [this.#root];
    const hidden = others.filter((o) => o?.visible);
    for (const o of hidden) o.visible = false;
    mesh.visible = true;
    try {
      return draw();
    } finally {
      mesh.visible = false;
      for (const o of hidden) o.visible = true;
    }
  }

  /** Draws at `share` of the device's pixel ratio (resizing the drawing buffer only when it changes). */
  #setResolution(share) {
    const ratio = Math.min(globalThis.devicePixelRatio ?? 1, 2) * share;
    if (this.#renderer.getPixelRatio() !== ratio) this.#renderer.setPixelRatio(ratio);
  }

  /**
   * Renders and waits for the pixels (a one-pixel read): `{ ms, triangles }`,
   * or null when the frame compiled a shader, which says nothing of the
   * frames to come.
   */
  #timedRender() {
    const renderer = this.#renderer;
    const programs = renderer.info.programs?.length ?? 0;
    const start = performance.now();
    renderer.render(this.#scene, this.#camera);
    const gl = renderer.getContext();
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
    const ms = performance.now() - start;
    if ((renderer.info.programs?.length ?? 0) !== programs) return null;
    return { ms, triangles: renderer.info.render.triangles };
  }

  #logFrame(light, timed) {
    if (!timed) return;
    this.#frameLog.push({ at: performance.now(), light, ms: timed.ms, triangles: timed.triangles });
    if (this.#frameLog.length > FRAME_LOG) this.#frameLog.shift();
  }

  /** The last timed frames, oldest first: `{ at, light, ms, triangles }` each (at: performance.now(); light: drawn while the camera moved). */
  get frameLog() {
    return this.#frameLog.slice();
  }

  /** Whether the view stands still and its last frame drew the whole model. */
  get settled() {
    return !this.#frameRequested && !this.#flight && !this.#settlePending;
  }

  /** When a model counts as heavy and what its light frames may take: `{ heavyFrameMs, lightFrameMs, minTriangles }`, any of them. */
  set navigationLimits(limits) {
    this.#navigationLimits = { ...this.#navigationLimits, ...limits };
    if (this.#navigation) Object.assign(this.#navigation.limits, limits);
  }

  /** Whether moving frames are drawn light, and the triangles they may draw. */
  get navigation() {
    const navigation = this.#navigation;
    return { heavy: !!navigation?.heavy, budget: navigation?.budget ?? 0 };
  }

  #resize(container) {
    const width = Math.max(container.clientWidth, 1);
    const height = Math.max(container.clientHeight, 1);
    this.#renderer.setSize(width, height, false);
    this.#renderer.domElement.style.width = '100%';
    this.#renderer.domElement.style.height = '100%';
    this.#camera.aspect = width / height;
    this.#camera.updateProjectionMatrix();
    this.requestRender();
  }
}

/**
 * Whether WebGL runs on a GPU here. A software rasterizer (SwiftShader,
 * llvmpipe, WARP) either refuses a context asked to fail on a major
 * performance caveat or names itself in the renderer string.
 */
function hardwareWebgl() {
  const strict = document.createElement('canvas').getContext('webgl2', { failIfMajorPerformanceCaveat: true });
  if (!strict) return false;
  const info = strict.getExtension('WEBGL_debug_renderer_info');
  const renderer = String(strict.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : strict.RENDERER));
  strict.getExtension('WEBGL_lose_context')?.loseContext();
  return !/swiftshader|llvmpipe|softpipe|lavapipe|software|basic render/i.test(renderer);
}

let previewRenderer = null;

/** Draws `object` once into `canvas` (a template's thumbnail), seen as the view frames a scene with `up` vertical. */
export function renderPreview(canvas, object, up = 'y') {
  previewRenderer ??= new THREE.WebGLRenderer({ canvas, antialias: true });
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0x181b21);
  const clay = new THREE.MeshStandardMaterial({ color: CLAY, roughness: 0.62, side: THREE.DoubleSide });
  const copy = object.clone();
  copy.traverse((node) => {
    if (node.isMesh) node.material = clay;
  });
  scene.add(copy, new THREE.HemisphereLight(0xffffff, 0x404040, 1.2));
  const box = new THREE.Box3().setFromObject(copy);
  const sphere = box.getBoundingSphere(new THREE.Sphere());
  const camera = new THREE.PerspectiveCamera(35, canvas.width / canvas.height, sphere.radius * 0.01, sphere.radius * 10);
  camera.up.set(0, up === 'y' ? 1 : 0, up === 'z' ? 1 : 0);
  const back = up === 'y' ? new THREE.Vector3(0.5, 0.6, 1) : new THREE.Vector3(0.5, -1, 0.6);
  camera.position.copy(sphere.center).addScaledVector(back.normalize(), sphere.radius * 3.2);
  camera.lookAt(sphere.center);
  const light = new THREE.DirectionalLight(0xffffff, 1.5);
  light.position.copy(camera.position);
  scene.add(light);
  previewRenderer.render(scene, camera);
  clay.dispose();
}

/**
 * Every mesh of a scene with its world box and the name a person would
 * know it by: its own node's, else the nearest named ancestor's (the file's
 * root, named after the file, does not count).
 */
function namedParts(root) {
  const parts = [];
  root.traverse((node) => {
    if (!node.isMesh || !node.geometry?.attributes?.position) return;
    let name = null;
    for (let at = node; at && at !== root && !name; at = at.parent) name = at.name || null;
    const box = new THREE.Box3().setFromObject(node);
    const size = box.getSize(new THREE.Vector3());
    parts.push({ node, name, box, volume: Math.max(size.x, 1e-12) * Math.max(size.y, 1e-12) * Math.max(size.z, 1e-12) });
  });
  return parts;
}

function highlightTexture() {
  const texture = new THREE.DataTexture(new Float32Array(4 * MAX_HIGHLIGHTS), MAX_HIGHLIGHTS, 1, THREE.RGBAFormat, THREE.FloatType);
  texture.magFilter = THREE.NearestFilter;
  texture.minFilter = THREE.NearestFilter;
  texture.needsUpdate = true;
  return texture;
}

/** Four rows of MAX_HIGHLIGHTS texels: a match's scene-to-template rows, then whether it is posed. */
function poseTexture() {
  const texture = new THREE.DataTexture(new Float32Array(4 * 4 * MAX_HIGHLIGHTS), MAX_HIGHLIGHTS, 4, THREE.RGBAFormat, THREE.FloatType);
  texture.magFilter = THREE.NearestFilter;
  texture.minFilter = THREE.NearestFilter;
  texture.needsUpdate = true;
  return texture;
}

/** A ring the same size on screen at any distance, drawn over everything, one per match. */
function screenMarkers() {
  const canvas = document.createElement('canvas');
  canvas.width = canvas.height = 64;
  const context = canvas.getContext('2d');
  context.strokeStyle = '#ffffff';
  context.lineWidth = 9;
  context.beginPath();
  context.arc(32, 32, 26, 0, Math.PI * 2);
  context.stroke();
  const material = new THREE.PointsMaterial({
    size: MARKER_PIXELS,
    sizeAttenuation: false,
    map: new THREE.CanvasTexture(canvas),
    vertexColors: true,
    transparent: true,
    alphaTest: 0.3,
    depthTest: false,
    depthWrite: false,
  });
  const markers = new THREE.Points(new THREE.BufferGeometry(), material);
  markers.renderOrder = 10;
  markers.frustumCulled = false;
  markers.raycast = () => {};
  return markers;
}

/** Puts a marker at every match centre, the focused one in the focus colour. */
function placeMarkers(markers, points, focus) {
  const colours = new Float32Array(points.length);
  for (let i = 0; i < points.length / 3; i += 1) (i === focus ? FOCUS : MATCH).toArray(colours, 3 * i);
  markers.geometry.dispose();
  markers.geometry = new THREE.BufferGeometry();
  markers.geometry.setAttribute('position', new THREE.Float32BufferAttribute(points, 3));
  markers.geometry.setAttribute('color', new THREE.Float32BufferAttribute(colours, 3));
}

/**
 * A matte material whose fragments inside any match take the match
 * colour: inside its ball and, for a posed match, inside the template's
 * box at its pose. Isolate drops every other fragment.
 */
function clayMaterial(highlights, poses, matchBox) {
  const material = new THREE.MeshStandardMaterial({ color: CLAY, roughness: 0.62, metalness: 0, side: THREE.DoubleSide });
  const uniforms = {
    matchBalls: { value: highlights },
    matchCount: { value: 0 },
    matchPoses: { value: poses },
    boxMin: { value: matchBox.min },
    boxMax: { value: matchBox.max },
    isolateMatches: { value: 0 },
    focusIndex: { value: -1 },
    surfaceOpacity: { value: 1 },
    matchColor: { value: MATCH },
    focusColor: { value: FOCUS },
  };
  material.userData.uniforms = uniforms;
  material.onBeforeCompile = (shader) => {
    Object.assign(shader.uniforms, uniforms);
    shader.vertexShader = shader.vertexShader
      .replace('#include <common>', '#include <common>\nvarying vec3 vMatchWorld;')
      .replace(
        '#include <project_vertex>',
        `#include <project_vertex>
        vec4 matchPoint = vec4(transformed, 1.0);
        #ifdef USE_INSTANCING
          matchPoint = instanceMatrix * matchPoint;
        #endif
        vMatchWorld = (modelMatrix * matchPoint).xyz;`,
      );
    shader.fragmentShader = shader.fragmentShader
      .replace(
        '#include <common>',
        `#include <common>
        varying vec3 vMatchWorld;
        uniform sampler2D matchBalls;
        uniform sampler2D matchPoses;
        uniform vec3 boxMin;
        uniform vec3 boxMax;
        uniform int isolateMatches;
        uniform int matchCount;
        uniform int focusIndex;
        uniform vec3 matchColor;
        uniform vec3 focusColor;
        uniform float surfaceOpacity;`,
      )
      .replace(
        '#include <color_fragment>',
        `#include <color_fragment>
        float matchWeight = 0.0;
        float focusWeight = 0.0;
        float rim = 0.0;
        for (int i = 0; i < ${MAX_HIGHLIGHTS}; i++) {
          if (i >= matchCount) break;
          vec4 ball = texelFetch(matchBalls, ivec2(i, 0), 0);
          float d = distance(vMatchWorld, ball.xyz);
          float inside = 1.0 - smoothstep(ball.w * 0.96, ball.w, d);
          if (inside > 0.0 && texelFetch(matchPoses, ivec2(i, 3), 0).x > 0.5) {
            vec4 world = vec4(vMatchWorld, 1.0);
            vec3 local = vec3(
              dot(texelFetch(matchPoses, ivec2(i, 0), 0), world),
              dot(texelFetch(matchPoses, ivec2(i, 1), 0), world),
              dot(texelFetch(matchPoses, ivec2(i, 2), 0), world));
            vec3 beyond = max(boxMin - local, local - boxMax);
            if (max(max(beyond.x, beyond.y), beyond.z) > 0.0) inside = 0.0;
          }
          rim = max(rim, inside * smoothstep(ball.w * 0.9, ball.w * 0.96, d));
          matchWeight = max(matchWeight, inside);
          if (i == focusIndex) focusWeight = inside;
        }
        vec3 tint = mix(matchColor, focusColor, focusWeight);
        diffuseColor.rgb = mix(diffuseColor.rgb, tint, 0.78 * matchWeight);
        diffuseColor.rgb *= 1.0 - 0.45 * rim;
        if (isolateMatches == 1 && matchWeight <= 0.0) discard;
        diffuseColor.a *= mix(surfaceOpacity, 1.0, matchWeight);`,
      );
  };
  return material;
}

/** A translucent ball with three great circles, so its size reads at any angle. */
function selectionSphere() {
  const group = new THREE.Group();
  const ball = new THREE.Mesh(
    new THREE.SphereGeometry(1, 48, 24),
    new THREE.MeshBasicMaterial({ color: 0x46a6ff, transparent: true, opacity: 0.22, depthWrite: false }),
  );
  ball.raycast = () => {};
  group.add(ball);
  const points = [];
  for (let i = 0; i <= 96; i += 1) {
    const a = (i / 96) * Math.PI * 2;
    points.push(new THREE.Vector3(Math.cos(a), Math.sin(a), 0));
  }
  const circle = new THREE.BufferGeometry().setFromPoints(points);
  const lineMaterial = new THREE.LineBasicMaterial({ color: 0x8cc8ff, transparent: true, opacity: 0.8 });
  for (const rotation of [
    [0, 0, 0],
    [Math.PI / 2, 0, 0],
    [0, Math.PI / 2, 0],
  ]) {
    const line = new THREE.Line(circle, lineMaterial);
    line.rotation.set(...rotation);
    line.raycast = () => {};
    group.add(line);
  }
  return group;
}
