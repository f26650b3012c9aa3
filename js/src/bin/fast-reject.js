#!/usr/bin/env node
// The native CLI through the WebAssembly build, so that native and wasm
// results and times can be compared on the same scenes:
//   fast-reject match SCENE (--template FILE | --select X,Y,Z,R) [options] [--json]
//   fast-reject demo [--json]     the demo scene and template shipped in demo/
// The option flags are the core's options (optionDefaults()), kebab-cased,
// as in the native CLI: a new option needs no change here.
import { readFile } from 'node:fs/promises';
import { extname } from 'node:path';
import { fileURLToPath } from 'node:url';
import { parseArgs } from 'node:util';

import { shown } from '../errors.js';
import { Scene, Template, init, memoryBytes, optionDefaults } from '../index.js';

/** `volumeThreshold` -> `volume-threshold`. */
const kebab = (key) => key.replace(/[A-Z]/g, (c) => `-${c.toLowerCase()}`);

/** The option flags, from the core's defaults: flag -> { group, key, fallback }. */
function optionFlags(defaults) {
  const flags = {};
  for (const group of ['scene', 'match']) {
    for (const [key, fallback] of Object.entries(defaults[group])) {
      flags[kebab(key)] = { group, key, fallback };
    }
  }
  return flags;
}

function usage(flags) {
  const options = Object.entries(flags)
    .map(([flag, { fallback }]) => `[--${flag} ${typeof fallback === 'number' ? 'N' : 'NAME'} (default ${fallback})]`)
    .join('\n                   ');
  return `usage: fast-reject match SCENE (--template FILE | --select X,Y,Z,R)
                   ${options}
                   [--threads N] [--json]
       fast-reject demo [--json]`;
}

class UsageError extends Error {}

function parseNumber(flag, text) {
  const value = Number(text);
  if (text.trim() === '' || !Number.isFinite(value)) {
    throw new UsageError(`--${flag} takes a number, got '${text}'`);
  }
  return value;
}

function parseCommandLine(argv, flags) {
  const options = {
    template: { type: 'string' },
    select: { type: 'string' },
    threads: { type: 'string' },
    json: { type: 'boolean' },
    help: { type: 'boolean', short: 'h' },
  };
  for (const flag of Object.keys(flags)) options[flag] = { type: 'string' };
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
    return { scene: demo('scene.glb'), template: demo('template.glb'), json: !!values.json, sceneOptions: {}, match: {} };
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
  const chosen = { scene: {}, match: {} };
  for (const [flag, { group, key, fallback }] of Object.entries(flags)) {
    if (values[flag] === undefined) continue;
    chosen[group][key] = typeof fallback === 'number' ? parseNumber(flag, values[flag]) : values[flag];
  }
  const threads = values.threads === undefined ? undefined : parseNumber('threads', values.threads);
  if (threads !== undefined && !(Number.isInteger(threads) && threads >= 1)) {
    throw new UsageError('--threads must be at least 1');
  }
  return {
    scene: positionals[1],
    template: values.template,
    select,
    threads,
    json: !!values.json,
    sceneOptions: chosen.scene,
    match: chosen.match,
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

/** `value` with every object key in snake_case (`timingsMs` to `timings_ms`). */
function snakeCaseKeys(value) {
  if (Array.isArray(value)) return value.map(snakeCaseKeys);
  if (value === null || typeof value !== 'object') return value;
  return Object.fromEntries(
    Object.entries(value).map(([key, inner]) => [key.replace(/[A-Z]/g, (c) => `_${c.toLowerCase()}`), snakeCaseKeys(inner)]),
  );
}

/** The report as the native CLI prints it without --json. */
function table(report, build) {
  const t = report.template;
  const lines = [
    `build: wasm ${build}, ${report.threads} thread(s)`,
    `template: centre (${t.center.map((v) => v.toFixed(4)).join(', ')}), radius ${t.radius.toFixed(4)}`,
    report.grid
      ? `grid: ${report.grid.resolution} voxels on the longest side, voxel ${report.grid.voxelSize.toFixed(5)}, ${report.grid.skinVoxels} candidate points`
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
    lines.push(`  #${i + 1} at (${p})  distance ${inst.distance.toFixed(4)}${inst.score === null ? '' : `  score ${inst.score.toFixed(3)}`}  support ${inst.support}`);
  });
  const tm = report.timingsMs;
  lines.push(
    '',
    `time (ms): load ${tm.load.toFixed(1)}, voxelize/weld ${(tm.voxelize + tm.surface).toFixed(1)}, template ${tm.template.toFixed(1)}, match ${tm.match.toFixed(1)}, group ${tm.group.toFixed(1)}, total ${tm.total.toFixed(1)}`,
    `peak wasm memory: ${(memoryBytes() / 2 ** 20).toFixed(0)} MiB`,
  );
  return lines.join('\n');
}

class OutputError extends Error {}

/**
 * Writes `text` and a newline to stdout, resolving once it is written: a
 * closed pipe (EPIPE, `| head`) or a full disk rejects with an OutputError.
 */
function print(text) {
  return new Promise((resolve, reject) => {
    process.stdout.write(`${text}\n`, (error) => {
      if (error) reject(new OutputError(`cannot write the output: ${error.message}`));
      else resolve();
    });
  });
}

async function main(argv) {
  const { build } = await init();
  const flags = optionFlags(optionDefaults());
  let args;
  try {
    args = parseCommandLine(argv, flags);
  } catch (error) {
    if (error instanceof UsageError) error.usage = usage(flags);
    throw error;
  }
  if (args.help) {
    await print(usage(flags));
    return;
  }
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
    scene = Scene.fromBytes(sceneBytes, { format: formatOf(args.scene), ...args.sceneOptions });
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
  report.timingsMs.load += readMs;
  report.timingsMs.total += readMs;
  if (args.json) {
    const { instancePositions, highlightRadius, threads, ...cliShape } = report;
    // The native CLI's JSON, snake_case as it writes it.
    await print(JSON.stringify(snakeCaseKeys({ ...cliShape, wasm: { build, threads, memoryBytes: memoryBytes() } })));
  } else {
    await print(table(report, build));
  }
}

// A failed write is also emitted as an 'error' event, which would end the
// process with a stack trace: the write's callback reports it instead. A
// closed stderr leaves nothing to tell; the exit code says it.
process.stdout.on('error', () => {});
process.stderr.on('error', () => {
  process.exitCode ||= 1;
});

main(process.argv.slice(2)).catch((error) => {
  // One line, whatever the message quotes (a path, a flag, a file's text).
  console.error(`error: ${shown(error?.message ?? String(error), Infinity)}`);
  if (error?.usage) console.error(error.usage);
  process.exitCode = error instanceof UsageError ? 2 : 1;
});
