// The viewer page: wires files, the 3D view, the package's search worker
// (fast-reject/worker) and the panel. It opens on the embedded demo (a scene
// and a template served from /demo/) and searches it at once.
import { CancelledError, SearchWorker } from '/pkg/worker.js';

import { FileProblem, readModel } from './files.js';
import { View, parseModel, renderPreview } from './view.js';

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
  /** The running or last search's progress: {step, done, total}, or null. */
  progress: null,
  build: null,
  /** Whether the option fields were set from the core's defaults. */
  defaultsApplied: false,
  /**
   * 'starting' | 'loading' | 'ready' | 'searching' | 'asked' (a long search
   * waits for a yes) | 'done' | 'cancelled' | 'error' (also on <body data-status>).
   */
  status: 'starting',
  /** The last message shown to the user (tests wait on it). */
  lastMessage: null,
  /** The scene's repeated parts, as `findRepeats` gave them with the instanced file, or null. */
  repeats: null,
  /** Their finding's last progress, `{done, total}` steps, or null. */
  repeatsProgress: null,
  /** A search with more than this many seconds left is announced, with a Cancel. */
  longSearchSeconds: 30,
  /** The text of the running search's long-search notice, if one was shown. */
  longNotice: null,
};

const view = new View($('viewport'), {
  onPick: (point) => pickPoint(point),
  onFocus: (point) => focusPoint(point),
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

/** Shows a message; `action` ({label, run}) adds a button that does what it suggests. */
function showMessage(text, kind = 'error', action = null) {
  state.lastMessage = text;
  $('message-text').textContent = text;
  $('message').className = kind;
  $('message').hidden = false;
  const button = $('message-action');
  button.hidden = !action;
  button.textContent = action?.label ?? '';
  button.onclick = action
    ? () => {
        dismissMessage();
        action.run();
      }
    : null;
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
    const why = info.fallback ? 'the thread pool did not start' : globalThis.crossOriginIsolated ? 'one core' : 'not cross-origin isolated';
    badge.textContent = `single-threaded (${why})`;
    badge.title = info.fallback ?? '';
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
    if (state.running) {
      cancelSearch();
      restore = 'cancelled';
    }
    // The package reads it first: its checks say what is wrong with a file
    // in words; three.js's would be its internals.
    $('progress-text').textContent = `Loading ${model.name} into the matcher…`;
    $('progress-bar').value = 0;
    // Reading the file, then splitting it into parts: seconds on a whole
    // building, so the bar follows the steps.
    const onProgress = ({ done, total }) => {
      $('progress-bar').value = Math.min(done / total, 1);
      $('progress-text').textContent = `Loading ${model.name} into the matcher: ${SCENE_STEPS[done - 1] ?? 'step ' + done} done (${done} of ${total})`;
    };
    await matcher.loadScene(model.bytes, { format: model.format }, { onProgress });
    $('progress-text').textContent = `Reading ${model.name} for the view…`;
    try {
      object = await parseModel(model);
    } catch (error) {
      // The worker holds the new scene now: give it back the old one.
      if (state.scene) await matcher.loadScene(state.scene.bytes, { format: state.scene.format });
      throw error;
    }
  } catch (error) {
    object?.traverse((node) => node.geometry?.dispose());
    const message = error instanceof FileProblem ? error.message : `Could not open ${model?.name ?? 'the file'}: ${sentence(error.message)}`;
    showMessage(`${message} The current scene is unchanged.`);
    $('progress-text').textContent = '\u00a0';
    setStatus(restore);
    return false;
  }
  state.generation += 1;
  state.scene = model;
  state.selection = null;
  state.report = null;
  // The demo's mug means nothing in another scene; a template the user
  // opened is kept.
  if (state.modelTemplate?.demo) setModelTemplate(null);
  view.setModel(object, upAxisFor(object));
  showUpAxis();
  $('scene-name').textContent = `${model.name}`;
  dismissMessage();
  clearResults();
  clearRepeats();
  setSelectionRadius(sliderRadius());
  $('progress-text').textContent = '\u00a0';
  setStatus('ready');
  return true;
}

/**
 * Opens a template file. Both the package and three.js read it before it
 * replaces the current template, so a broken file keeps the one that works.
 */
async function openTemplate(files) {
  let model;
  let object;
  try {
    model = await readModel(files);
    await matcher.checkTemplate(model);
    object = await parseModel(model);
  } catch (error) {
    const message = error instanceof FileProblem ? error.message : `Could not open ${model?.name ?? 'the template'}: ${sentence(error.message)}`;
    const kept = state.modelTemplate ? ` The template is still ${state.modelTemplate.name}.` : '';
    showMessage(message + kept);
    return false;
  }
  setModelTemplate({ kind: 'model', ...model, object });
  dismissMessage();
  setTemplateKind('model');
  await runSearch();
  return true;
}

/** Shows `template` ({kind: 'model', name, format, bytes, object}, or null) as the file template. */
function setModelTemplate(template) {
  state.modelTemplate = template;
  $('template-name').textContent = template?.name ?? 'none';
  view.setTemplate(template?.object ?? null);
  $('template-preview').hidden = !template;
  if (template) renderPreview($('template-preview'), template.object, view.up);
}

/** A message from a library as a sentence: capitalized, with a full stop. */
function sentence(text) {
  const trimmed = String(text).trim();
  return /[.!?]$/.test(trimmed) ? trimmed : `${trimmed}.`;
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
/** Which half of the view a drop at `event` lands on: the left takes a scene, the right a template. */
function dropTarget(event) {
  const rect = viewport.getBoundingClientRect();
  return event.clientX > rect.left + rect.width / 2 ? 'template' : 'scene';
}
viewport.addEventListener('dragover', (event) => {
  const target = dropTarget(event);
  $('drop-scene').classList.toggle('target', target === 'scene');
  $('drop-template').classList.toggle('target', target === 'template');
});
viewport.addEventListener('drop', async (event) => {
  event.preventDefault();
  dragDepth = 0;
  $('drop-overlay').hidden = true;
  const files = [...event.dataTransfer.files];
  if (dropTarget(event) === 'template') await openTemplate(files);
  else await openScene(files);
});

// ---- view tools: fit, x-ray, isolate, cut-away, markers, keys ------------------

$('fit-button').addEventListener('click', () => view.frame());
/** The check boxes that switch a view mode, with the key that toggles each. */
const VIEW_MODES = [
  { box: 'xray', key: 'x', set: (on) => (view.xray = on) },
  { box: 'isolate', key: 'i', set: (on) => (view.isolate = on) },
  { box: 'cutaway', key: 'c', set: (on) => (view.cutaway = on) },
  { box: 'markers', key: 'm', set: (on) => (view.markersVisible = on) },
];
for (const mode of VIEW_MODES) $(mode.box).addEventListener('change', () => mode.set($(mode.box).checked));
window.addEventListener('keydown', (event) => {
  // Keys typed into a field are the field's.
  if (event.target.closest?.('input, select, textarea') || event.ctrlKey || event.metaKey || event.altKey) return;
  const mode = VIEW_MODES.find((m) => m.key === event.key.toLowerCase());
  if (event.key === 'f' || event.key === 'F' || event.key === 'Home') {
    view.frame();
  } else if (mode) {
    $(mode.box).checked = !$(mode.box).checked;
    mode.set($(mode.box).checked);
  } else if (event.key === 'Escape' && state.running) {
    cancelSearch();
  } else {
    return;
  }
  event.preventDefault();
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
  $('selection-mouse-hints').hidden = kind !== 'selection';
  view.setSelection(kind === 'selection' ? state.selection : null);
}
for (const input of document.querySelectorAll('input[name="template-kind"]')) {
  input.addEventListener('change', () => {
    setTemplateKind(templateKind());
    markStale();
  });
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
    markStale();
  }
  $('radius-value').textContent = formatLength(radius);
  $('radius-slider').value = String(Math.round((Math.log(radius / low) / Math.log(high / low)) * 1000));
}

$('radius-slider').addEventListener('input', () => setSelectionRadius(sliderRadius()));

/**
 * A click on the surface: places the selection sphere, in selection mode
 * only (a click in model mode must not change what is searched for).
 */
function pickPoint(point) {
  if (templateKind() !== 'selection') {
    $('progress-text').textContent = 'Choose "Selection sphere" to pick a part of the scene with a click.';
    return;
  }
  state.selectionBeforeClick = { selection: state.selection, stale: !$('results-stale').hidden, at: performance.now() };
  placeSelection(point);
}

/** A double-click: the view turns to the point; the sphere goes back to where it was before the double-click's first click. */
function focusPoint(point) {
  const before = state.selectionBeforeClick;
  if (templateKind() === 'selection' && before && performance.now() - before.at < 800) {
    state.selection = before.selection;
    view.setSelection(state.selection);
    showSelectionHint();
    $('results-stale').hidden = !before.stale;
  }
  state.selectionBeforeClick = null;
  view.flyTo(point, view.distanceToTarget());
}

function placeSelection(point) {
  state.selection = { center: point, radius: state.selection?.radius ?? sliderRadius() };
  view.setSelection(state.selection);
  $('radius-value').textContent = formatLength(state.selection.radius);
  showSelectionHint();
  markStale();
}

function showSelectionHint() {
  const point = state.selection?.center;
  $('selection-hint').textContent = point
    ? `Sphere at (${point.map((v) => v.toFixed(3)).join(', ')}). Search to find every part like it.`
    : 'Click the surface to place the sphere; Shift + wheel or the slider sets its radius.';
}

/** The matches shown were found for another template: say so until the next search. */
function markStale() {
  if (!state.report || state.running) return;
  $('results-stale').hidden = false;
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

/** Boxes that judge an instance by its pose, which the curvature search does not find. */
const POSE_OPTIONS = { wholeCopies: 'whole-copies', keepNearTwins: 'keep-near-twins' };

function searchOptions() {
  const options = { descriptor: descriptor(), resolution: Number($('resolution').value) };
  const thresholds = {
    volumeThreshold: 'volume-threshold',
    harmonicsThreshold: 'harmonics-threshold',
    curvatureThreshold: 'curvature-threshold',
    curvatureSpacing: 'curvature-spacing',
  };
  // Only the boxes of the stages that run: the export lists what applied.
  const stages = options.descriptor.split('+');
  for (const [key, id] of Object.entries(thresholds)) {
    if (!stages.includes($(id).dataset.for)) continue;
    const value = Number($(id).value);
    if ($(id).value !== '' && Number.isFinite(value)) options[key] = value;
  }
  if (options.descriptor !== 'curvature') {
    for (const [key, id] of Object.entries(POSE_OPTIONS)) if ($(id).checked) options[key] = true;
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
  // The curvature search finds no pose: no whole copy, no near twin.
  for (const id of Object.values(POSE_OPTIONS)) $(id).disabled = descriptor() === 'curvature';
}

/**
 * Searches the scene for the current template. A search judged to take
 * longer than `longSearchSeconds` first asks (`approved` skips the
 * question: the person said yes).
 */
async function runSearch({ approved = false } = {}) {
  if (!state.scene) {
    showMessage('Open a scene first.', 'info');
    return;
  }
  const template = currentTemplate();
  if (!template) return;
  if (state.running) cancelSearch();
  const generation = ++state.generation;
  const options = searchOptions();
  state.lastOptions = options;
  state.lastTemplate = template;
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
  const start = performance.now();
  // The elapsed time ticks while a step takes long (preparing, one layer).
  let step = $('progress-text').textContent;
  const showStep = (text) => {
    step = text;
    $('progress-text').textContent = `${text} (${((performance.now() - start) / 1000).toFixed(1)} s)`;
  };
  const ticker = setInterval(() => {
    if (generation === state.generation) showStep(step);
  }, 250);
  // With several parts (windows, vertex rounds) the bar follows them, and
  // the time left is read from their pace; with one, it follows the layers.
  const firstSeen = new Map();
  state.longNotice = null;
  state.progress = null;
  try {
    if (!approved && options.descriptor !== 'curvature') {
      const preparing = step;
      showStep('Preparing: judging the size of the search');
      const plan = await matcher.plan(template, options);
      if (generation !== state.generation) return;
      if (plan && plan.leastSeconds > state.longSearchSeconds) {
        askBeforeSearching(plan);
        return;
      }
      showStep(preparing);
    }
    const onLayer = (stats) => {
      if (generation !== state.generation) return;
      layers.push(stats);
      addLayerRow(stats);
      if (firstSeen.size > 0) return;
      $('progress-bar').value = Math.min(layers.length / expectedLayers, 1);
      showStep(
        `${stats.descriptor} layer ${stats.layer} of 6 (r = ${formatLength(stats.radius)}): ` +
          `${stats.survivors.toLocaleString()} of ${stats.candidates.toLocaleString()} candidates survive`,
      );
    };
    const onProgress = ({ step: what, done, total }) => {
      if (generation !== state.generation) return;
      state.progress = { step: what, done, total };
      if (total < 2) return;
      // The weld before a curvature search: told, but the bar is the
      // vertices' (it would otherwise fill twice).
      if (what === 'surface steps') {
        showStep(`Welding the mesh for the curvature search: step ${done} of ${total}`);
        return;
      }
      const now = performance.now();
      if (!firstSeen.has(what)) firstSeen.set(what, { done, at: now });
      const first = firstSeen.get(what);
      $('progress-bar').value = Math.min(done / total, 1);
      const pace = done > first.done ? (now - first.at) / (done - first.done) : null;
      const left = pace && done < total ? `, about ${formatSeconds((pace * (total - done)) / 1000)} left` : '';
      // Said once, as soon as the pace is known: a sphere placed by
      // mistake on a whole building would otherwise run for minutes.
      const secondsLeft = pace ? (pace * (total - done)) / 1000 : 0;
      const longNow = !approved && !state.longNotice && now - first.at >= LONG_SEARCH_PACE_MS;
      if (longNow && secondsLeft > state.longSearchSeconds) {
        state.longNotice =
          `This search will take about ${formatSeconds(secondsLeft)} more: ${(total - done).toLocaleString()} ` +
          `${PROGRESS_WORDS[what] ?? what} of the scene are left to search. A smaller sphere, or a template of ` +
          'fewer parts, searches less.';
        showMessage(state.longNotice, 'info', { label: 'Cancel the search', run: cancelSearch });
      }
      showStep(`Searched ${done.toLocaleString()} of ${total.toLocaleString()} ${PROGRESS_WORDS[what] ?? what}${left}`);
    };
    const report = await matcher.match(template, options, { onLayer, onProgress });
    if (generation !== state.generation) return;
    dismissLongNotice();
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
      // A template too small for the grid: the message says what resolution
      // it needs, and one click searches at it.
      const needed = /raise the resolution to at least (\d+)/.exec(error.message)?.[1];
      const action = needed && {
        label: `Search at ${needed}`,
        run: () => {
          $('resolution').value = needed;
          runSearch();
        },
      };
      showMessage(error.message, 'error', action);
      setStatus('error');
    }
  } finally {
    clearInterval(ticker);
    if (generation === state.generation) {
      state.running = false;
      $('cancel-button').disabled = true;
    }
  }
}

/**
 * Says that the search `plan` judged will take long, and starts it only
 * when the person says yes: a sphere dropped on a whole building by
 * mistake would otherwise run for minutes before they learn of it.
 */
function askBeforeSearching(plan) {
  const copies = plan.parts - plan.distinctParts;
  const copied = copies > 0 ? ` (${copies.toLocaleString()} more copy one of them and are not searched again)` : '';
  $('progress-text').textContent = 'Not started: the search waits for a yes.';
  setStatus('asked');
  showMessage(
    `This search will take about ${formatSeconds(plan.leastSeconds)} or more: ` +
      `${plan.distinctParts.toLocaleString()} different parts of the scene are large enough to hold the template${copied}, ` +
      'and each is searched on its own. A smaller sphere, or a template of fewer parts, searches less.',
    'info',
    { label: 'Search anyway', run: () => runSearch({ approved: true }) },
  );
}

/** How long the pace is watched before the time left is trusted. */
const LONG_SEARCH_PACE_MS = 1500;

/** What each of the scene load's steps ('scene steps') did, in order. */
const SCENE_STEPS = ['reading the file', 'checking the voxel work', 'finding the connected parts', 'measuring the parts', 'checking the memory'];

/** What a progress step counts, in the viewer's words. */
const PROGRESS_WORDS = { parts: 'parts', windows: 'windows of a large part', candidates: 'vertices' };

/** A duration for "about … left": whole seconds, minutes past two. */
function formatSeconds(seconds) {
  return seconds < 120 ? `${Math.max(1, Math.round(seconds))} s` : `${Math.round(seconds / 60)} min`;
}

/** The notice of a long search is stale once it ends. */
function dismissLongNotice() {
  if (state.longNotice && state.lastMessage === state.longNotice) dismissMessage();
  state.longNotice = null;
}

function cancelSearch() {
  if (!state.running) return;
  dismissLongNotice();
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
for (const id of ['resolution', 'volume-threshold', 'harmonics-threshold', 'curvature-threshold', 'curvature-spacing', ...Object.values(POSE_OPTIONS)]) {
  $(id).addEventListener('change', rerunSoon);
}

// ---- results -------------------------------------------------------------

// ---- repeated parts -----------------------------------------------------

/** Finds the scene's repeated parts in the worker, with the instanced file. */
async function findRepeatedParts() {
  const scene = state.scene;
  if (!scene) return;
  const generation = state.generation;
  $('repeats-button').disabled = true;
  $('repeats-summary').textContent = `Finding the parts ${scene.name} repeats…`;
  try {
    const started = performance.now();
    const onProgress = ({ done, total }) => {
      if (generation !== state.generation) return;
      state.repeatsProgress = { done, total };
      $('repeats-summary').textContent = `Finding the parts ${scene.name} repeats… ${Math.round((100 * done) / total)}%`;
    };
    state.repeatsProgress = null;
    const report = await matcher.findRepeats(scene.bytes, { format: scene.format, instanced: 'nodes' }, { onProgress });
    if (generation !== state.generation) return;
    state.repeats = report;
    showRepeats(report, scene, performance.now() - started);
  } catch (error) {
    if (generation !== state.generation || error instanceof CancelledError) return;
    $('repeats-summary').textContent = '';
    showMessage(`Could not find the repeated parts: ${sentence(error.message)}`);
  } finally {
    $('repeats-button').disabled = false;
  }
}

function showRepeats(report, scene, wallMs) {
  const families = report.families;
  const copies = families.reduce((sum, f) => sum + f.copies.length, 0);
  $('repeat-count').textContent = String(families.length);
  const size = (bytes) => `${(bytes / 1e6).toFixed(bytes < 1e6 ? 2 : 1)} MB`;
  $('repeats-summary').textContent = families.length === 0
    ? `No part repeats (${(wallMs / 1000).toFixed(2)} s).`
    : `${families.length} part${families.length === 1 ? '' : 's'} repeat${families.length === 1 ? 's' : ''}, ${copies} copies in all `
      + `(${(wallMs / 1000).toFixed(2)} s). The instanced file: ${size(report.written.bytes)}, from ${size(scene.bytes.length)}. `
      + 'Click a part to light up every copy.';
  $('save-instanced-button').disabled = families.length === 0;
  const list = $('family-list');
  list.replaceChildren();
  families.forEach((family, index) => {
    const item = document.createElement('li');
    const button = document.createElement('button');
    button.type = 'button';
    const mirrored = family.copies.filter((c) => c.mirrored).length;
    button.textContent = `${family.copies.length} copies × ${family.triangles} triangles`
      + (mirrored ? ` (${mirrored} mirrored)` : '') + ` · radius ${formatLength(family.radius)}`;
    button.addEventListener('click', () => showFamily(index));
    item.append(button);
    list.append(item);
  });
}

/** Lights up every copy of family `index`: its centre moved by each pose, in a ball of its radius. */
function showFamily(index) {
  const family = state.repeats?.families[index];
  if (!family) return;
  const [x, y, z] = family.center;
  const points = new Float64Array(family.copies.flatMap(({ pose: m }) => [0, 1, 2].map((r) => m[r][0] * x + m[r][1] * y + m[r][2] * z + m[r][3])));
  view.setGhosts([]);
  view.setMatchPoses([]);
  view.setMatches(points, family.radius);
  [...$('family-list').querySelectorAll('button')].forEach((b, i) => b.classList.toggle('focused', i === index));
}

function saveInstanced() {
  const glb = state.repeats?.glb;
  if (!glb) return;
  const link = document.createElement('a');
  link.href = URL.createObjectURL(new Blob([glb], { type: 'model/gltf-binary' }));
  link.download = `${(state.scene?.name ?? 'scene').replace(/\.[^.]+$/, '')}-instanced.glb`;
  link.click();
  setTimeout(() => URL.revokeObjectURL(link.href), 1000);
}
$('repeats-button').addEventListener('click', () => findRepeatedParts());
$('save-instanced-button').addEventListener('click', saveInstanced);

function clearRepeats() {
  state.repeats = null;
  $('repeat-count').textContent = '';
  $('repeats-summary').textContent = '';
  $('family-list').replaceChildren();
  $('save-instanced-button').disabled = true;
}

function clearResults() {
  $('results-stale').hidden = true;
  $('results-legend').hidden = true;
  $('export-button').disabled = true;
  view.setGhosts([]);
  view.setMatches(new Float64Array(), 0);
  view.setMatchPoses([]);
  $('progress-bar').value = 0;
  $('instance-list').replaceChildren();
  $('layer-table').tBodies[0].replaceChildren();
  $('timing-table').tBodies[0].replaceChildren();
  $('match-count').textContent = '';
  $('total-time').textContent = '';
}

/**
 * Adds a layer's figures to the table: one row per layer, summed over the
 * parts and windows that ran it, as a scene of many parts runs each layer
 * hundreds of times.
 */
function addLayerRow(stats) {
  const body = $('layer-table').tBodies[0];
  const key = `${stats.descriptor} ${stats.layer}`;
  let row = [...body.rows].find((r) => r.dataset.key === key);
  if (!row) {
    row = document.createElement('tr');
    row.dataset.key = key;
    row.dataset.candidates = '0';
    row.dataset.survivors = '0';
    row.dataset.ms = '0';
    for (let i = 0; i < 5; i++) row.append(document.createElement('td'));
    row.cells[0].textContent = key;
    row.cells[1].textContent = formatLength(stats.radius);
    body.append(row);
  }
  for (const [field, cell] of [['candidates', 2], ['survivors', 3], ['ms', 4]]) {
    const sum = Number(row.dataset[field]) + stats[field];
    row.dataset[field] = String(sum);
    row.cells[cell].textContent = field === 'ms' ? sum.toFixed(1) : sum.toLocaleString();
  }
}

function showResults(report, wallMs) {
  const shown = view.setMatches(report.instancePositions, report.highlightRadius);
  const count = report.instances.length;
  $('match-count').textContent = String(count);
  const more = shown < count ? ` (the best ${shown} are coloured)` : '';
  $('progress-text').textContent = `Done: ${count} match${count === 1 ? '' : 'es'}${more} in ${(wallMs / 1000).toFixed(2)} s.`;
  // The scene was read once, before the first search: its load time is
  // not this search's.
  const searchMs = report.timingsMs.total - report.timingsMs.load;
  $('total-time').textContent =
    `${searchMs.toFixed(0)} ms searching, ${wallMs.toFixed(0)} ms in all, ` +
    `${report.threads} thread${report.threads === 1 ? '' : 's'}` +
    (report.gpu ? `, layers on the GPU (${report.gpu.adapter})` : ', CPU only') +
    (report.gpu?.fallback ? `; some went back to the CPU: ${report.gpu.fallback}` : '');
  // Beside the layer table it explains, not in the default view.
  const order = layerOrderNote(report.stages);
  $('layer-order').textContent = order;
  $('layer-order').hidden = !order;
  showResolutionUsed(report.grid);
  state.names = report.instances.map((instance) => view.nameAt(instance.position));
  const poses = report.instances.map((instance) => instance.pose).filter(Boolean);
  view.setGhosts(templateKind() === 'model' ? poses : []);
  view.setMatchPoses(templateKind() === 'model' ? report.instances.map((instance) => instance.pose ?? null) : []);
  $('results-legend').hidden = count === 0;
  $('export-button').disabled = false;
  const list = $('instance-list');
  report.instances.forEach((instance, index) => {
    const item = document.createElement('li');
    const button = document.createElement('button');
    button.type = 'button';
    button.innerHTML = '<span class="rank"></span><span class="name"></span><span class="distance"></span><span class="detail"></span>';
    button.querySelector('.rank').textContent = `#${index + 1}`;
    button.querySelector('.name').textContent = state.names[index] ?? '';
    const score = instance.score === null ? '' : `score ${formatShare(instance.score)} · `;
    button.querySelector('.distance').textContent = `${score}distance ${instance.distance.toFixed(3)}`;
    const whole = instance.whole === true ? ' · whole copy' : instance.whole === false ? ' · part of a larger whole' : '';
    button.querySelector('.detail').textContent = `support ${instance.support}${whole}`;
    button.title = `position ${instance.position.map((v) => formatLength(v)).join(', ')}`;
    button.addEventListener('click', () => focusInstance(index));
    item.append(button);
    list.append(item);
  });
  const timings = $('timing-table').tBodies[0];
  for (const [stage, ms] of Object.entries(report.timingsMs)) {
    const row = document.createElement('tr');
    row.innerHTML = '<td></td><td></td>';
    row.cells[0].textContent = stage === 'load' ? 'load (once, with the scene)' : stage;
    row.cells[1].textContent = `${ms.toFixed(1)} ms`;
    timings.append(row);
  }
  // The table was filled live; filled again from the report, it holds
  // every layer of a cascade that ended early too.
  $('layer-table').tBodies[0].replaceChildren();
  report.stages.forEach(addLayerRow);
  // The list sits below the search settings: bring it into view.
  $('results').scrollIntoView({ block: 'nearest', behavior: 'smooth' });
}

/**
 * The grid a search used, under the Resolution box when it differs from
 * the box: the search refines the grid for a small template and coarsens
 * it for a large one, and the box alone would say 512 for a grid of 1592.
 */
function showResolutionUsed(grid) {
  const note = $('resolution-used');
  const asked = Number($('resolution').value);
  note.hidden = !grid || grid.resolution === asked;
  if (note.hidden) return;
  const why = grid.resolution > asked ? 'finer, for this small template' : 'coarser, for this large template';
  note.textContent = `This search used ${grid.resolution} (${why}).`;
}

/** A share in 0..1 as a percentage that tells 99.6% from 100%. */
function formatShare(share) {
  const percent = share * 100;
  return `${percent >= 99.95 ? '100' : percent.toFixed(1)}%`;
}

/** Why a stage's layers are not in order of radius, when they are not. */
function layerOrderNote(stages) {
  const seen = new Map();
  for (const { descriptor, layer } of stages) {
    if (!seen.has(descriptor)) seen.set(descriptor, []);
    const layers = seen.get(descriptor);
    if (!layers.includes(layer)) layers.push(layer);
  }
  const shuffled = [...seen].filter(([, layers]) => layers.some((layer, i) => i > 0 && layer < layers[i - 1]));
  if (shuffled.length === 0) return '';
  const names = shuffled.map(([name, layers]) => `${name} (${layers.join(', ')})`).join(' and ');
  return `Layers ran in the order ${names}: all cost the same, so the one that rejects the most candidates goes first; the result does not depend on it.`;
}

/** The report as a file: what was searched, with what, and each match's name. */
function exportReport() {
  const report = state.report;
  if (!report) return;
  const { instancePositions, ...plain } = report;
  void instancePositions;
  const template = state.lastTemplate;
  const document_ = {
    ...plain,
    scene: state.scene?.name ?? null,
    // c_T and r_k as the search found them, and what the person gave.
    template: {
      ...plain.template,
      ...(template?.kind === 'selection' ? { selection: { center: template.center, radius: template.radius } } : { file: template?.name ?? null }),
    },
    // The curvature search reads the mesh, not the grid.
    options: state.lastOptions?.descriptor === 'curvature' ? { ...state.lastOptions, resolution: undefined } : state.lastOptions,
    instances: plain.instances.map((instance, i) => ({ name: state.names?.[i] ?? null, ...instance })),
  };
  const blob = new Blob([JSON.stringify(document_, null, 2)], { type: 'application/json' });
  const link = document.createElement('a');
  link.href = URL.createObjectURL(blob);
  link.download = `${(state.scene?.name ?? 'scene').replace(/\.[^.]+$/, '')}-matches.json`;
  link.click();
  setTimeout(() => URL.revokeObjectURL(link.href), 1000);
}
$('export-button').addEventListener('click', exportReport);
$('show-ghosts').addEventListener('change', () => {
  view.ghostsVisible = $('show-ghosts').checked;
});

function focusInstance(index) {
  const report = state.report;
  if (!report) return;
  const p = report.instancePositions;
  view.setMatches(p, report.highlightRadius, index);
  const hidden = view.flyTo([p[3 * index], p[3 * index + 1], p[3 * index + 2]], report.highlightRadius * 7);
  // A match inside an assembly: what stands in front of it is cut away.
  if (hidden && !view.cutaway) {
    $('cutaway').checked = true;
    view.cutaway = true;
  }
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
    const mug = { kind: 'model', format: 'glb', name: 'demo mug (template.glb)', bytes: template.bytes, demo: true };
    setModelTemplate({ ...mug, object: await parseModel(mug) });
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
  /** The scene's repeated parts, once found: `findRepeats`'s report with the instanced file. */
  get repeats() {
    return state.repeats;
  },
  /** The last finding of repeated parts' progress: `{done, total}` steps, or null. */
  get repeatsProgress() {
    return state.repeatsProgress;
  },
  /** The options the last search was started with. */
  get options() {
    return state.lastOptions ?? null;
  },
  /** The last search's progress as last reported: `{step, done, total}`, or null. */
  get progress() {
    return state.progress;
  },
  /** Searches with more seconds left than this are announced (tests lower it). */
  set longSearchSeconds(seconds) {
    state.longSearchSeconds = seconds;
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
  /** Matches the template model is drawn at. */
  get ghosts() {
    return view.ghostCount;
  },
  get xray() {
    return view.xray;
  },
  get isolate() {
    return view.isolate;
  },
  get cutaway() {
    return view.cutaway;
  },
  /** The colours drawn at scene points, [r, g, b] each (a square of them with `{ spread }`), without ghosts, markers or the sphere. */
  coloursAt: (points, options) => view.coloursAt(points, options),
  /** The camera's distance to the point it orbits (tests check fit and focus with it). */
  get cameraDistance() {
    return view.distanceToTarget();
  },
  /** Whether the camera is still on its way to a double-clicked point. */
  get flying() {
    return view.flying;
  },
  /** Each match's part name, as the list shows it. */
  get names() {
    return state.names ?? [];
  },
  /** The point the camera orbits. */
  get cameraTarget() {
    return view.target;
  },
  project: (point) => view.project(point),
  /** The last timed frames, `{ at, light, ms, triangles }` each (light: drawn while the camera moved). */
  get frameLog() {
    return view.frameLog;
  },
  /** Whether moving frames are drawn light (the model is heavy here), and their triangle budget. */
  get navigation() {
    return view.navigation;
  },
  /** When a model counts as heavy and what its light frames may take (tests lower them): `{ heavyFrameMs, lightFrameMs, minTriangles }`. */
  set navigationLimits(limits) {
    view.navigationLimits = limits;
  },
  /** Whether the view stands still with the whole model drawn. */
  get settled() {
    return view.settled;
  },
  /** Hides the message and forgets it. */
  dismissMessage,
  setSelectionRadius,
};

start();
