#!/usr/bin/env node
// The native CLI through the WebAssembly build, so that native and wasm
// results and times can be compared on the same scenes:
//   fast-reject match SCENE (--template FILE | --select X,Y,Z,R)
//               [--descriptor D] [--resolution N] [--threads N] [--layers K]
//               [--volume-threshold T] [--harmonics-threshold T]
//               [--curvature-threshold T] [--curvature-spacing F]
//               [--verify-threshold T] [--hidden-surface T] [--json]
//   fast-reject demo [--json]     the demo scene and template shipped in demo/
import { readFile } from 'node:fs/promises';
import { extname } from 'node:path';
import { fileURLToPath } from 'node:url';
import { parseArgs } from 'node:util';

import { Scene, Template, init, memoryBytes } from '../index.js';

const USAGE = `usage: fast-reject match SCENE (--template FILE | --select X,Y,Z,R)
                   [--descriptor volume+harmonics|volume|harmonics|curvature] [--resolution N]
                   [--threads N] [--layers K] [--volume-threshold T]
                   [--harmonics-threshold T] [--curvature-threshold T]
                   [--curvature-spacing F]
                   [--verify-threshold T] [--hidden-surface T] [--json]
       fast-reject demo [--json]`;

/** Numeric flags and the match option each one sets. */
const NUMERIC_FLAGS = {
  layers: 'layers',
  'volume-threshold': 'volumeThreshold',
  'harmonics-threshold': 'harmonicsThreshold',
  'curvature-threshold': 'curvatureThreshold',
  'curvature-spacing': 'curvatureSpacing',
  'verify-threshold': 'verifyThreshold',
  'hidden-surface': 'hiddenSurface',
};

class UsageError extends Error {}

function parseNumber(flag, text) {
  const value = Number(text);
  if (text.trim() === '' || !Number.isFinite(value)) {
    throw new UsageError(`--${flag} takes a number, got '${text}'`);
  }
  return value;
}

function parseCommandLine(argv) {
  const options = {
    template: { type: 'string' },
    select: { type: 'string' },
    descriptor: { type: 'string' },
    resolution: { type: 'string' },
    threads: { type: 'string' },
    json: { type: 'boolean' },
    help: { type: 'boolean', short: 'h' },
  };
  for (const flag of Object.keys(NUMERIC_FLAGS)) options[flag] = { type: 'string' };
  // Values may start with '-' (a negative coordinate in --select): join each
  // valued flag with its value so that parseArgs never takes it for a flag.
  const valued = new Set(Object.keys(options).filter((k) => options[k].type === 'string').map((k) => `--${k}`));
  const args = [];
  for (let i = 0; i < argv.length; i++) {
    args.push(valued.has(argv[i]) && i + 1 < argv.length ? `${argv[i]}=${argv[++i]}` : argv[i]);
  }
  let parsed;
  try {
    parsed = parseArgs({ args, options, allowPositionals: true });
  } catch (error) {
    throw new UsageError(error.message);
  }
  const { values, positionals } = parsed;
  if (values.help) return { help: true };
  if (positionals[0] === 'demo' && positionals.length === 1) {
    const demo = (name) => fileURLToPath(new URL(`../demo/${name}`, import.meta.url));
    return { scene: demo('scene.glb'), template: demo('template.glb'), json: !!values.json, match: {} };
  }
  if (positionals[0] !== 'match' || positionals.length !== 2) {
    throw new UsageError('expected: match SCENE, or demo');
  }
  if ((values.template === undefined) === (values.select === undefined)) {
    throw new UsageError('give exactly one of --template FILE and --select X,Y,Z,R');
  }
  let select;
  if (values.select !== undefined) {
    const parts = values.select.split(',');
    if (parts.length !== 4) {
      throw new UsageError(`--select takes four numbers X,Y,Z,R (sphere centre and radius), got '${values.select}'`);
    }
    select = parts.map((p) => parseNumber('select', p));
  }
  const match = {};
  if (values.descriptor !== undefined) match.descriptor = values.descriptor;
  for (const [flag, key] of Object.entries(NUMERIC_FLAGS)) {
    if (values[flag] !== undefined) match[key] = parseNumber(flag, values[flag]);
  }
  const threads = values.threads === undefined ? undefined : parseNumber('threads', values.threads);
  if (threads !== undefined && !(Number.isInteger(threads) && threads >= 1)) {
    throw new UsageError('--threads must be at least 1');
  }
  return {
    scene: positionals[1],
    template: values.template,
    select,
    resolution: values.resolution === undefined ? undefined : parseNumber('resolution', values.resolution),
    threads,
    json: !!values.json,
    match,
  };
}

function formatOf(path) {
  return extname(path).slice(1).toLowerCase() || undefined;
}

async function readMesh(path) {
  try {
    return await readFile(path);
  } catch (error) {
    throw new Error(`cannot read '${path}': ${error.message}`);
  }
}

function printTable(report, build) {
  const t = report.template;
  const lines = [
    `build: wasm ${build}, ${report.threads} thread(s)`,
    `template: centre (${t.center.map((v) => v.toFixed(4)).join(', ')}), radius ${t.radius.toFixed(4)}`,
    report.grid
      ? `grid: ${report.grid.resolution} voxels on the longest side, voxel ${report.grid.voxel_size.toFixed(5)}, ${report.grid.skin_voxels} candidate points`
      : `surface: ${report.surface.vertices} welded vertices (the candidate points), ${report.surface.triangles} triangles`,
    '',
  ];
  for (const s of report.stages) {
    lines.push(
      `${s.descriptor.padEnd(10)} ${String(s.layer).padStart(5)} ${s.radius.toFixed(4).padStart(8)} ${String(s.candidates).padStart(10)} ${String(s.survivors).padStart(10)} ${s.ms.toFixed(1).padStart(9)}`,
    );
  }
  lines.push('', `${report.instances.length} instance(s):`);
  report.instances.forEach((inst, i) => {
    const p = inst.position.map((v) => v.toFixed(4)).join(', ');
    lines.push(`  #${i + 1} at (${p})  distance ${inst.distance.toFixed(4)}${inst.score === null ? '' : `  agreement ${inst.score.toFixed(3)}`}  support ${inst.support}`);
  });
  const tm = report.timings_ms;
  lines.push(
    '',
    `time (ms): load ${tm.load.toFixed(1)}, voxelize/weld ${(tm.voxelize + tm.surface).toFixed(1)}, template ${tm.template.toFixed(1)}, match ${tm.match.toFixed(1)}, group ${tm.group.toFixed(1)}, total ${tm.total.toFixed(1)}`,
    `peak wasm memory: ${(memoryBytes() / 2 ** 20).toFixed(0)} MiB`,
  );
  console.log(lines.join('\n'));
}

async function main(argv) {
  const args = parseCommandLine(argv);
  if (args.help) {
    console.log(USAGE);
    return;
  }
  const { build } = await init();
  if (args.threads > 1) {
    console.error(`note: --threads ${args.threads}: Node runs the plain wasm build on one thread`);
  }
  const start = performance.now();
  const [sceneBytes, templateBytes] = await Promise.all([
    readMesh(args.scene),
    args.template === undefined ? undefined : readMesh(args.template),
  ]);
  const readMs = performance.now() - start;
  let scene;
  try {
    scene = Scene.fromBytes(sceneBytes, { format: formatOf(args.scene), resolution: args.resolution });
  } catch (error) {
    throw new Error(`scene '${args.scene}': ${error.message}`);
  }
  let template;
  try {
    template =
      args.template === undefined
        ? Template.fromSelection(args.select.slice(0, 3), args.select[3])
        : Template.fromBytes(templateBytes, { format: formatOf(args.template) });
  } catch (error) {
    throw new Error(args.template === undefined ? error.message : `'${args.template}': ${error.message}`);
  }
  const report = scene.match(template, args.match);
  template.free();
  scene.free();
  report.timings_ms.load += readMs;
  report.timings_ms.total += readMs;
  if (args.json) {
    const { instancePositions, highlightRadius, threads, ...cliShape } = report;
    console.log(JSON.stringify({ ...cliShape, wasm: { build, threads, memory_bytes: memoryBytes() } }));
  } else {
    printTable(report, build);
  }
}

main(process.argv.slice(2)).catch((error) => {
  console.error(`error: ${error.message}`);
  if (error instanceof UsageError) console.error(USAGE);
  process.exitCode = error instanceof UsageError ? 2 : 1;
});
