// The viewer page: wires files, the 3D view, the package's search worker
// (fast-reject/worker) and the panel. It opens on the embedded demo (a scene
// and a template served from /demo/) and searches it at once.
import { CancelledError, SearchWorker } from '/pkg/worker.js';

import { FileProblem, readModel } from './files.js';
import { View, parseModel } from './view.js';

const $ = (id) => document.getElementById(id);

const state = {
  /** {name, format, bytes} of the scene shown and loaded in the worker. */
  scene: null,
  /** {kind: 'model', name, format, bytes} of the last template file. */
  modelTemplate: null,
  /** {center, radius} of the selection sphere, in scene coordinates. */
  selection: null,
  /** Incremented by every search and every scene change: late replies of older ones are dropped. */
  generation: 0,
  running: false,
  report: null,
  build: null,
  /** Whether the option fields were set from the core's defaults. */
  defaultsApplied: false,
  /** 'starting' | 'loading' | 'ready' | 'searching' | 'done' | 'cancelled' | 'error' (also on <body data-status>). */
  status: 'starting',
  /** The last message shown to the user (tests wait on it). */
  lastMessage: null,
};

const view = new View($('viewport'), {
  onPick: (point) => placeSelection(point),
  onWheelRadius: (factor) => setSelectionRadius((state.selection?.radius ?? sliderRadius()) * factor),
});
// WebGPU where the browser has a hardware adapter; the threaded build where
// the page is cross-origin isolated.
const matcher = new SearchWorker();

function setStatus(status) {
  state.status = status;
  document.body.dataset.status = status;
}

// ---- messages ----------------------------------------------------------

function showMessage(text, kind = 'error') {
  state.lastMessage = text;
  $('message-text').textContent = text;
  $('message').className = kind;
  $('message').hidden = false;
}
function dismissMessage() {
  state.lastMessage = null;
  $('message').hidden = true;
}
$('message-close').addEventListener('click', dismissMessage);

// ---- build and WebGPU badges ---------------------------------------------

function showBuild(info) {
  state.build = info;
  applyDefaults(info.defaults);
  const badge = $('threads-badge');
  if (info.build === 'threads') {
    badge.textContent = `threaded: ${info.threads} threads (cross-origin isolated)`;
    badge.classList.add('on');
  } else {
    const why = globalThis.crossOriginIsolated ? 'one core' : 'not cross-origin isolated';
    badge.textContent = `single-threaded (${why})`;
    badge.classList.remove('on');
  }
}

async function showWebGpu() {
  const badge = $('webgpu-badge');
  let adapter = null;
  try {
    adapter = await navigator.gpu?.requestAdapter();
  } catch {
    adapter = null;
  }
  // A fallback adapter is software: slower than the CPU code, so unused.
  const hardware = !!adapter && !adapter.info?.isFallbackAdapter;
  badge.textContent = hardware
    ? 'WebGPU: the search runs its layers on the GPU'
    : adapter
      ? 'WebGPU: software only (the search runs on the CPU)'
      : 'WebGPU: not available (the search runs on the CPU)';
  badge.classList.toggle('on', hardware);
  badge.dataset.webgpu = hardware ? 'yes' : 'no';
}

// ---- scene -----------------------------------------------------------------

/** Loads a scene from files; on any failure the current scene stays as it was. */
async function openScene(files) {
  let model;
  let object;
  let restore = state.status === 'loading' ? 'ready' : state.status;
  try {
    setStatus('loading');
    model = await readModel(files);
    $('progress-text').textContent = `Reading ${model.name}…`;
    object = await parseModel(model);
    if (state.running) {
      cancelSearch();
      restore = 'cancelled';
    }
    $('progress-text').textContent = `Loading ${model.name} into the matcher…`;
    await matcher.loadScene(model.bytes, { format: model.format });
  } catch (error) {
    object?.traverse((node) => node.geometry?.dispose());
    showMessage(`Could not open ${model?.name ?? 'the file'}: ${error.message} The current scene is unchanged.`);
    $('progress-text').textContent = '\u00a0';
    setStatus(restore);
    return false;
  }
  state.generation += 1;
  state.scene = model;
  state.selection = null;
  state.report = null;
  view.setModel(object, upAxisFor(object));
  showUpAxis();
  $('scene-name').textContent = `${model.name}`;
  dismissMessage();
  clearResults();
  setSelectionRadius(sliderRadius());
  $('progress-text').textContent = '\u00a0';
  setStatus('ready');
  return true;
}

async function openTemplate(files) {
  try {
    const model = await readModel(files);
    state.modelTemplate = { kind: 'model', ...model };
    $('template-name').textContent = model.name;
    setTemplateKind('model');
    await runSearch();
  } catch (error) {
    showMessage(error instanceof FileProblem ? error.message : `Could not open the template: ${error.message}`);
  }
}

$('scene-input').addEventListener('change', async (event) => {
  const files = [...event.target.files];
  event.target.value = '';
  await openScene(files);
});
$('template-input').addEventListener('change', async (event) => {
  const files = [...event.target.files];
  event.target.value = '';
  await openTemplate(files);
});

// Drag and drop anywhere on the view.
const viewport = $('viewport');
let dragDepth = 0;
viewport.addEventListener('dragenter', (event) => {
  event.preventDefault();
  dragDepth += 1;
  $('drop-overlay').hidden = false;
});
viewport.addEventListener('dragleave', () => {
  dragDepth = Math.max(dragDepth - 1, 0);
  if (dragDepth === 0) $('drop-overlay').hidden = true;
});
viewport.addEventListener('dragover', (event) => event.preventDefault());
// A file dropped beside the view must not make the browser navigate to it
// (and lose the page).
window.addEventListener('dragover', (event) => event.preventDefault());
window.addEventListener('drop', (event) => event.preventDefault());
viewport.addEventListener('drop', async (event) => {
  event.preventDefault();
  dragDepth = 0;
  $('drop-overlay').hidden = true;
  await openScene([...event.dataTransfer.files]);
});

/** The chosen up axis, or the view's guess for `object` when it is 'auto'. */
function upAxisFor(object) {
  const chosen = $('up-axis').value;
  return chosen === 'auto' ? view.guessUp(object) : chosen;
}

function showUpAxis() {
  $('up-axis-used').textContent = $('up-axis').value === 'auto' ? `(${view.up} up)` : '';
}

$('up-axis').addEventListener('change', () => {
  const chosen = $('up-axis').value;
  view.up = chosen === 'auto' ? view.guessUp() : chosen;
  showUpAxis();
});

// ---- template: model or selection sphere ------------------------------------

function templateKind() {
  return document.querySelector('input[name="template-kind"]:checked').value;
}

function setTemplateKind(kind) {
  document.querySelector(`input[name="template-kind"][value="${kind}"]`).checked = true;
  $('model-template').hidden = kind !== 'model';
  $('selection-template').hidden = kind !== 'selection';
  view.setSelection(kind === 'selection' ? state.selection : null);
}
for (const input of document.querySelectorAll('input[name="template-kind"]')) {
  input.addEventListener('change', () => setTemplateKind(templateKind()));
}

/** The slider is logarithmic, from 0.2% to 50% of the scene's radius. */
const RADIUS_SHARES = [0.002, 0.5];

function sliderRadius() {
  const t = Number($('radius-slider').value) / 1000;
  const [low, high] = RADIUS_SHARES;
  return view.sceneRadius * low * Math.pow(high / low, t);
}

/** Sizes the selection sphere (clamped to the slider's range) and moves the slider to match. */
function setSelectionRadius(radius) {
  const [low, high] = RADIUS_SHARES.map((share) => view.sceneRadius * share);
  radius = Math.min(Math.max(radius, low), high);
  if (state.selection) {
    state.selection = { ...state.selection, radius };
    view.setSelection(state.selection);
  }
  $('radius-value').textContent = formatLength(radius);
  $('radius-slider').value = String(Math.round((Math.log(radius / low) / Math.log(high / low)) * 1000));
}

$('radius-slider').addEventListener('input', () => setSelectionRadius(sliderRadius()));

function placeSelection(point) {
  if (templateKind() !== 'selection') setTemplateKind('selection');
  state.selection = { center: point, radius: state.selection?.radius ?? sliderRadius() };
  view.setSelection(state.selection);
  $('radius-value').textContent = formatLength(state.selection.radius);
  $('selection-hint').textContent = `Sphere at (${point.map((v) => v.toFixed(3)).join(', ')}). Search to find every part like it.`;
}

/** What the worker needs for the current template, or null with a message. */
function currentTemplate() {
  if (templateKind() === 'selection') {
    if (!state.selection) {
      showMessage('Click the surface to place a selection sphere first.', 'info');
      return null;
    }
    return { kind: 'selection', center: state.selection.center, radius: state.selection.radius };
  }
  if (!state.modelTemplate) {
    showMessage('Open a template file first, or switch to a selection sphere.', 'info');
    return null;
  }
  return state.modelTemplate;
}

// ---- search ---------------------------------------------------------------

function descriptor() {
  return $('descriptor').value;
}

/**
 * Sets the option fields to the core's defaults (once: a restarted worker
 * must not undo what the user typed). The page's own values are only what
 * shows before the module is up.
 */
function applyDefaults(defaults) {
  if (!defaults || state.defaultsApplied) return;
  state.defaultsApplied = true;
  const kebab = (key) => key.replace(/[A-Z]/g, (c) => `-${c.toLowerCase()}`);
  for (const [key, value] of Object.entries({ ...defaults.scene, ...defaults.match })) {
    const field = document.getElementById(kebab(key));
    if (field) field.value = String(value);
  }
  showThresholds();
}

function searchOptions() {
  const options = { descriptor: descriptor(), resolution: Number($('resolution').value) };
  const thresholds = {
    volumeThreshold: 'volume-threshold',
    harmonicsThreshold: 'harmonics-threshold',
    curvatureThreshold: 'curvature-threshold',
    curvatureSpacing: 'curvature-spacing',
  };
  for (const [key, id] of Object.entries(thresholds)) {
    const value = Number($(id).value);
    if ($(id).value !== '' && Number.isFinite(value)) options[key] = value;
  }
  return options;
}

/** Shows only the thresholds the chosen descriptor uses. */
function showThresholds() {
  const stages = descriptor().split('+');
  for (const element of document.querySelectorAll('[data-for]')) {
    if (stages.includes(element.dataset.for)) delete element.dataset.hidden;
    else element.dataset.hidden = '';
  }
  $('resolution').disabled = descriptor() === 'curvature';
}

async function runSearch() {
  if (!state.scene) {
    showMessage('Open a scene first.', 'info');
    return;
  }
  const template = currentTemplate();
  if (!template) return;
  if (state.running) cancelSearch();
  const generation = ++state.generation;
  const options = searchOptions();
  // Two stages, or the curvature search's sampled pass and its final pass
  // (a coarse mesh runs the final pass alone; the bar then fills at the end).
  const sampled = options.descriptor === 'curvature' && options.curvatureSpacing > 0;
  const stageCount = options.descriptor === 'volume+harmonics' || sampled ? 2 : 1;
  const expectedLayers = 6 * stageCount;
  const layers = [];
  state.running = true;
  setStatus('searching');
  dismissMessage();
  $('cancel-button').disabled = false;
  $('progress-bar').value = 0;
  $('progress-text').textContent =
    options.descriptor === 'curvature'
      ? 'Preparing: welding the surface and describing the template…'
      : 'Preparing: voxelizing the scene and describing the template…';
  clearResults();
  try {
    const start = performance.now();
    const onLayer = (stats) => {
      if (generation !== state.generation) return;
      layers.push(stats);
      $('progress-bar').value = Math.min(layers.length / expectedLayers, 1);
      $('progress-text').textContent =
        `${stats.descriptor} layer ${stats.layer} (r = ${formatLength(stats.radius)}): ` +
        `${stats.survivors.toLocaleString()} of ${stats.candidates.toLocaleString()} candidates survive`;
      appendLayerRow(stats);
    };
    const report = await matcher.match(template, options, { onLayer });
    if (generation !== state.generation) return;
    state.report = report;
    $('progress-bar').value = 1;
    showResults(report, performance.now() - start);
    setStatus('done');
  } catch (error) {
    if (generation !== state.generation) return;
    if (error instanceof CancelledError) {
      $('progress-text').textContent = 'Cancelled.';
      setStatus('cancelled');
    } else {
      $('progress-text').textContent = 'The search failed.';
      showMessage(error.message);
      setStatus('error');
    }
  } finally {
    if (generation === state.generation) {
      state.running = false;
      $('cancel-button').disabled = true;
    }
  }
}

function cancelSearch() {
  if (!state.running) return;
  state.running = false;
  state.generation += 1;
  matcher.cancel();
  $('cancel-button').disabled = true;
  $('progress-text').textContent = 'Cancelled.';
  setStatus('cancelled');
}

$('search-button').addEventListener('click', () => runSearch());
$('cancel-button').addEventListener('click', () => cancelSearch());

// Changing a setting re-runs the search that is shown (or running).
let rerunTimer = 0;
function rerunSoon() {
  clearTimeout(rerunTimer);
  if (!state.report && !state.running) return;
  rerunTimer = setTimeout(() => runSearch(), 250);
}
$('descriptor').addEventListener('change', () => {
  showThresholds();
  rerunSoon();
});
for (const id of ['resolution', 'volume-threshold', 'harmonics-threshold', 'curvature-threshold', 'curvature-spacing']) {
  $(id).addEventListener('change', rerunSoon);
}

// ---- results -------------------------------------------------------------

function clearResults() {
  view.setMatches(new Float64Array(), 0);
  $('progress-bar').value = 0;
  $('instance-list').replaceChildren();
  $('layer-table').tBodies[0].replaceChildren();
  $('timing-table').tBodies[0].replaceChildren();
  $('match-count').textContent = '';
  $('total-time').textContent = '';
}

function appendLayerRow(stats) {
  const row = document.createElement('tr');
  for (const text of [
    `${stats.descriptor} ${stats.layer}`,
    formatLength(stats.radius),
    stats.candidates.toLocaleString(),
    stats.survivors.toLocaleString(),
    stats.ms.toFixed(1),
  ]) {
    const cell = document.createElement('td');
    cell.textContent = text;
    row.append(cell);
  }
  $('layer-table').tBodies[0].append(row);
}

function showResults(report, wallMs) {
  const shown = view.setMatches(report.instancePositions, report.highlightRadius);
  const count = report.instances.length;
  $('match-count').textContent = String(count);
  const more = shown < count ? ` (the best ${shown} are coloured)` : '';
  $('progress-text').textContent = `Done: ${count} match${count === 1 ? '' : 'es'}${more}.`;
  $('total-time').textContent =
    `${report.timings_ms.total.toFixed(0)} ms in the matcher, ${wallMs.toFixed(0)} ms in the worker, ` +
    `${report.threads} thread${report.threads === 1 ? '' : 's'}` +
    (report.gpu ? `, layers on the GPU (${report.gpu.adapter})` : ', CPU only') +
    (report.gpu?.fallback ? `; some went back to the CPU: ${report.gpu.fallback}` : '');
  const list = $('instance-list');
  report.instances.forEach((instance, index) => {
    const item = document.createElement('li');
    const button = document.createElement('button');
    button.type = 'button';
    const score = instance.score === null ? '' : ` · ${(instance.score * 100).toFixed(0)}% fit`;
    button.innerHTML = '<span class="rank"></span><span class="distance"></span><span class="detail"></span>';
    button.querySelector('.rank').textContent = `#${index + 1}`;
    button.querySelector('.distance').textContent = `d ${instance.distance.toFixed(3)}`;
    button.querySelector('.detail').textContent = `${instance.support} pts${score}`;
    button.title = `position ${instance.position.map((v) => v.toFixed(3)).join(', ')}`;
    button.addEventListener('click', () => focusInstance(index));
    item.append(button);
    list.append(item);
  });
  const timings = $('timing-table').tBodies[0];
  for (const [stage, ms] of Object.entries(report.timings_ms)) {
    const row = document.createElement('tr');
    row.innerHTML = '<td></td><td></td>';
    row.cells[0].textContent = stage;
    row.cells[1].textContent = `${ms.toFixed(1)} ms`;
    timings.append(row);
  }
  // The table was filled live; a cascade that ended early is complete too.
  if ($('layer-table').tBodies[0].rows.length !== report.stages.length) {
    $('layer-table').tBodies[0].replaceChildren();
    report.stages.forEach(appendLayerRow);
  }
}

function focusInstance(index) {
  const report = state.report;
  if (!report) return;
  const p = report.instancePositions;
  view.setMatches(p, report.highlightRadius, index);
  view.flyTo([p[3 * index], p[3 * index + 1], p[3 * index + 2]], report.highlightRadius * 7);
  [...$('instance-list').querySelectorAll('button')].forEach((b, i) => b.classList.toggle('focused', i === index));
}

function formatLength(value) {
  if (!Number.isFinite(value)) return '–';
  const digits = value >= 10 ? 1 : value >= 1 ? 2 : 3;
  return value.toPrecision(Math.max(digits, 3)).replace(/(\.\d*?)0+$/, '$1').replace(/\.$/, '');
}

// ---- start: the embedded demo --------------------------------------------

async function fetchFile(path) {
  const response = await fetch(path);
  if (!response.ok) throw new Error(`${path}: HTTP ${response.status}`);
  return { name: path.split('/').pop(), bytes: new Uint8Array(await response.arrayBuffer()) };
}

async function start() {
  showThresholds();
  setTemplateKind('model');
  showWebGpu();
  try {
    showBuild(await matcher.ready());
    const [scene, template] = await Promise.all([fetchFile('/demo/scene.glb'), fetchFile('/demo/template.glb')]);
    if (!(await openScene([{ ...scene, name: 'demo scene.glb' }]))) return;
    state.modelTemplate = { kind: 'model', format: 'glb', name: 'demo mug (template.glb)', bytes: template.bytes };
    $('template-name').textContent = state.modelTemplate.name;
    await runSearch();
  } catch (error) {
    showMessage(`The viewer could not start: ${error.message}`);
    setStatus('error');
  }
}

/** A small handle for tests and the console. */
globalThis.viewer = {
  get status() {
    return state.status;
  },
  get build() {
    return state.build;
  },
  get sceneName() {
    return state.scene?.name ?? null;
  },
  get report() {
    return state.report;
  },
  get selection() {
    return state.selection;
  },
  get lastMessage() {
    return state.lastMessage;
  },
  /** The vertical axis the view orbits around. */
  get up() {
    return view.up;
  },
  /** Matches coloured on the mesh now. */
  get highlighted() {
    return view.highlighted;
  },
  project: (point) => view.project(point),
  /** Hides the message and forgets it. */
  dismissMessage,
  setSelectionRadius,
};

start();
