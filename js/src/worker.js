// `fast-reject/worker`: the search in a worker of its own, so that the
// calling thread never blocks. A Web Worker in the browser (the threaded
// build where the page is cross-origin isolated, WebGPU where the browser
// has a hardware adapter), a worker_threads Worker in Node. The worker keeps
// the loaded scene between searches. A search cannot be interrupted from
// outside while it computes, so cancelling terminates the worker and starts
// a fresh one, which loads the same scene again before the next request.
import { CancelledError, ThreadPoolError, describe, plainOptions, shown } from './errors.js';

export { CancelledError, ThreadPoolError };

const isNode = typeof process !== 'undefined' && !!process.versions?.node;
const BACKENDS = ['auto', 'cpu', 'gpu'];
const BUILDS = ['auto', 'plain', 'threads'];

/** Bytes given as Uint8Array, ArrayBuffer or any typed array, as a Uint8Array. */
function asBytes(bytes, what) {
  if (bytes instanceof Uint8Array) return bytes;
  if (bytes instanceof ArrayBuffer) return new Uint8Array(bytes);
  if (ArrayBuffer.isView(bytes)) return new Uint8Array(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  throw new TypeError(`fast-reject: the ${what} must be a Uint8Array or an ArrayBuffer, got ${typeof bytes}`);
}

/** What the worker is sent for a template: a sphere, or the file's bytes and format. */
function templateSpec(template) {
  if (template?.center) return { center: Array.from(template.center, Number), radius: Number(template.radius) };
  const { format } = template ?? {};
  if (format !== undefined && format !== null && typeof format !== 'string') {
    throw new TypeError(`fast-reject: the template's format must be a string, got a ${typeof format}`);
  }
  return { bytes: asBytes(template?.bytes, 'template'), format };
}

/** The error a worker's `{name, message}` stands for. */
function revive({ name, message }) {
  if (name === 'CancelledError') return new CancelledError(message);
  if (name === 'ThreadPoolError') return new ThreadPoolError(message);
  const error = name === 'TypeError' ? new TypeError(message) : new Error(message);
  return error;
}

/**
 * One worker, started at once. Requests run one at a time in the order
 * they are made; `cancel()` stops the running one and everything queued
 * behind it.
 */
export class SearchWorker {
  #options;
  /** {post(message), terminate(), hold(busy)}, or null when none runs. */
  #thread = null;
  #ready = null;
  #pending = new Map();
  #nextId = 1;
  /** The last scene that loaded: its bytes and options, to load it again after a restart. */
  #scene = null;
  #closed = false;

  /**
   * `build` and `threads` as for `init()`; `backend`: 'auto' (default:
   * WebGPU on a hardware adapter, the CPU otherwise), 'cpu', or 'gpu' (any
   * adapter, a software one included; the CPU when there is none).
   */
  constructor({ build = 'auto', threads, backend = 'auto' } = {}) {
    if (!BACKENDS.includes(backend)) {
      throw new TypeError(`fast-reject: backend must be 'auto', 'cpu' or 'gpu', got ${describe(backend)}`);
    }
    // Checked here as well as in the worker: they are sent to it, and a
    // value that cannot be sent would fail outside any request.
    if (!BUILDS.includes(build)) {
      throw new TypeError(`fast-reject: build must be 'auto', 'plain' or 'threads', got ${describe(build)}`);
    }
    if (threads !== undefined && typeof threads !== 'number') {
      throw new TypeError(`fast-reject: threads must be a number, got a ${typeof threads}`);
    }
    this.#options = { build, threads, backend };
    this.#start();
  }

  #start() {
    // A worker that was replaced may still report (its exit, a last
    // message): only the current one is heard.
    let thread = null;
    const receive = (message) => thread === this.#thread && this.#receive(message);
    const fail = (why) => thread === this.#thread && this.#fail(why);
    thread = isNode ? startNodeThread(receive, fail) : startWebWorker(receive, fail);
    this.#thread = thread;
    const { build, threads, backend } = this.#options;
    let ready = this.#post({ type: 'init', build, threads, backend }).then(({ info }) => info);
    const scene = this.#scene;
    if (scene) {
      // It parsed before, so it parses again, before any caller's request.
      ready = ready.then(async (info) => {
        await this.#post({ type: 'load', ...scene });
        return info;
      });
    }
    this.#ready = ready;
    // Unhandled until a caller asks: the caller's request rejects instead.
    ready.catch(() => {});
  }

  /**
   * A caller's request: pending (so that a cancel rejects it) from the
   * moment it is made, and posted once the worker is up and has its scene.
   */
  #request(message, callbacks = {}) {
    if (this.#closed) return Promise.reject(new Error('fast-reject: this SearchWorker was terminated'));
    if (!this.#thread) this.#start();
    const thread = this.#thread;
    const { id, settled } = this.#register(callbacks);
    this.#ready.then(
      () => {
        if (this.#thread === thread && this.#pending.has(id)) this.#send(thread, { ...message, id });
      },
      (error) => this.#settle(id, (job) => job.reject(error)),
    );
    return settled;
  }

  /** Posts a message at once: the worker's own start (init, the scene again). */
  #post(message) {
    const { id, settled } = this.#register();
    this.#send(this.#thread, { ...message, id });
    return settled;
  }

  /**
   * Posts request `message` to `thread`. One that cannot be sent (a
   * DataCloneError, thrown at once or, in Node, once the worker is up)
   * rejects that request alone: nothing reached the worker, which stays
   * as it was.
   */
  #send(thread, message) {
    new Promise((resolve) => resolve(thread.post(message))).catch((error) =>
      this.#settle(message.id, (job) =>
        job.reject(
          new TypeError(`fast-reject: the request cannot be sent to the search worker: ${describe(error)}`, {
            cause: error,
          }),
        ),
      ),
    );
  }

  #register({ onLayer, onProgress } = {}) {
    const id = this.#nextId++;
    const settled = new Promise((resolve, reject) => {
      this.#pending.set(id, { resolve, reject, onLayer, onProgress });
    });
    this.#thread.hold(true);
    return { id, settled };
  }

  #receive(message) {
    const job = this.#pending.get(message.id);
    if (!job) return;
    if (message.type === 'layer' || message.type === 'progress') {
      let goOn;
      try {
        goOn =
          message.type === 'layer'
            ? job.onLayer?.(message.stats) !== false
            : job.onProgress?.(message.progress) !== false;
      } catch (error) {
        this.#cancel(
          new CancelledError(
            `fast-reject: the search was cancelled: the progress callback threw: ${describe(error)}`,
            { cause: error },
          ),
        );
        return;
      }
      if (!goOn) this.#cancel(new CancelledError());
      return;
    }
    this.#settle(message.id, (done) => {
      if (message.type === 'error') done.reject(revive(message.error));
      else done.resolve(message);
    });
  }

  /** Ends request `id` with `finish(job)`, if it is still pending. */
  #settle(id, finish) {
    const job = this.#pending.get(id);
    if (!job) return;
    this.#pending.delete(id);
    if (this.#pending.size === 0) this.#thread?.hold(false);
    finish(job);
  }

  /** The worker died (it could not start, or ran out of memory): every request fails, the next one starts a new worker. */
  #fail(why) {
    this.#thread?.terminate();
    this.#thread = null;
    const error = new Error(`fast-reject: the search worker failed: ${shown(why)}`);
    const pending = [...this.#pending.values()];
    this.#pending.clear();
    for (const job of pending) job.reject(error);
  }

  #cancel(error) {
    this.#thread?.terminate();
    this.#thread = null;
    const pending = [...this.#pending.values()];
    this.#pending.clear();
    for (const job of pending) job.reject(error);
    if (!this.#closed) this.#start();
  }

  /** Build information once the worker is up: `build`, `threads`, `memoryLimitBytes`, and `defaults` (every option's default). */
  ready() {
    if (this.#closed) return Promise.reject(new Error('fast-reject: this SearchWorker was terminated'));
    if (!this.#thread) this.#start();
    return this.#ready;
  }

  /**
   * Parses a scene in the worker and keeps it for the next searches. On
   * failure the previous scene stays loaded. The bytes are copied, not
   * transferred: the caller keeps them, and so does this object, to load
   * the scene again after a cancel. `onProgress({ step: 'scene steps',
   * done, total })` as each step ends (returning `false` or throwing
   * cancels); `signal`, an AbortSignal, cancels. A cancelled load rejects
   * with a `CancelledError` and leaves the previous scene loaded.
   */
  loadScene(bytes, options = {}, { signal, onProgress } = {}) {
    let scene;
    return this.#controlled(
      () => {
        scene = { bytes: asBytes(bytes, 'scene').slice(), options: plainOptions(options, 'scene') };
        return { type: 'load', ...scene };
      },
      signal,
      { onProgress },
    ).then((reply) => {
      this.#scene = scene;
      return reply.scene;
    });
  }

  /**
   * Parses a template in the worker and forgets it: rejects with the
   * reason a search with it would fail at once (a broken file, a sphere
   * with NaN), so that a page can refuse it before it replaces a good one.
   */
  checkTemplate(template) {
    let spec;
    try {
      spec = templateSpec(template);
    } catch (error) {
      return Promise.reject(error);
    }
    return this.#request({ type: 'check', template: spec }).then(() => undefined);
  }

  /**
   * What searching the loaded scene for `template` with `options` will
   * take, judged without running it (`Scene.plan` of the package): the
   * parts to search and the least time, or null for the curvature
   * descriptor.
   */
  plan(template, options = {}) {
    return this.#controlled(
      () => ({ type: 'plan', template: templateSpec(template), options: plainOptions(options, 'match') }),
      undefined,
      {},
    ).then((reply) => reply.plan);
  }

  /**
   * Searches the loaded scene for `template`: `{bytes, format?}` (a model)
   * or `{center, radius}` (the part of the scene inside a sphere).
   * `onLayer(stats)` after every cascade layer, `onProgress({ step,
   * done, total })` as the scene's parts are searched (returning `false`
   * from either or throwing cancels); `signal` an AbortSignal that cancels.
   * A cancelled search rejects with a `CancelledError`.
   */
  match(template, options = {}, { onLayer, onProgress, signal } = {}) {
    return this.#controlled(
      () => ({ type: 'match', template: templateSpec(template), options: plainOptions(options, 'match') }),
      signal,
      { onLayer, onProgress },
    ).then((reply) => reply.report);
  }

  /**
   * The parts a mesh file holds twice or more, found in the worker without
   * a template (`findRepeats` of the package); the loaded scene stays as
   * it was. `onProgress({ step: 'repeat steps', done, total })` as each
   * step ends (returning `false` or throwing cancels); `signal`, an
   * AbortSignal, cancels: the promise rejects with a `CancelledError`.
   */
  findRepeats(bytes, options = {}, { signal, onProgress } = {}) {
    return this.#controlled(
      () => ({ type: 'repeats', bytes: asBytes(bytes, 'scene'), options: plainOptions(options, 'repeats') }),
      signal,
      { onProgress },
    ).then((reply) => reply.report);
  }

  /**
   * A caller's request that `signal` can cancel, its `callbacks` heard:
   * the callbacks are checked, then the message is made (`makeMessage`
   * throws on bad input), then the signal; any of these rejects at once.
   */
  #controlled(makeMessage, signal, callbacks) {
    let message;
    try {
      for (const [name, callback] of Object.entries(callbacks)) {
        if (callback !== undefined && typeof callback !== 'function') {
          throw new TypeError(`fast-reject: ${name} must be a function`);
        }
      }
      message = makeMessage();
      if (signal?.aborted) throw new CancelledError(undefined, { cause: signal.reason });
    } catch (error) {
      return Promise.reject(error);
    }
    const abort = () => this.#cancel(new CancelledError(undefined, { cause: signal.reason }));
    signal?.addEventListener('abort', abort, { once: true });
    return this.#request(message, callbacks).finally(() => signal?.removeEventListener('abort', abort));
  }

  /** Stops the running request and every queued one (they reject with a `CancelledError`); the worker restarts with the scene. */
  cancel() {
    this.#cancel(new CancelledError());
  }

  /** Stops the worker for good; pending requests reject. */
  terminate() {
    this.#closed = true;
    this.#cancel(new CancelledError('fast-reject: the SearchWorker was terminated'));
  }
}

/** A module Web Worker, written the way bundlers recognize (they bundle the worker's script). */
function startWebWorker(receive, fail) {
  const worker = new Worker(new URL('./search-thread.js', import.meta.url), { type: 'module' });
  worker.onmessage = ({ data }) => receive(data);
  worker.onerror = (event) => {
    event.preventDefault();
    fail(event.message || 'it could not start (is the package built and served with its files?)');
  };
  return {
    post: (message) => worker.postMessage(message),
    terminate: () => worker.terminate(),
    hold: () => {},
  };
}

/** A worker_threads Worker; it keeps Node running only while a request is pending. */
function startNodeThread(receive, fail) {
  const thread = nodeThreads().then(({ Worker }) => {
    // Not a literal: browser bundlers must not take this for an asset.
    const script = './search-thread.js';
    const worker = new Worker(new URL(script, import.meta.url));
    worker.on('message', receive);
    worker.on('error', (error) => fail(error?.message ?? String(error)));
    worker.on('exit', (code) => {
      if (!ended) fail(`it exited with code ${code}`);
    });
    return worker;
  });
  let ended = false;
  thread.catch((error) => fail(error?.message ?? String(error)));
  return {
    post: (message) => thread.then((worker) => worker.postMessage(message)),
    terminate: () => {
      ended = true;
      thread.then((worker) => worker.terminate());
    },
    hold: (busy) => thread.then((worker) => (busy ? worker.ref() : worker.unref())),
  };
}

let threadsModule = null;
function nodeThreads() {
  // A computed specifier: bundlers for the browser must not resolve it.
  const name = 'node:worker_threads';
  threadsModule ??= import(/* @vite-ignore */ /* webpackIgnore: true */ name);
  return threadsModule;
}
