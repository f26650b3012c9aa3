// wasm-bindgen-rayon's no-bundler worker helper starts every pool worker
// from a blob: copy of its own script. Under a dev server that rewrites the
// script (Vite adds `import ... from "/@vite/client"` for its dynamic
// import), the copy cannot resolve that root path, the worker dies, and
// initThreadPool never settles. A script of the page's origin is started
// from its own URL instead; a cross-origin one keeps the blob copy.
//   node scripts/patch-pool-start.mjs HELPER.js...
import { readFileSync, writeFileSync } from 'node:fs';

const BLOB_START = [
  '      let scriptBlob = await fetch(import.meta.url).then(r => r.blob());',
  '      let url = URL.createObjectURL(scriptBlob);',
];
const URL_START = [
  '      const script = new URL(import.meta.url);',
  '      const sameOrigin = script.origin === globalThis.location?.origin;',
  '      let url = sameOrigin ? script.href : URL.createObjectURL(await fetch(script).then(r => r.blob()));',
];
const REVOKE = '      URL.revokeObjectURL(url);';
const REVOKE_BLOB = '      if (!sameOrigin) URL.revokeObjectURL(url);';

for (const file of process.argv.slice(2)) {
  const text = readFileSync(file, 'utf8');
  // The helper ships with Windows line ends.
  const eol = text.includes('\r\n') ? '\r\n' : '\n';
  const [blobStart, urlStart] = [BLOB_START.join(eol), URL_START.join(eol)];
  if (text.includes(urlStart)) continue;
  if (!text.includes(blobStart) || !text.includes(REVOKE)) {
    console.error(`patch-pool-start: ${file} no longer starts its workers from a blob copy; check the dev-server start`);
    process.exit(1);
  }
  writeFileSync(file, text.replace(blobStart, urlStart).replace(REVOKE, REVOKE_BLOB));
}
