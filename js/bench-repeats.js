// Repeated parts and the instanced file, native against wasm: the native
// command (`repeats --json --out`, 2 threads), the plain build in Node, and
// the plain and threaded builds in headless Chromium (2 threads), with the
// peak wasm memory. Best of N runs of the whole call (parse, find, write).
//   node js/bench-repeats.js [SCENE ...]    (BENCH_RUNS=N, default 3)
// A scene is a folder of ../shared/scenes, or `generated/NAME` for one of
// target/bench-inputs (the buildings of `scripts/bench.py scale`).
import { execFileSync } from 'node:child_process';
import { mkdtempSync, readFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { fileURLToPath } from 'node:url';

import { findRepeats, init, memoryBytes } from '../pkg/index.js';
import { runInBrowser } from './test/browser.js';

const repo = fileURLToPath(new URL('../', import.meta.url));
const scenes = process.argv.slice(2).length ? process.argv.slice(2) : ['real-saw-roller'];
const runs = Number(process.env.BENCH_RUNS ?? 3);
const GENERATED = 'generated/';
const path = (scene) => scene.startsWith(GENERATED)
  ? `${repo}target/bench-inputs/${scene.slice(GENERATED.length)}/scene.glb`
  : `${repo}../shared/scenes/${scene}/scene.glb`;
const out = `${mkdtempSync(`${tmpdir()}/repeats-`)}/out.glb`;

const best = (list, key) => list.reduce((a, b) => (key(b) < key(a) ? b : a));
const total = (t) => t.load + t.repeats + (t.write ?? 0);
await init();
const rows = [];
for (const scene of scenes) {
  const native = best(Array.from({ length: runs }, () => {
    const report = JSON.parse(execFileSync(`${repo}target/release/fast-reject`, ['repeats', path(scene), '--json', '--out', out], { encoding: 'utf8', maxBuffer: 1 << 28 }));
    return { ms: total(report.timings_ms), families: report.families.length, written: report.written };
  }), (r) => r.ms);
  const bytes = new Uint8Array(readFileSync(path(scene)));
  const node = best(Array.from({ length: runs }, () => {
    const start = performance.now();
    findRepeats(bytes, { instanced: 'nodes' });
    return { ms: performance.now() - start, memory: memoryBytes() };
  }), (r) => r.ms);
  const jobs = [];
  for (let i = 0; i < runs; i++) jobs.push({ build: 'plain', scene, repeats: 'nodes' }, { build: 'threads', scene, repeats: 'nodes' });
  const browser = await runInBrowser(jobs, { threads: 2 });
  const failed = browser.find((r) => r.error);
  if (failed) throw new Error(failed.error);
  const pick = (build) => best(browser.filter((r) => r.info.build === build), (r) => r.wallMs);
  rows.push({ scene, native, node, plain: pick('plain'), threads: pick('threads') });
  console.error(`${scene}: done`);
}
const ms = (v) => `${Math.round(v)}`;
const mib = (b) => `${Math.round(b / 2 ** 20)}`;
console.log('| scene | families | written bytes | native (2 threads) | wasm plain, Node | wasm plain, Chromium | wasm threads (2), Chromium | Chromium threads / native | peak wasm memory, Node / Chromium threads (MiB) |');
console.log('|---|---:|---:|---:|---:|---:|---:|---:|---:|');
for (const r of rows) {
  console.log(`| ${r.scene} | ${r.native.families} | ${r.native.written.bytes} | ${ms(r.native.ms)} | ${ms(r.node.ms)} | ${ms(r.plain.wallMs)} | ${ms(r.threads.wallMs)} | `
    + `${(r.threads.wallMs / r.native.ms).toFixed(2)}x | ${mib(r.node.memory)} / ${mib(r.threads.memoryBytes)} |`);
}
