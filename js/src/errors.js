// The package's error classes, and the checks that throw them, in a module
// of their own so that the worker API (worker.js) can use them without
// loading the WebAssembly module on the calling thread.

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

/**
 * The threaded build's pool of workers did not start: they failed to load
 * or did not answer in time. `build: 'auto'` falls back to the plain build
 * instead (and `init()`'s `fallback` says why); `build: 'threads'` throws
 * this. Apart by its class, and by `code === 'thread-pool'`.
 */
export class ThreadPoolError extends Error {
  constructor(message, options) {
    super(message, options);
    this.name = 'ThreadPoolError';
    this.code = 'thread-pool';
  }
}

// Control characters (escape sequences start with them) and the invisible
// ones that reorder or hide text: the set the core escapes in its messages.
const UNSAFE = /[\u0000-\u001f\u007f-\u009f\u200b-\u200f\u2028-\u202e\u2060-\u2069\ufeff\ufff9-\ufffb]/gu;
const NAMED = { '\n': '\\n', '\r': '\\r', '\t': '\\t' };

/**
 * Text from outside the package (a file name, an option, what a caller's
 * callback threw) as a message may show it: unsafe characters as `\u{..}`
 * escapes, cut after `max` characters, so that no message can drive a
 * terminal or hide what it says.
 */
export function shown(text, max = 400) {
  const escaped = String(text).replace(UNSAFE, (c) => NAMED[c] ?? `\\u{${c.codePointAt(0).toString(16)}}`);
  return escaped.length > max ? `${escaped.slice(0, max)}... (${escaped.length} characters in all)` : escaped;
}

/** What `thrown` says, for a message: its `message` or its string form, shown safely. */
export function describe(thrown) {
  try {
    return shown(thrown instanceof Error || typeof thrown?.message === 'string' ? thrown.message : String(thrown));
  } catch {
    return 'a value that cannot be printed';
  }
}

/**
 * `options` read once, here, into a fresh plain object of its own
 * enumerable properties (`undefined` ones left out): what the module and
 * the worker are given can then neither throw while they read it (a Proxy
 * trap, a getter) nor fail to be sent to a worker (a function). Such an
 * option is a TypeError naming it; the values themselves are checked by
 * the module. `undefined` and `null` stay as they are (the defaults).
 */
export function plainOptions(options, what) {
  if (options === undefined || options === null) return options;
  let keys = null;
  try {
    // Array.isArray throws for a revoked Proxy.
    if (typeof options === 'object' && !Array.isArray(options)) keys = Object.keys(options);
  } catch (error) {
    throw new TypeError(`fast-reject: cannot read the ${what} options: ${describe(error)}`, { cause: error });
  }
  if (!keys) throw new TypeError(`fast-reject: ${what} options must be an object`);
  const plain = {};
  for (const key of keys) {
    let value;
    try {
      value = options[key];
    } catch (error) {
      throw new TypeError(`fast-reject: cannot read ${what} option ${shown(key)}: ${describe(error)}`, { cause: error });
    }
    if (value === undefined) continue;
    const type = value === null ? 'null' : typeof value;
    if (type === 'object' || type === 'function' || type === 'symbol') {
      throw new TypeError(
        `fast-reject: invalid ${what} option ${shown(key)}: expected a number, a string or a boolean, got ${type === 'object' ? 'an object' : `a ${type}`}`,
      );
    }
    // Defined, not assigned: a key named __proto__ stays an (unknown) option.
    Object.defineProperty(plain, key, { value, enumerable: true, writable: true, configurable: true });
  }
  return plain;
}
