//! Per-stage timings on every shared scene, the real CAD ones included:
//! load, voxelize, template, every layer of every stage, group, total, and
//! the peak of heap memory during the search.
//!
//! `cargo bench --bench stages` runs each scene `FAST_REJECT_BENCH_RUNS`
//! times (default 3) and prints the fastest run of each, so that figures
//! from a busy machine stay comparable. `cargo bench --bench stages -- NAME`
//! runs the scenes whose names contain NAME. The scenes come from
//! `../shared/scenes` (or `$FAST_REJECT_SHARED/scenes`); the default
//! parameters are used throughout.
//! `FAST_REJECT_BENCH_DESCRIPTOR=curvature` measures the curvature
//! descriptor instead of volume+harmonics, with the cost per candidate of
//! every layer (how it grows with the radius);
//! `FAST_REJECT_BENCH_CURVATURE_SPACING=0.5` adds its sampled first pass.
//! `FAST_REJECT_BENCH_BACKEND=gpu` runs the volume and harmonics layers on
//! a GPU (any adapter, lavapipe included), with the cost per candidate of
//! every layer: how the GPU's time grows with the candidates.

#[path = "../tests/common/mod.rs"]
mod common;

#[cfg(not(all(target_arch = "wasm32", target_os = "unknown")))]
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use fast_reject::mesh::io::load;
use fast_reject::scene::{Scene, SceneOptions};
use fast_reject::search::{DescriptorKind, MatchOptions, MatchReport, search};

/// The system allocator, counting the bytes held and their peak (not in
/// the JavaScript binding's build, which counts with its own).
#[cfg(not(all(target_arch = "wasm32", target_os = "unknown")))]
struct Counting;

static HELD: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

#[cfg(not(all(target_arch = "wasm32", target_os = "unknown")))]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded unchanged to the system allocator.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            let held = HELD.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
            PEAK.fetch_max(held, Ordering::Relaxed);
        }
        p
    }

    unsafe fn dealloc(&self, p: *mut u8, layout: Layout) {
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.dealloc(p, layout) };
        HELD.fetch_sub(layout.size(), Ordering::Relaxed);
    }
}

#[cfg(not(all(target_arch = "wasm32", target_os = "unknown")))]
#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// A scene's fastest run and the peak heap of its runs (MiB).
struct Measured {
    report: MatchReport,
    peak_mib: f64,
    /// GPU submissions and kernels per search.
    submissions: Option<(usize, usize)>,
    /// Milliseconds the fastest run waited for the GPU.
    waited_ms: Option<f64>,
}

/// (scene, true for a selection query); any other folder of the scenes
/// with a `scene.glb`, a `template.glb` and a `truth.json` follows them
/// (a generated scene copied there).
const SCENES: [(&str, bool); 9] = [
    ("zoo-bunny", false),
    ("remeshed-cow", false),
    ("crowd-rocker", false),
    ("select-cow-head", true),
    ("fused-homer", false),
    ("cluttered-bunny", false),
    ("twisted-homer", false),
    ("real-saw-fin", false),
    ("real-saw-roller", false),
];

fn main() {
    let root = common::shared_dir().join("scenes");
    // A run that measured nothing must not look like a run that passed.
    assert!(
        root.exists(),
        "no shared scenes at {}: the benchmark needs ../shared beside the crate, or FAST_REJECT_SHARED",
        root.display()
    );
    let runs: usize = std::env::var("FAST_REJECT_BENCH_RUNS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3)
        .max(1);
    let mut options = MatchOptions::DEFAULT;
    if let Ok(name) = std::env::var("FAST_REJECT_BENCH_DESCRIPTOR") {
        options.descriptor = name.parse().expect("a descriptor name");
    }
    if let Ok(spacing) = std::env::var("FAST_REJECT_BENCH_CURVATURE_SPACING") {
        options.curvature_spacing = spacing.parse().expect("a number");
    }
    let gpu = gpu_from_env();
    let filter: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    println!(
        "descriptor: {}, curvature spacing: {}, threads: {}, layers on: {}, runs per scene: {runs} (fastest shown)\n",
        options.descriptor,
        options.curvature_spacing,
        rayon::current_num_threads(),
        gpu.as_ref().map_or("the CPU".into(), describe),
    );
    let mut summary = Vec::new();
    for (name, select) in scenes(&root) {
        if !filter.is_empty() && !filter.iter().any(|f| name.contains(f.as_str())) {
            continue;
        }
        PEAK.store(HELD.load(Ordering::Relaxed), Ordering::Relaxed);
        let before = gpu.as_ref().map(counters);
        let (best, waited_ms) = (0..runs)
            .map(|_| {
                let waited = gpu.as_ref().map(|g| counters(g).2);
                let report = run(&name, select, &options, gpu.as_ref());
                let waited = gpu.as_ref().zip(waited).map(|(g, w)| counters(g).2 - w);
                (report, waited)
            })
            .min_by(|a, b| a.0.timings.total().total_cmp(&b.0.timings.total()))
            .unwrap();
        let peak_mib = PEAK.load(Ordering::Relaxed) as f64 / (1024.0 * 1024.0);
        let submissions = gpu.as_ref().zip(before).map(|(gpu, (s0, k0, _))| {
            let (s1, k1, _) = counters(gpu);
            ((s1 - s0) / runs, (k1 - k0) / runs)
        });
        print_scene(&name, &best);
        summary.push((
            name,
            Measured {
                report: best,
                peak_mib,
                submissions,
                waited_ms,
            },
        ));
    }
    let curvature = options.descriptor == DescriptorKind::Curvature;
    stage_table(&summary, curvature);
    if curvature || gpu.is_some() {
        per_candidate_table(&summary);
    }
    if gpu.is_some() {
        println!(
            "\n| scene | GPU submissions per search | kernels | match ms | waiting for the GPU ms | host ms (match less waiting) |\n|---|---:|---:|---:|---:|---:|"
        );
        for (name, m) in &summary {
            let (s, k) = m.submissions.unwrap_or_default();
            let (matching, waited) = (m.report.timings.match_, m.waited_ms.unwrap_or_default());
            println!(
                "| {name} | {s} | {k} | {matching:.1} | {waited:.1} | {:.1} |",
                matching - waited
            );
        }
    }
}

/// The shared scenes in [`SCENES`]' order, then the other folders under
/// `root` that hold a scene, a template and a truth, by name.
fn scenes(root: &std::path::Path) -> Vec<(String, bool)> {
    let mut others: Vec<String> = std::fs::read_dir(root)
        .map(|entries| {
            entries
                .filter_map(|e| e.ok())
                .filter(|e| {
                    let dir = e.path();
                    ["scene.glb", "template.glb", "truth.json"]
                        .iter()
                        .all(|f| dir.join(f).is_file())
                })
                .filter_map(|e| e.file_name().into_string().ok())
                .filter(|name| SCENES.iter().all(|(known, _)| known != name))
                .collect()
        })
        .unwrap_or_default();
    others.sort();
    SCENES
        .iter()
        .map(|&(name, select)| (name.to_string(), select))
        .chain(others.into_iter().map(|name| (name, false)))
        .collect()
}

/// One row per scene: candidate points, milliseconds per stage (the
/// scene's preparation is voxelization, or the weld for curvature) and
/// the heap's peak, the scene and its mesh included.
fn stage_table(summary: &[(String, Measured)], curvature: bool) {
    let (points, prepare) = if curvature {
        ("vertices", "weld")
    } else {
        ("skin voxels", "voxelize")
    };
    println!(
        "| scene | {points} | candidates | load | {prepare} | template | match | group | total (ms) | peak heap MiB | instances |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (name, m) in summary {
        let r = &m.report;
        let t = &r.timings;
        let points = (r.grid.as_ref().map(|g| g.skin_voxels))
            .or(r.surface.as_ref().map(|s| s.vertices))
            .unwrap_or(0);
        // Layer 1 of the first stage sees every candidate.
        let candidates: usize = r
            .stages
            .iter()
            .filter(|s| s.layer == 1 && s.descriptor == r.stages[0].descriptor)
            .map(|s| s.candidates)
            .sum();
        println!(
            "| {name} | {points} | {candidates} | {:.0} | {:.0} | {:.0} | {:.0} | {:.0} | {:.0} | {:.0} | {} |",
            t.load,
            t.voxelize + t.surface,
            t.template,
            t.match_,
            t.group,
            t.total(),
            m.peak_mib,
            r.instances.len()
        );
    }
}

/// Microseconds per candidate for each layer of each pass (the sample
/// pass and the final one): how the cost grows with the radius.
fn per_candidate_table(summary: &[(String, Measured)]) {
    let layers = summary
        .iter()
        .flat_map(|(_, m)| m.report.stages.iter().map(|s| s.layer))
        .max()
        .unwrap_or(0);
    print!("\n| scene (us per candidate) | pass |");
    for l in 1..=layers {
        print!(" layer {l} |");
    }
    println!("\n|---|---|{}", "---:|".repeat(layers));
    for (name, m) in summary {
        for pass in m
            .report
            .stages
            .chunk_by(|a, b| a.descriptor == b.descriptor)
        {
            print!("| {name} | {} |", pass[0].descriptor);
            for s in pass {
                print!(" {:.0} |", 1000.0 * s.ms / s.candidates.max(1) as f64);
            }
            println!();
        }
    }
}

fn run(name: &str, select: bool, options: &MatchOptions, gpu: Option<&Gpu>) -> MatchReport {
    let start = std::time::Instant::now();
    let scene_mesh = load(
        &std::fs::read(common::scene_dir(name).join("scene.glb")).unwrap(),
        None,
    )
    .unwrap();
    let source = common::template(name, select);
    let scene = Scene::new(scene_mesh, &SceneOptions::DEFAULT).unwrap();
    let load_ms = start.elapsed().as_secs_f64() * 1e3;
    let mut report = search_on(&scene, &source, options, gpu);
    report.timings.load = load_ms;
    report
}

/// The GPU `FAST_REJECT_BENCH_BACKEND` asks for (cpu or gpu; any
/// adapter).
#[cfg(all(feature = "gpu", not(target_arch = "wasm32")))]
type Gpu = fast_reject::gpu::Gpu;
#[cfg(not(all(feature = "gpu", not(target_arch = "wasm32"))))]
type Gpu = std::convert::Infallible;

fn gpu_from_env() -> Option<Gpu> {
    match std::env::var("FAST_REJECT_BENCH_BACKEND").as_deref() {
        #[cfg(all(feature = "gpu", not(target_arch = "wasm32")))]
        Ok("gpu") => Some(
            Gpu::request(fast_reject::gpu::AdapterChoice::Any)
                .expect("a GPU device")
                .expect("FAST_REJECT_BENCH_BACKEND=gpu: no GPU adapter"),
        ),
        Ok("cpu") | Err(_) => None,
        Ok(other) => panic!("FAST_REJECT_BENCH_BACKEND={other}: cpu, or gpu with the gpu feature"),
    }
}

#[cfg(all(feature = "gpu", not(target_arch = "wasm32")))]
fn describe(gpu: &Gpu) -> String {
    gpu.description()
}

#[cfg(not(all(feature = "gpu", not(target_arch = "wasm32"))))]
fn describe(gpu: &Gpu) -> String {
    match *gpu {}
}

/// Submissions and kernels the GPU has run so far, and the milliseconds
/// searches have waited for it.
#[cfg(all(feature = "gpu", not(target_arch = "wasm32")))]
fn counters(gpu: &Gpu) -> (usize, usize, f64) {
    let (submissions, kernels) = gpu.submissions();
    (submissions, kernels, gpu.waited_ms())
}

#[cfg(not(all(feature = "gpu", not(target_arch = "wasm32"))))]
fn counters(gpu: &Gpu) -> (usize, usize, f64) {
    match *gpu {}
}

fn search_on(
    scene: &Scene,
    source: &fast_reject::TemplateSource,
    options: &MatchOptions,
    gpu: Option<&Gpu>,
) -> MatchReport {
    match gpu {
        #[cfg(all(feature = "gpu", not(target_arch = "wasm32")))]
        Some(gpu) => pollster::block_on(fast_reject::search_on(
            fast_reject::Executor::Device(gpu),
            scene,
            source,
            options,
            &mut (),
        )),
        #[cfg(not(all(feature = "gpu", not(target_arch = "wasm32"))))]
        Some(never) => match *never {},
        None => search(scene, source, options, &mut ()),
    }
    .unwrap()
}

fn print_scene(name: &str, r: &MatchReport) {
    println!("== {name}: {} instance(s)", r.instances.len());
    println!("stage      layer   radius candidates  survivors        ms");
    for s in &r.stages {
        println!(
            "{:<10} {:>5} {:>8.4} {:>10} {:>10} {:>9.1}",
            s.descriptor, s.layer, s.radius, s.candidates, s.survivors, s.ms
        );
    }
    println!();
}
