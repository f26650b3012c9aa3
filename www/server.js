#!/usr/bin/env node
// The viewer's static server, bound to 127.0.0.1. It sends the
// Cross-Origin-Opener-Policy / Cross-Origin-Embedder-Policy headers that make
// the page cross-origin isolated, which the threaded WebAssembly build needs
// (SharedArrayBuffer); `--no-isolation` leaves them out, and the page then
// runs the single-threaded build.
//
//   node www/server.js [--port N] [--no-isolation]
//
// It serves www/ at /, the npm package built into pkg/ at /pkg/, three.js
// from www/node_modules at /vendor/three/, and the embedded demo scene at
// /demo/.
import { readFile, stat } from 'node:fs/promises';
import { createServer } from 'node:http';
import { extname, resolve, sep } from 'node:path';
import { fileURLToPath } from 'node:url';

const www = fileURLToPath(new URL('.', import.meta.url));
const repo = resolve(www, '..');

/** The viewer's URL prefixes and the folders they serve. */
const VIEWER_ROOTS = {
  '/pkg/': resolve(repo, 'pkg'),
  '/vendor/three/': resolve(www, 'node_modules/three'),
  '/demo/': resolve(repo, 'assets/demo'),
  '/': resolve(www, 'public'),
  '/src/': resolve(www, 'src'),
};

const TYPES = {
  '.html': 'text/html; charset=utf-8',
  '.js': 'text/javascript; charset=utf-8',
  '.css': 'text/css; charset=utf-8',
  '.json': 'application/json',
  '.wasm': 'application/wasm',
  '.glb': 'model/gltf-binary',
  '.gltf': 'model/gltf+json',
  '.png': 'image/png',
  '.svg': 'image/svg+xml',
};

/** The file a URL path names under the longest matching prefix, or null when it would leave its root. */
function fileFor(roots, pathname) {
  for (const [prefix, root] of roots) {
    if (!pathname.startsWith(prefix)) continue;
    let rest = pathname.slice(prefix.length);
    if (rest === '' || rest.endsWith('/')) rest += 'index.html';
    const file = resolve(root, rest);
    return file === root || file.startsWith(root + sep) ? file : null;
  }
  return null;
}

/**
 * Starts the server; resolves to `{ server, origin }`. `port` 0 picks a free
 * one; a taken port is answered by trying the next few. `roots` maps URL
 * prefixes to folders (the viewer's by default; the package's browser tests
 * serve their own page and the scenes).
 */
export async function startServer({ port = 8080, isolation = true, roots = VIEWER_ROOTS } = {}) {
  const sorted = Object.entries(roots).sort((a, b) => b[0].length - a[0].length);
  const isolationHeaders = isolation
    ? { 'Cross-Origin-Opener-Policy': 'same-origin', 'Cross-Origin-Embedder-Policy': 'require-corp' }
    : {};
  const server = createServer(async (request, response) => {
    let pathname;
    try {
      pathname = decodeURIComponent(new URL(request.url, 'http://localhost').pathname);
    } catch {
      response.writeHead(400).end('bad request');
      return;
    }
    const file = fileFor(sorted, pathname);
    try {
      if (!file || !(await stat(file)).isFile()) throw new Error('not a file');
      const body = await readFile(file);
      response.writeHead(200, {
        'Content-Type': TYPES[extname(file)] ?? 'application/octet-stream',
        'Cache-Control': 'no-cache',
        ...isolationHeaders,
      });
      response.end(request.method === 'HEAD' ? undefined : body);
    } catch {
      response.writeHead(404, { 'Content-Type': 'text/plain', ...isolationHeaders }).end(`not found: ${pathname}`);
    }
  });
  for (let attempt = 0; ; attempt += 1) {
    const tryPort = port === 0 ? 0 : port + attempt;
    try {
      await new Promise((done, fail) => {
        server.once('error', fail);
        server.listen(tryPort, '127.0.0.1', () => {
          server.off('error', fail);
          done();
        });
      });
      break;
    } catch (error) {
      if (error.code !== 'EADDRINUSE' || port === 0 || attempt >= 20) throw error;
    }
  }
  return { server, origin: `http://127.0.0.1:${server.address().port}` };
}

async function main(args) {
  let port = Number(process.env.PORT ?? 8080);
  let isolation = true;
  for (let i = 0; i < args.length; i += 1) {
    if (args[i] === '--port') port = Number(args[++i]);
    else if (args[i] === '--no-isolation') isolation = false;
    else {
      console.error(`usage: node www/server.js [--port N] [--no-isolation]   (unknown argument ${args[i]})`);
      process.exit(2);
    }
  }
  if (!Number.isInteger(port) || port < 0 || port > 65535) {
    console.error('server: --port needs a number between 0 and 65535');
    process.exit(2);
  }
  for (const root of [VIEWER_ROOTS['/pkg/'], VIEWER_ROOTS['/vendor/three/']]) {
    try {
      await stat(root);
    } catch {
      console.error(`server: ${root} is missing; run bash scripts/viewer.sh (it builds pkg/ and installs three.js)`);
      process.exit(1);
    }
  }
  const { origin } = await startServer({ port, isolation });
  console.log(`fast-reject viewer: ${origin}/  (${isolation ? 'cross-origin isolated: threads' : 'not isolated: single-threaded'}; Ctrl-C stops)`);
}

if (process.argv[1] && resolve(process.argv[1]) === fileURLToPath(import.meta.url)) {
  main(process.argv.slice(2)).catch((error) => {
    console.error(`server: ${error.message}`);
    process.exit(1);
  });
}
