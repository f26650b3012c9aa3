// The package's error classes, in a module of their own so that the worker
// API (worker.js) can throw them without loading the WebAssembly module on
// the calling thread.

/**
 * A search stopped before its end: the progress callback returned `false`
 * or threw (that error is the `cause`), or the caller cancelled it. Apart
 * from a failure by its class, and by `code === 'cancelled'`.
 */
export class CancelledError extends Error {
  constructor(message = 'fast-reject: the search was cancelled', options) {
    super(message, options);
    this.name = 'CancelledError';
    this.code = 'cancelled';
  }
}
