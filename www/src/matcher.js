// The page's side of the search worker: promises for loading and matching,
// per-layer progress, and a cancel that really stops the work (the worker is
// terminated and a fresh one is started with the current scene).

/** Rejects a cancelled search; the page tells it apart from a failure. */
export class Cancelled extends Error {
  constructor() {
    super('search cancelled');
    this.name = 'Cancelled';
  }
}

export class Matcher {
  #worker = null;
  #ready = null;
  #pending = new Map();
  #nextId = 1;
  /** The scene the worker holds (bytes kept to restart it after a cancel). */
  #scene = null;
  #onStatus;

  /** `onStatus(info)` is told which build runs, each time a worker starts. */
  constructor({ onStatus = () => {} } = {}) {
    this.#onStatus = onStatus;
    this.#start();
  }

  #start() {
    const worker = new Worker(new URL('./search-worker.js', import.meta.url), { type: 'module' });
    this.#worker = worker;
    worker.onmessage = ({ data }) => this.#receive(data);
    worker.onerror = (event) => {
      event.preventDefault();
      const message = `the search worker failed: ${event.message || 'it could not start (is pkg/ built?)'}`;
      for (const job of this.#pending.values()) job.reject(new Error(message));
      this.#pending.clear();
    };
    this.#ready = this.#request({ type: 'init' }).then(({ info }) => {
      this.#onStatus(info);
      return info;
    });
    // A restarted worker gets the scene it had; callers queue behind it.
    if (this.#scene) {
      const scene = this.#scene;
      this.#ready = this.#ready.then(async (info) => {
        // It parsed before, so it parses again.
        await this.#request({ type: 'load', ...scene });
        return info;
      });
    }
  }

  #request(message, onLayer) {
    const id = this.#nextId++;
    return new Promise((resolve, reject) => {
      this.#pending.set(id, { resolve, reject, onLayer });
      this.#worker.postMessage({ ...message, id });
    });
  }

  #receive(data) {
    const job = this.#pending.get(data.id);
    if (!job) return;
    if (data.type === 'layer') {
      job.onLayer?.(data.stats);
      return;
    }
    this.#pending.delete(data.id);
    if (data.type === 'error') job.reject(new Error(data.message));
    else job.resolve(data);
  }

  /** Resolves to the build info once the worker is up. */
  ready() {
    return this.#ready;
  }

  /**
   * Parses a scene in the worker; on failure the previous scene stays loaded
   * and the promise rejects with the package's message.
   */
  async load(scene) {
    await this.#ready;
    const reply = await this.#request({ type: 'load', ...scene });
    this.#scene = scene;
    return reply;
  }

  /** Runs one search; `onLayer(stats)` after every cascade layer. */
  async match(template, options, onLayer) {
    await this.#ready;
    const reply = await this.#request({ type: 'match', template, options }, onLayer);
    return reply;
  }

  /** Stops a running search at once; the next call waits for a fresh worker. */
  cancel() {
    this.#worker.terminate();
    for (const job of this.#pending.values()) job.reject(new Cancelled());
    this.#pending.clear();
    this.#start();
  }
}
