// Loads the package the way a viewer's worker would, runs one search and
// reports instances, timings, threads and memory.
import { Scene, Template, findRepeats, init, memoryBytes } from '/pkg/index.js';

/**
 * The test probe `threadsUsed` is not in the package's API: it is read from
 * the build's own glue, the same module instance that index.js loaded (an
 * ES module is one instance per URL), so it runs in the initialized pool.
 */
async function threadsUsed(build, tasks) {
  const glue = await import(`/pkg/${build}/fast_reject.js`);
  return glue.threadsUsed(tasks);
}

async function bytes(url) {
  const response = await fetch(url);
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
  return new Uint8Array(await response.arrayBuffer());
}

onmessage = async ({ data: job }) => {
  try {
    const info = await init({ build: job.build, threads: job.threads });
    if (job.repeats) {
      // The repeated parts, and the instanced file (`job.repeats`: 'nodes'
      // or 'gpu-instancing'), of the scene alone.
      const sceneBytes = await bytes(`/scenes/${job.scene}/scene.glb`);
      const start = performance.now();
      const report = findRepeats(sceneBytes, { instanced: job.repeats });
      postMessage({
        info,
        wallMs: performance.now() - start,
        memoryBytes: memoryBytes(),
        families: report.families.length,
        copies: report.families.reduce((sum, f) => sum + f.copies.length, 0),
        written: report.written,
        timings: report.timingsMs,
      });
      return;
    }
    const [sceneBytes, templateBytes] = await Promise.all([
      bytes(`/scenes/${job.scene}/scene.glb`),
      bytes(`/scenes/${job.scene}/template.glb`),
    ]);
    const start = performance.now();
    // Every progress report, with when it came: what a viewer would show.
    const told = [];
    const onProgress = ({ step, done, total }) => {
      told.push({ step, done, total, at: performance.now() - start });
    };
    const scene = Scene.fromBytes(sceneBytes, { resolution: job.resolution }, { onProgress });
    const template = Template.fromBytes(templateBytes);
    let layers = 0;
    const onLayer = () => {
      layers += 1;
    };
    // `gpu`: the layers on WebGPU, the software adapter allowed.
    const options = job.options ?? {};
    const report = job.gpu
      ? await scene.matchGpu(template, options, { onLayer, onProgress }, { allowSoftware: true })
      : scene.match(template, options, { onLayer, onProgress });
    const wallMs = performance.now() - start;
    template.free();
    scene.free();
    postMessage({
      info,
      threadsUsed: await threadsUsed(info.build, 1024),
      layers,
      wallMs,
      memoryBytes: memoryBytes(),
      instances: report.instances,
      stages: report.stages.map(({ ms, ...counts }) => counts),
      gpu: report.gpu,
      timings: report.timingsMs,
      progress: progressSummary(told, wallMs),
    });
  } catch (error) {
    postMessage({ error: String(error?.stack ?? error) });
  }
};

/**
 * What the progress reports showed: their steps in order, whether each
 * step's count only rose, and the longest time nothing was told (from the
 * start, between reports, to the end).
 */
function progressSummary(told, wallMs) {
  const steps = [...new Set(told.map((p) => p.step))];
  const rising = steps.every((step) => {
    const mine = told.filter((p) => p.step === step);
    return mine.every((p, i) => p.done <= p.total && (i === 0 || p.done > mine[i - 1].done));
  });
  const times = [0, ...told.map((p) => p.at), wallMs];
  const longestSilenceMs = Math.max(...times.slice(1).map((t, i) => t - times[i]));
  return { reports: told.length, steps, rising, longestSilenceMs };
}
