//! The JavaScript binding (wasm32-unknown-unknown only): handles for a
//! scene and a template, one `match` call with a progress callback, and
//! reports as plain objects with typed arrays.
//!
//! Nothing else in the crate imports wasm-bindgen. The npm package wraps
//! these exports in `js/src/index.js`, which picks the plain or the threaded
//! build; the matching itself is the same rayon code in both (rayon runs on
//! the calling thread in the plain build, on Web Workers in the threaded one).
//!
//! A panic on wasm32 is a trap that leaves the instance unusable, so every
//! input is validated here or by the core and comes back as a JS `Error`
//! carrying the core's message; grids are capped below what the module's
//! memory can hold.

mod heap;
mod options;

use std::ops::ControlFlow;
use std::sync::{Mutex, Once};

use js_sys::{Float64Array, Function, Object, Reflect};
use wasm_bindgen::prelude::*;

use crate::cascade::{LayerStats, Observer, Progress, go_on};
use crate::clock::{now_ms, set_clock};
use crate::error::{Error, FileText, Format};
use crate::exec::Threads;
use crate::mesh::TriMesh;
use crate::mesh::io::{NoResources, load_model_within, load_within, write_glb};
use crate::repeats::{REPEAT_STEPS, find_repeats_observed, instanced_model, split_by_material};
use crate::scene::{Scene, SceneOptions};
use crate::search::{MatchReport, search};
use crate::template::TemplateSource;

use options::memory_limit_bytes;

/// Re-exported so that JavaScript can call `initThreadPool(n)` on the
/// threaded build.
#[cfg(feature = "threads")]
pub use wasm_bindgen_rayon::init_thread_pool;

#[wasm_bindgen]
extern "C" {
    /// The page's or Node's monotonic clock, for stage timings.
    #[wasm_bindgen(js_namespace = performance, js_name = now)]
    fn performance_now() -> f64;
}

/// The last panic's message: the trap that follows a panic carries none, so
/// the JS side asks for it afterwards to explain why the module stopped.
static LAST_PANIC: Mutex<Option<String>> = Mutex::new(None);

/// Installs the clock and the panic hook once, from every entry point that
/// starts work: a `#[wasm_bindgen(start)]` function is not run by every
/// host (wasm-bindgen-test skips it), and without the clock every timing
/// would read 0.
fn ensure_started() {
    static STARTED: Once = Once::new();
    STARTED.call_once(|| {
        set_clock(performance_now);
        std::panic::set_hook(Box::new(|info| {
            if let Ok(mut last) = LAST_PANIC.lock() {
                *last = Some(info.to_string());
            }
        }));
    });
}

/// The message of the panic that trapped the module, if one did.
#[wasm_bindgen(js_name = lastPanicMessage)]
pub fn last_panic_message() -> Option<String> {
    LAST_PANIC.lock().ok().and_then(|last| last.clone())
}

/// Threads rayon runs on: 1 in the plain build, the pool's size once
/// `initThreadPool` has run in the threaded one.
#[wasm_bindgen(js_name = threadCount)]
pub fn thread_count() -> usize {
    #[cfg(feature = "parallel")]
    return rayon::current_num_threads();
    #[cfg(not(feature = "parallel"))]
    1
}

/// Runs `tasks` small pieces of work through the same backend as matching
/// and returns how many distinct threads executed them: the evidence that a
/// threaded build really runs in parallel (a pool that exists but is never
/// used would report 1). Pass a few hundred tasks: the backend hands out
/// chunks of at least 64.
#[wasm_bindgen(js_name = threadsUsed)]
pub fn threads_used(tasks: u32) -> usize {
    let ran_on = crate::exec::Threads::Parallel.map(tasks as usize, |i| {
        // Enough work per task that one thread cannot drain the queue
        // before the others wake up.
        let mut x = i as u64 | 1;
        for _ in 0..50_000 {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
        }
        std::hint::black_box(x);
        current_thread_index()
    });
    let mut threads = ran_on;
    threads.sort_unstable();
    threads.dedup();
    threads.len()
}

fn current_thread_index() -> usize {
    #[cfg(feature = "parallel")]
    return rayon::current_thread_index().unwrap_or(usize::MAX);
    #[cfg(not(feature = "parallel"))]
    usize::MAX
}

/// Bytes of linear memory the module holds now. Memory never shrinks, so
/// after a search this is its peak.
#[wasm_bindgen(js_name = memoryBytes)]
pub fn memory_bytes() -> f64 {
    (core::arch::wasm32::memory_size(0) as f64) * 65536.0
}

/// Bytes of linear memory the module may grow to; grids are capped from it.
#[wasm_bindgen(js_name = memoryLimitBytes)]
pub fn memory_limit() -> f64 {
    memory_limit_bytes() as f64
}

/// Every option's default, `{ scene, match }`, in the names JavaScript
/// uses: the one list the CLI's flags and the viewer's fields come from.
#[wasm_bindgen(js_name = optionDefaults)]
pub fn option_defaults() -> Result<JsValue, JsError> {
    options::defaults()
}

/// Bytes the heap may still grow by: the module's limit less what is live.
/// The JS wrapper refuses input bytes that could not be copied in and
/// parsed within it, since a failed allocation would trap the module.
#[wasm_bindgen(js_name = freeBytes)]
pub fn free_bytes() -> f64 {
    memory_limit_bytes().saturating_sub(heap::live_bytes()) as f64
}

/// The largest mesh the loaders may build here (they refuse more): half
/// of the memory budget.
fn max_mesh_bytes() -> u64 {
    options::memory_budget(0) / 2
}

/// The most bytes loading a file of `len` bytes that starts with `head`
/// (its first 512 bytes, or all of a shorter file) may hold at once, its
/// copy in the module included. The JS wrapper refuses a file over what is
/// free before it is copied in: a failed allocation would trap the module.
#[wasm_bindgen(js_name = peakLoadBytes)]
pub fn peak_load_bytes(head: &[u8], len: f64) -> f64 {
    crate::mesh::io::peak_load_bytes(head, len as u64, max_mesh_bytes()) as f64
}

/// A core error as a JS `Error` with the core's message. Where memory ran
/// short, it says how much the scenes and templates still alive hold: the
/// page may be keeping some it no longer needs.
fn js_error(error: Error) -> JsError {
    let message = error.describe_with(options::js_name);
    match error {
        Error::MeshTooLarge { .. } | Error::OverBudget { .. } | Error::GridTooLarge { .. } => {
            JsError::new(&format!("{message}{}", held_elsewhere()))
        }
        _ => JsError::new(&message),
    }
}

/// The advice [`js_error`] adds to a memory error: what is live of the
/// module's memory, when that is a share worth freeing.
fn held_elsewhere() -> String {
    const MIB: u64 = 1 << 20;
    let (live, limit) = (heap::live_bytes(), memory_limit_bytes());
    if live < limit / 8 {
        return String::new();
    }
    format!(
        " ({} MiB of the module's {} MiB are held now, by the scenes and templates alive \
         and this call's input: free() those no longer needed)",
        live / MIB,
        limit / MIB
    )
}

/// Parses a mesh in the named format (or the one its content shows), with
/// the time it took for the report's `load`.
fn parse_mesh(bytes: &[u8], format: Option<Format>) -> Result<(TriMesh, f64), JsError> {
    ensure_started();
    let start = now_ms();
    let mesh = load_within(bytes, format, &NoResources, max_mesh_bytes()).map_err(js_error)?;
    Ok((mesh, now_ms() - start))
}

/// The parts a mesh file holds twice or more, found without a template:
/// `{families, timingsMs: {load, repeats}}`, each family as `fast-reject
/// repeats --json` writes it (its representative's centre and radius, its
/// triangles and pieces, each copy's `pose`, `residual` and `mirrored`).
/// `options`: `format` (recognized from the content when absent) and
/// `instanced` (`'nodes'` or `'gpu-instancing'`): the scene written as an
/// instanced GLB too, as `glb` (a `Uint8Array`) with `written: {bytes,
/// meshes, nodes, keptCopies}`, as `repeats --out` writes it.
/// `on_progress` is called as each step ends with `{step: "repeat steps",
/// done, total}`; returning `false` from it or throwing cancels.
#[wasm_bindgen(js_name = findRepeats)]
pub fn find_repeats_in(
    bytes: &[u8],
    options: JsValue,
    on_progress: Option<Function>,
) -> Result<JsValue, JsError> {
    let settings = options::RepeatsSettings::from_js(&options)?;
    ensure_started();
    let mut progress = CountedSteps {
        observer: JsObserver {
            on_layer: None,
            on_progress,
            failure: None,
        },
        step: Progress::REPEATS,
        before: 0,
        // Reading, finding, the materials, and writing where asked.
        total: 1 + REPEAT_STEPS + 1 + usize::from(settings.instanced.is_some()),
    };
    let start = now_ms();
    // A model keeps every attribute besides the positions, and its placed
    // mesh is built beside it: a share of what one mesh may take.
    let model = load_model_within(bytes, settings.format, &NoResources, max_mesh_bytes() / 3)
        .map_err(js_error)?;
    let (mesh, sources) = model.placed().map_err(js_error)?;
    let load_ms = now_ms() - start;
    progress.step_done()?;
    let start = now_ms();
    let families = find_repeats_observed(&mesh, Threads::Parallel, &mut progress)
        .map_err(|e| progress.error(e))?;
    progress.before += REPEAT_STEPS;
    let families = split_by_material(&model, &mesh, &sources, families);
    progress.step_done()?;
    let repeats_ms = now_ms() - start;
    let parsed = json_value(&families, "families")?;
    let timings = Object::new();
    set(&timings, "load", &JsValue::from(load_ms));
    set(&timings, "repeats", &JsValue::from(repeats_ms));
    let object = Object::new();
    set(&object, "families", &parsed);
    if let Some(placement) = settings.instanced {
        let start = now_ms();
        let instanced = instanced_model(&model, &mesh, &sources, &families, placement);
        let glb = write_glb(&instanced.model).map_err(js_error)?;
        let nodes: usize = instanced
            .model
            .nodes
            .iter()
            .map(|n| n.placements.len())
            .sum();
        let written = Object::new();
        set(&written, "bytes", &JsValue::from(glb.len() as f64));
        set(
            &written,
            "meshes",
            &JsValue::from(instanced.model.meshes.len() as f64),
        );
        set(&written, "nodes", &JsValue::from(nodes as f64));
        set(
            &written,
            "keptCopies",
            &JsValue::from(instanced.kept_copies as f64),
        );
        set(&object, "written", &written.into());
        set(
            &object,
            "glb",
            &js_sys::Uint8Array::from(glb.as_slice()).into(),
        );
        set(&timings, "write", &JsValue::from(now_ms() - start));
        progress.step_done()?;
    }
    set(&object, "timingsMs", &timings.into());
    Ok(object.into())
}

/// A job's progress as one sequence of `step`: the binding's own steps
/// (reading the file, ...) and the core's, counted on from them.
struct CountedSteps {
    observer: JsObserver,
    step: &'static str,
    /// Steps done before the current one.
    before: usize,
    total: usize,
}

impl CountedSteps {
    /// Tells the page one more step is done.
    fn step_done(&mut self) -> Result<(), JsError> {
        self.before += 1;
        let progress = Progress {
            step: self.step,
            done: self.before,
            total: self.total,
        };
        go_on(self.observer.on_progress(&progress)).map_err(|e| self.error(e))
    }

    /// `error` for the page: a cancel says what the callback threw.
    fn error(&self, error: Error) -> JsError {
        match error {
            Error::Cancelled => cancelled(&self.observer.failure),
            _ => js_error(error),
        }
    }
}

impl Observer for CountedSteps {
    fn on_layer(&mut self, _: &LayerStats) -> ControlFlow<()> {
        ControlFlow::Continue(())
    }

    fn on_progress(&mut self, progress: &Progress) -> ControlFlow<()> {
        self.observer.on_progress(&Progress {
            step: self.step,
            done: self.before + progress.done,
            total: self.total,
        })
    }
}

/// A scene split into its parts, ready to be searched any number of times.
#[wasm_bindgen(js_name = Scene)]
#[derive(Debug)]
pub struct SceneHandle {
    scene: Scene,
    load_ms: f64,
}

#[wasm_bindgen(js_class = Scene)]
impl SceneHandle {
    /// Parses `bytes` (glb/gltf, obj, ply or stl) and prepares it for
    /// searching. `options` is a plain object (see
    /// `options::SceneSettings`): `format` names the format, or it is
    /// recognized from the content, and the core's scene options.
    /// `on_progress` is called as each step ends with `{step: "scene
    /// steps", done, total}` (reading, then the scene's build steps);
    /// returning `false` from it or throwing cancels.
    #[wasm_bindgen(js_name = fromBytes)]
    pub fn from_bytes(
        bytes: &[u8],
        options: JsValue,
        on_progress: Option<Function>,
    ) -> Result<SceneHandle, JsError> {
        let settings = options::SceneSettings::from_js(&options)?;
        let mut progress = CountedSteps {
            observer: JsObserver {
                on_layer: None,
                on_progress,
                failure: None,
            },
            step: Progress::SCENE,
            before: 0,
            total: 1 + Scene::BUILD_STEPS,
        };
        let (mesh, parse_ms) = parse_mesh(bytes, settings.format)?;
        progress.step_done()?;
        // After parsing: the budget is what is free with the mesh in memory.
        let options = settings
            .options
            .with_memory_budget(options::memory_budget(0));
        let start = now_ms();
        let scene =
            Scene::new_observed(mesh, &options, &mut progress).map_err(|e| progress.error(e))?;
        // Splitting the scene into its parts counts as loading it.
        let load_ms = parse_ms + now_ms() - start;
        Ok(SceneHandle { scene, load_ms })
    }

    /// Voxels along the scene's longest side.
    #[wasm_bindgen(getter)]
    pub fn resolution(&self) -> u32 {
        self.scene.resolution()
    }

    /// Edge length of a voxel, in scene units.
    #[wasm_bindgen(getter, js_name = voxelSize)]
    pub fn voxel_size(&self) -> f64 {
        self.scene.voxel_size()
    }

    /// Connected parts of the scene's mesh: the voxel search looks at each
    /// alone.
    #[wasm_bindgen(getter)]
    pub fn parts(&self) -> usize {
        self.scene.parts().len()
    }

    /// Triangles of the scene's mesh.
    #[wasm_bindgen(getter)]
    pub fn triangles(&self) -> usize {
        self.scene.mesh().triangles().len()
    }

    /// Searches the scene for `template`. `options` is a plain object (see
    /// `options::MatchSettings`); `on_layer` is called after every cascade
    /// layer with its statistics, `on_progress` as the parts (windows,
    /// vertices) are worked through with `{step, done, total}`, and
    /// returning `false` from either or throwing cancels the search. A
    /// `resolution` other than the scene's voxelizes it again (and keeps
    /// that grid for the next calls).
    #[wasm_bindgen(js_name = "match")]
    pub fn run_match(
        &mut self,
        template: &TemplateHandle,
        options: JsValue,
        on_layer: Option<Function>,
        on_progress: Option<Function>,
    ) -> Result<JsValue, JsError> {
        let settings = self.settings_for_search(&options)?;
        let mut progress = JsObserver {
            on_layer,
            on_progress,
            failure: None,
        };
        let result = search(
            &self.scene,
            &template.source,
            &settings.options,
            &mut progress,
        );
        self.finish_search(result, progress, template)
    }

    /// What a search for `template` with `options` will take, judged
    /// without running it (see [`crate::search::SearchPlan`]), on the
    /// module's threads; null for the curvature descriptor. A `resolution`
    /// other than the scene's voxelizes it again, as the search would.
    pub fn plan(
        &mut self,
        template: &TemplateHandle,
        options: JsValue,
    ) -> Result<JsValue, JsError> {
        let settings = self.settings_for_search(&options)?;
        match crate::search::plan(&self.scene, &template.source, &settings.options) {
            Ok(Some(plan)) => json_value(&plan, "plan"),
            Ok(None) => Ok(JsValue::NULL),
            Err(error) => Err(js_error(error)),
        }
    }

    /// [`Self::run_match`] with the volume and harmonics layers on the
    /// browser's WebGPU, resolving to the same report; its `gpu` names the
    /// adapter. A page with no adapter, or only a fallback (software)
    /// one unless `allow_software`, searches on the CPU (`gpu` null); a
    /// device that fails on the way hands its layers back to the CPU and
    /// says why in `gpu.fallback`. The same instances either way.
    #[cfg(feature = "gpu")]
    #[wasm_bindgen(js_name = matchGpu)]
    pub async fn run_match_gpu(
        &mut self,
        template: &TemplateHandle,
        options: JsValue,
        on_layer: Option<Function>,
        on_progress: Option<Function>,
        allow_software: bool,
    ) -> Result<JsValue, JsError> {
        let settings = self.settings_for_search(&options)?;
        let mut progress = JsObserver {
            on_layer,
            on_progress,
            failure: None,
        };
        let gpu = gpu::shared(allow_software).await;
        let result = match gpu.as_deref() {
            Some(gpu) => {
                crate::search::search_on(
                    crate::search::Executor::Device(gpu),
                    &self.scene,
                    &template.source,
                    &settings.options,
                    &mut progress,
                )
                .await
            }
            None => search(
                &self.scene,
                &template.source,
                &settings.options,
                &mut progress,
            ),
        };
        self.finish_search(result, progress, template)
    }
}

impl SceneHandle {
    /// The search's settings from the JS `options`, with the scene
    /// voxelized again for another resolution and its budget set to what
    /// is free.
    fn settings_for_search(
        &mut self,
        options: &JsValue,
    ) -> Result<options::MatchSettings, JsError> {
        ensure_started();
        let settings = options::MatchSettings::from_js(options)?;
        if let Some(resolution) = settings.resolution
            && resolution != self.scene.resolution()
        {
            // On failure (a grid too large) the scene at the old resolution
            // stays, so the handle remains usable.
            let options = SceneOptions::DEFAULT
                .with_resolution(resolution)
                .with_memory_budget(options::memory_budget(0));
            self.scene = Scene::new(self.scene.mesh().clone(), &options).map_err(js_error)?;
        }
        // Whatever else the page holds (other scenes, templates) is live
        // heap: the search may use only what is free, besides what the
        // scene has built already.
        let budget = options::memory_budget(self.scene.built_bytes());
        self.scene.set_memory_budget(budget);
        Ok(settings)
    }

    /// The report as a JS object, or the error that says why there is none.
    fn finish_search(
        &self,
        result: crate::Result<crate::MatchReport>,
        progress: JsObserver,
        template: &TemplateHandle,
    ) -> Result<JsValue, JsError> {
        let mut report = match result {
            Ok(report) => report,
            Err(Error::Cancelled) => return Err(cancelled(&progress.failure)),
            Err(error) => return Err(js_error(error)),
        };
        report.timings.load = self.load_ms + template.load_ms;
        report_to_js(&report)
    }
}

/// The page's GPU, asked for once.
#[cfg(feature = "gpu")]
mod gpu {
    use std::cell::RefCell;
    use std::rc::Rc;

    use crate::gpu::{AdapterChoice, Gpu};

    thread_local! {
        /// Per choice of adapters (hardware only, any): the device, or
        /// none when the page has no such adapter or it failed.
        static SHARED: RefCell<[Option<Option<Rc<Gpu>>>; 2]> = const { RefCell::new([None, None]) };
    }

    /// The GPU for a search: a hardware adapter's, or any adapter's with
    /// `allow_software`; `None` when there is none (the search runs on
    /// the CPU).
    pub(super) async fn shared(allow_software: bool) -> Option<Rc<Gpu>> {
        let slot = usize::from(allow_software);
        if let Some(known) = SHARED.with(|s| s.borrow()[slot].clone()) {
            return known;
        }
        let choice = if allow_software {
            AdapterChoice::Any
        } else {
            AdapterChoice::Hardware
        };
        let gpu = Gpu::request_async(choice).await.ok().flatten().map(Rc::new);
        SHARED.with(|s| s.borrow_mut()[slot] = Some(gpu.clone()));
        gpu
    }
}

/// What to look for.
#[wasm_bindgen(js_name = Template)]
#[derive(Debug)]
pub struct TemplateHandle {
    source: TemplateSource,
    load_ms: f64,
}

#[wasm_bindgen(js_class = Template)]
impl TemplateHandle {
    /// A separate model from bytes (same formats as a scene); `options` may
    /// name the `format`.
    #[wasm_bindgen(js_name = fromBytes)]
    pub fn from_bytes(bytes: &[u8], options: JsValue) -> Result<TemplateHandle, JsError> {
        let format = options::format_only("template", &options)?;
        let (mesh, load_ms) = parse_mesh(bytes, format)?;
        Ok(TemplateHandle {
            source: TemplateSource::Model(mesh),
            load_ms,
        })
    }

    /// The part of the scene inside a sphere (scene coordinates).
    #[wasm_bindgen(js_name = fromSelection)]
    pub fn from_selection(x: f64, y: f64, z: f64, radius: f64) -> Result<TemplateHandle, JsError> {
        let center = [x, y, z];
        if !(center.iter().all(|c| c.is_finite()) && radius.is_finite() && radius > 0.0) {
            return Err(JsError::new(&format!(
                "invalid selection: the sphere needs a finite centre and a positive radius, got {center:?} and {radius}"
            )));
        }
        Ok(TemplateHandle {
            source: TemplateSource::Selection { center, radius },
            load_ms: 0.0,
        })
    }

    /// Whether this is a selection sphere rather than a model.
    #[wasm_bindgen(getter, js_name = isSelection)]
    pub fn is_selection(&self) -> bool {
        matches!(self.source, TemplateSource::Selection { .. })
    }
}

/// Forwards layer statistics and progress to JS callbacks; `false` or a
/// throw from either cancels.
struct JsObserver {
    on_layer: Option<Function>,
    on_progress: Option<Function>,
    failure: Option<String>,
}

impl Observer for JsObserver {
    fn on_layer(&mut self, stats: &LayerStats) -> ControlFlow<()> {
        tell(&mut self.failure, self.on_layer.as_ref(), || {
            layer_to_js(stats)
        })
    }

    fn on_progress(&mut self, progress: &Progress) -> ControlFlow<()> {
        tell(&mut self.failure, self.on_progress.as_ref(), || {
            progress_to_js(progress)
        })
    }
}

/// A cancel for the page, saying what the callback threw (`failure`) if it
/// threw.
fn cancelled(failure: &Option<String>) -> JsError {
    JsError::new(&match failure {
        Some(why) => format!("{}: the progress callback threw: {why}", Error::Cancelled),
        None => Error::Cancelled.to_string(),
    })
}

/// Calls `callback` with `value`: a `Break` when it answers `false` or
/// throws, the thrown text kept in `failure` (escaped like the core's
/// quotes).
fn tell(
    failure: &mut Option<String>,
    callback: Option<&Function>,
    value: impl FnOnce() -> JsValue,
) -> ControlFlow<()> {
    let Some(callback) = callback else {
        return ControlFlow::Continue(());
    };
    match callback.call1(&JsValue::NULL, &value()) {
        Ok(answer) if answer == JsValue::FALSE => ControlFlow::Break(()),
        Ok(_) => ControlFlow::Continue(()),
        Err(thrown) => {
            *failure = Some(FileText::new(&describe_js(&thrown)).to_string());
            ControlFlow::Break(())
        }
    }
}

/// A thrown JS value in words (an Error's message, or its string form).
fn describe_js(value: &JsValue) -> String {
    if let Some(error) = value.dyn_ref::<js_sys::Error>() {
        return String::from(error.message());
    }
    value.as_string().unwrap_or_else(|| format!("{value:?}"))
}

fn set(target: &Object, key: &str, value: &JsValue) {
    // Setting a data property on a fresh plain object cannot fail.
    let _ = Reflect::set(target, &JsValue::from_str(key), value);
}

/// A layer's statistics as a plain object (the CLI JSON's field names).
fn layer_to_js(stats: &LayerStats) -> JsValue {
    let object = Object::new();
    set(&object, "descriptor", &JsValue::from_str(stats.descriptor));
    set(&object, "layer", &JsValue::from(stats.layer as f64));
    set(&object, "radius", &JsValue::from(stats.radius));
    set(
        &object,
        "candidates",
        &JsValue::from(stats.candidates as f64),
    );
    set(&object, "survivors", &JsValue::from(stats.survivors as f64));
    set(&object, "ms", &JsValue::from(stats.ms));
    object.into()
}

/// How far the search has come, as a plain object: `step` ("parts",
/// "windows", "candidates" or "surface steps"), `done` and `total`.
fn progress_to_js(progress: &Progress) -> JsValue {
    let object = Object::new();
    set(&object, "step", &JsValue::from_str(progress.step));
    set(&object, "done", &JsValue::from(progress.done as f64));
    set(&object, "total", &JsValue::from(progress.total as f64));
    object.into()
}

/// `value` as plain JS data in the CLI's JSON shape (snake_case keys).
fn json_value(value: &impl serde::Serialize, what: &str) -> Result<JsValue, JsError> {
    let text = serde_json::to_string(value)
        .map_err(|e| JsError::new(&format!("cannot encode the {what}: {e}")))?;
    js_sys::JSON::parse(&text)
        .map_err(|e| JsError::new(&format!("cannot decode the {what}: {}", describe_js(&e))))
}

/// The report as a plain object in the CLI's JSON shape, plus typed arrays
/// for drawing: `instancePositions` (x, y, z per instance, best first) and
/// `highlightRadius` (r_k: the ball each instance occupies).
fn report_to_js(report: &MatchReport) -> Result<JsValue, JsError> {
    let object: Object = json_value(report, "report")?.unchecked_into();
    let positions: Vec<f64> = report.instances.iter().flat_map(|i| i.position).collect();
    set(
        &object,
        "instancePositions",
        &Float64Array::from(positions.as_slice()).into(),
    );
    set(
        &object,
        "highlightRadius",
        &JsValue::from(report.template.radius),
    );
    set(&object, "threads", &JsValue::from(thread_count() as f64));
    Ok(object.into())
}
