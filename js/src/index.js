// The entry of the npm package `fast-reject`: loads the threaded build where
// the page can run it (cross-origin isolated, inside a Web Worker, with
// SharedArrayBuffer and more than one core) and the plain build everywhere
// else, Node included. Both builds export the same API; this file wraps it
// so that callers never see which one runs, get real `Error`s for bad
// arguments, and cannot use a handle after `free()`. Both builds can also
// run the cascade's layers on WebGPU (`Scene.matchGpu`).

import { CancelledError, ThreadPoolError, describe, plainOptions } from './errors.js';

export { CancelledError, ThreadPoolError };

/**
 * How long the threaded build's pool may take to start: its workers load
 * in well under a second, and one that failed to load (a dev server that
 * rewrote its script, a policy that blocks it) never answers, so waiting
 * longer would only hang the caller.
 */
const POOL_START_MS = 8_000;

let loading = null;
let loaded = null;

const isNode = typeof process !== 'undefined' && !!process.versions?.node;

/** Whether this context can run the threaded build. */
export function threadsSupported() {
  return whyNoThreads() === '';
}

/**
 * What of the threaded build's needs this context lacks, in a user's words
 * ('' when it has them all): the one list both `threadsSupported` and the
 * refusal read.
 */
function whyNoThreads() {
  if (isNode) {
    return 'it runs its threads in Web Workers, which Node lacks; in Node use the plain build, which runs on one thread';
  }
  const missing = [];
  if (globalThis.crossOriginIsolated !== true) {
    missing.push('the page is not cross-origin isolated (serve it with COOP: same-origin and COEP: require-corp)');
  }
  if (typeof SharedArrayBuffer !== 'function') missing.push('SharedArrayBuffer is unavailable');
  // The pool blocks its caller while it works: only a worker may block.
  if (!(typeof WorkerGlobalScope !== 'undefined' && globalThis instanceof WorkerGlobalScope)) {
    missing.push('it is not called inside a Web Worker (the pool blocks its caller; use fast-reject/worker)');
  }
  if ((globalThis.navigator?.hardwareConcurrency ?? 1) <= 1) missing.push('the browser reports one core');
  return missing.join('; ');
}

/**
 * Loads a build once; later calls return the same info. Options: `build`
 * ('auto' by default, 'plain' or 'threads') and `threads` (pool size,
 * default: the number of cores).
 */
export function init(options = {}) {
  if (!loading) {
    loading = instantiate(options).then(
      (module) => (loaded = module),
      (error) => {
        loading = null;
        throw error;
      },
    );
  }
  return loading.then(info);
}

async function instantiate({ build = 'auto', threads } = {}) {
  if (!['auto', 'plain', 'threads'].includes(build)) {
    throw new TypeError(`fast-reject: build must be 'auto', 'plain' or 'threads', got ${describe(build)}`);
  }
  const threaded = build === 'threads' || (build === 'auto' && threadsSupported());
  if (threaded && !threadsSupported()) {
    throw new Error(`fast-reject: the threaded build cannot run here: ${whyNoThreads()}`);
  }
  const glue = threaded ? await import('./threads/fast_reject.js') : await import('./plain/fast_reject.js');
  const wasmUrl = threaded
    ? new URL('./threads/fast_reject_bg.wasm', import.meta.url)
    : new URL('./plain/fast_reject_bg.wasm', import.meta.url);
  let source = wasmUrl;
  if (isNode) {
    // A computed specifier: bundlers for the browser must not try to
    // resolve Node's file system module.
    const fsModule = 'node:fs/promises';
    const { readFile } = await import(/* @vite-ignore */ /* webpackIgnore: true */ fsModule);
    source = await readFile(wasmUrl);
  }
  await glue.default({ module_or_path: source });
  if (threaded) {
    const count = threads ?? globalThis.navigator.hardwareConcurrency;
    const problem = await poolProblem(glue.initThreadPool(count), count);
    if (problem && build === 'threads') throw new ThreadPoolError(`fast-reject: ${problem}`);
    if (problem) return { ...(await instantiate({ build: 'plain' })), fallback: problem };
  }
  return { glue, build: threaded ? 'threads' : 'plain', broken: null, fallback: null };
}

/** Why the pool `starting` (of `count` workers) did not start within POOL_START_MS, or null once it has. */
async function poolProblem(starting, count) {
  let timer;
  const late = new Promise((settle) => {
    timer = setTimeout(
      () =>
        settle(
          `the threaded build's ${count} pool workers did not start within ${POOL_START_MS / 1000} s ` +
            '(a worker script that failed to load: a dev server that rewrites it, or a policy that blocks workers)',
        ),
      POOL_START_MS,
    );
  });
  const started = starting.then(
    () => null,
    (error) => `the threaded build's pool workers failed to start: ${describe(error)}`,
  );
  try {
    return await Promise.race([started, late]);
  } finally {
    clearTimeout(timer);
  }
}

function info() {
  return {
    build: loaded.build,
    threads: loaded.glue.threadCount(),
    memoryLimitBytes: loaded.glue.memoryLimitBytes(),
    fallback: loaded.fallback,
  };
}

function module() {
  if (!loaded) throw new Error('fast-reject: call `await init()` before using the API');
  if (loaded.broken) throw new Error(loaded.broken);
  return loaded.glue;
}

/**
 * Calls into wasm. A JS `Error` from the binding passes through untouched;
 * a trap (a bug: input checks should make it impossible) marks the module
 * unusable and says why, rather than failing later in confusing ways.
 */
function call(f) {
  const glue = module();
  try {
    return f(glue);
  } catch (error) {
    throw trapped(glue, error);
  }
}

/** `call` for an async binding: the same errors, once the promise settles. */
async function callAsync(f) {
  const glue = module();
  try {
    return await f(glue);
  } catch (error) {
    throw trapped(glue, error);
  }
}

/** The error to throw for `error` from the module: a trap marks it broken. */
function trapped(glue, error) {
  if (!(error instanceof WebAssembly.RuntimeError)) return error;
  let why = '';
  try {
    why = glue.lastPanicMessage() ?? '';
  } catch {
    // The message is a courtesy; the trap is what matters.
  }
  loaded.broken = `fast-reject: internal error (${why || error.message}); the module cannot be used any more: start a new worker or process`;
  return new Error(loaded.broken, { cause: error });
}

/**
 * Refuses a file that could not be copied into the module and parsed there:
 * the module says how much loading it may hold at once, from its length
 * and first bytes (a binary PLY's mesh can take twelve times the file). A
 * failed allocation would trap the module, so the check comes first.
 */
function checkFits(glue, data, what) {
  const free = glue.freeBytes();
  const peak = glue.peakLoadBytes(data.subarray(0, 512), data.byteLength);
  if (peak > free) {
    const mib = (n) => `${Math.round(n / 2 ** 20)} MiB`;
    throw new Error(
      `fast-reject: the ${what} (${mib(data.byteLength)}) does not fit in the module's free memory: loading it may take ${mib(peak)}, and ${mib(free)} are free: free other scenes and templates, or use a smaller file`,
    );
  }
}

/** A Uint8Array view of bytes given as Uint8Array, ArrayBuffer or any typed array. */
function asBytes(bytes, what) {
  if (bytes instanceof Uint8Array) return bytes;
  if (bytes instanceof ArrayBuffer || (typeof SharedArrayBuffer === 'function' && bytes instanceof SharedArrayBuffer)) {
    return new Uint8Array(bytes);
  }
  if (ArrayBuffer.isView(bytes)) return new Uint8Array(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  throw new TypeError(`fast-reject: the ${what} must be a Uint8Array or an ArrayBuffer, got ${typeof bytes}`);
}

/**
 * Handles that searches use now: handle -> `{ uses, freeLater }`, the wasm
 * object to free once the last of them ends if `free()` was called meanwhile.
 */
const inUse = new WeakMap();

function hold(handle) {
  const use = inUse.get(handle) ?? { uses: 0, freeLater: null };
  use.uses += 1;
  inUse.set(handle, use);
}

function release(handle) {
  const use = inUse.get(handle);
  use.uses -= 1;
  if (use.uses > 0) return;
  inUse.delete(handle);
  if (use.freeLater) freeInner(use.freeLater);
}

class Handle {
  #inner;
  constructor(inner) {
    this.#inner = inner;
  }
  /** The wasm object; throws once freed, or once the module trapped. */
  get inner() {
    if (!this.#inner) throw new Error(`fast-reject: this ${this.constructor.name} was freed`);
    // After a trap even a getter would call into the broken module.
    if (loaded?.broken) throw new Error(loaded.broken);
    return this.#inner;
  }
  /**
   * Releases the wasm memory now (it is not garbage-collected in time
   * otherwise); the handle cannot be used afterwards. While a search uses
   * it (a pending `matchGpu`, or `free()` from a progress callback) the
   * module holds it borrowed and would refuse, so the memory is released
   * when that search ends.
   */
  free() {
    const inner = this.#inner;
    if (!inner) return;
    this.#inner = null;
    const use = inUse.get(this);
    if (use) use.freeLater = inner;
    else freeInner(inner);
  }
}

/**
 * Frees a wasm object. Never throws once the module trapped: the call that
 * trapped left its handles marked as borrowed inside the module, so
 * wasm-bindgen's free() would throw "attempted to take ownership of Rust
 * value while it was borrowed", and in a `finally` that error would replace
 * the one that says what happened.
 */
function freeInner(inner) {
  if (loaded?.broken) {
    // Detaches the JS object without calling in, and unregisters its
    // finalizer, which would call into the broken module later; the
    // memory goes with the module.
    inner.__destroy_into_raw?.();
    return;
  }
  inner.free();
}

/**
 * Runs `search(scene, template)` on the wasm objects of two handles, holding
 * both until it ends (a Promise settles).
 */
function searching(sceneHandle, templateHandle, search) {
  const scene = sceneHandle.inner;
  const template = templateHandle.inner;
  hold(sceneHandle);
  hold(templateHandle);
  const done = () => {
    release(templateHandle);
    release(sceneHandle);
  };
  let result;
  try {
    result = search(scene, template);
  } catch (error) {
    done();
    throw error;
  }
  if (result instanceof Promise) return result.finally(done);
  done();
  return result;
}

/**
 * The parts a mesh file holds twice or more, found without a template and
 * without voxelizing: `{ families, timingsMs }`, each family with its
 * representative's `center` and `radius`, `triangles` and `pieces` per
 * copy, and `copies`, each `{ pose, residual, mirrored }` (pose: the
 * row-major 4x4 from the first copy to this one). Options: `format`, and
 * `instanced` ('nodes' or 'gpu-instancing') to get the scene as an
 * instanced GLB too (`glb`, with `written`), as `repeats --out` writes it.
 * `onProgress({ step: 'repeat steps', done, total })` as each step ends
 * (returning `false` or throwing cancels: a `CancelledError`).
 */
export function findRepeats(bytes, options, observe) {
  const data = asBytes(bytes, 'scene');
  const settings = plainOptions(options, 'repeats');
  const progress = new Progress(checkObserve(observe, 'findRepeats'));
  try {
    return call((glue) => {
      checkFits(glue, data, 'scene');
      return glue.findRepeats(data, settings, progress.onProgress);
    });
  } catch (error) {
    throw progress.explain(error);
  }
}

/** `findRepeats`'s and `Scene.fromBytes`'s third argument: `{ onProgress }` or nothing. */
function checkObserve(observe, what) {
  if (observe === undefined || observe === null) return {};
  if (typeof observe !== 'object' || (observe.onProgress !== undefined && typeof observe.onProgress !== 'function')) {
    throw new TypeError(`fast-reject: ${what}'s third argument must be { onProgress } with a function`);
  }
  return { onProgress: observe.onProgress };
}

/** A voxelized scene, searched any number of times. */
export class Scene extends Handle {
  /**
   * Options are checked in the module, against the core's schema.
   * `onProgress({ step: 'scene steps', done, total })` as each step ends,
   * reading the file first (returning `false` or throwing cancels: a
   * `CancelledError`).
   */
  static fromBytes(bytes, options, observe) {
    const data = asBytes(bytes, 'scene');
    const settings = plainOptions(options, 'scene');
    const progress = new Progress(checkObserve(observe, 'Scene.fromBytes'));
    try {
      return new Scene(
        call((glue) => {
          checkFits(glue, data, 'scene');
          return glue.Scene.fromBytes(data, settings, progress.onProgress);
        }),
      );
    } catch (error) {
      throw progress.explain(error);
    }
  }
  get resolution() {
    return this.inner.resolution;
  }
  get voxelSize() {
    return this.inner.voxelSize;
  }
  get parts() {
    return this.inner.parts;
  }
  get triangles() {
    return this.inner.triangles;
  }
  /**
   * Finds every occurrence of `template`. `observe` is `onLayer(stats)`,
   * run after each cascade layer, or `{ onLayer, onProgress }`, where
   * `onProgress({ step, done, total })` runs as the scene's parts (a large
   * part's windows, the curvature search's vertices) are worked through.
   * Returning `false` from either or throwing stops the search with a
   * `CancelledError` (a throw is its `cause`).
   */
  match(template, options = {}, observe) {
    const callbacks = checkSearch(template, observe, 'match');
    const settings = plainOptions(options, 'match');
    const progress = new Progress(callbacks);
    try {
      return camelCaseKeys(
        searching(this, template, (scene, inner) =>
          call(() => scene.match(inner, settings, progress.onLayer, progress.onProgress)),
        ),
      );
    } catch (error) {
      throw progress.explain(error);
    }
  }
  /**
   * What a search for `template` with `options` will take, judged without
   * running it: `{ parts, distinctParts, skinVoxels, leastWork, threads,
   * leastSeconds, overLimit }`, or null for the curvature descriptor. A
   * page asks with it before a search that would run for minutes.
   */
  plan(template, options = {}) {
    checkSearch(template, undefined, 'plan');
    const settings = plainOptions(options, 'match');
    return camelCaseKeys(searching(this, template, (scene, inner) => call(() => scene.plan(inner, settings))));
  }
  /**
   * Like `match`, with the volume and harmonics layers on WebGPU where
   * `navigator.gpu` gives a hardware adapter (a fallback, software one only
   * with `allowSoftware`): the same instances. Resolves to the report; its
   * `gpu` names the adapter, or is null when the CPU ran (no adapter, as in
   * Node). A device that fails midway hands its layers back to the CPU and
   * says why in `gpu.fallback`.
   */
  async matchGpu(template, options = {}, observe, { allowSoftware = false } = {}) {
    const callbacks = checkSearch(template, observe, 'matchGpu');
    const settings = plainOptions(options, 'match');
    const progress = new Progress(callbacks);
    try {
      return camelCaseKeys(
        await searching(this, template, (scene, inner) =>
          callAsync(() =>
            scene.matchGpu(inner, settings, progress.onLayer, progress.onProgress, Boolean(allowSoftware)),
          ),
        ),
      );
    } catch (error) {
      throw progress.explain(error);
    }
  }
}

/**
 * The module's report (the CLI's JSON shape, snake_case keys) with the
 * package's casing, that of its options: `timingsMs`, `grid.voxelSize`.
 * Keys are field names, never data; typed arrays pass as they are.
 */
function camelCaseKeys(value) {
  if (Array.isArray(value)) return value.map(camelCaseKeys);
  if (value === null || typeof value !== 'object' || ArrayBuffer.isView(value)) return value;
  return Object.fromEntries(
    Object.entries(value).map(([key, inner]) => [key.replace(/_([a-z])/g, (_, c) => c.toUpperCase()), camelCaseKeys(inner)]),
  );
}

/** The search's callbacks, `{ onLayer, onProgress }`, from `observe`: a function (onLayer) or that object. */
function checkSearch(template, observe, what) {
  if (!(template instanceof Template)) throw new TypeError(`fast-reject: ${what} needs a Template`);
  const callbacks =
    typeof observe === 'function'
      ? { onLayer: observe }
      : observe === undefined || observe === null
        ? {}
        : typeof observe === 'object'
          ? { onLayer: observe.onLayer, onProgress: observe.onProgress }
          : null;
  if (callbacks === null) {
    throw new TypeError(`fast-reject: ${what}'s third argument must be a function (onLayer) or { onLayer, onProgress }`);
  }
  for (const name of ['onLayer', 'onProgress']) {
    if (callbacks[name] !== undefined && typeof callbacks[name] !== 'function') {
      throw new TypeError(`fast-reject: ${name} must be a function`);
    }
  }
  return callbacks;
}

/**
 * The callbacks as the module calls them: they remember whether the
 * caller cancelled and what the caller's callback threw, so that the
 * module's error becomes a `CancelledError` that keeps the thrown value as
 * its `cause` instead of a flattened message.
 */
class Progress {
  #cancelled = false;
  #threw = false;
  #thrown;
  constructor({ onLayer, onProgress }) {
    this.onLayer = this.#guarded(onLayer);
    this.onProgress = this.#guarded(onProgress);
  }
  #guarded(callback) {
    return (
      callback &&
      ((value) => {
        try {
          if (callback(value) !== false) return true;
        } catch (error) {
          this.#threw = true;
          this.#thrown = error;
        }
        this.#cancelled = true;
        return false;
      })
    );
  }
  /** The error to throw for `error`, which the module threw. */
  explain(error) {
    if (!this.#cancelled) return error;
    if (!this.#threw) return new CancelledError();
    return new CancelledError(`fast-reject: the search was cancelled: the progress callback threw: ${describe(this.#thrown)}`, {
      cause: this.#thrown,
    });
  }
}

/** What to look for: a model, or a part of the scene inside a sphere. */
export class Template extends Handle {
  static fromBytes(bytes, options) {
    const data = asBytes(bytes, 'template');
    const settings = plainOptions(options, 'template');
    return new Template(
      call((glue) => {
        checkFits(glue, data, 'template');
        return glue.Template.fromBytes(data, settings);
      }),
    );
  }
  static fromSelection(center, radius) {
    if (!center || center.length !== 3) {
      throw new TypeError('fast-reject: a selection needs a centre [x, y, z] and a radius');
    }
    const [x, y, z] = Array.from(center, Number);
    return new Template(call((glue) => glue.Template.fromSelection(x, y, z, Number(radius))));
  }
  get isSelection() {
    return this.inner.isSelection;
  }
}

/** Every option's default, `{ scene, match }`: the core's schema, in JavaScript's names. */
export function optionDefaults() {
  return call((glue) => glue.optionDefaults());
}

/** Linear memory the module holds now; it never shrinks, so after a search this is the peak. */
export function memoryBytes() {
  return call((glue) => glue.memoryBytes());
}
