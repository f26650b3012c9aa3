//! The GPU backend against the CPU on shared scenes: the same candidates
//! at every layer and the same instances (lavapipe in CI; any adapter).
#![cfg(all(feature = "gpu", not(target_arch = "wasm32")))]

mod common;

use fast_reject::gpu::{AdapterChoice, Gpu};
use fast_reject::search::{Executor, MatchOptions, MatchReport, search, search_on};
use fast_reject::{Scene, SceneOptions};

/// Any adapter, lavapipe included; a machine with none fails, saying what
/// to install. Built with FAST_REJECT_SKIP_GPU=1, the tests that need one
/// are ignored instead (never in CI).
fn gpu() -> Gpu {
    Gpu::request(AdapterChoice::Any)
        .expect("a GPU device")
        .expect(NO_ADAPTER)
}

const NO_ADAPTER: &str = "no GPU adapter: install a Vulkan driver (Debian: mesa-vulkan-drivers) \
     or build the tests with FAST_REJECT_SKIP_GPU=1 to skip them";

/// The search with its voxel layers on `gpu`, waited on.
fn search_gpu(
    scene: &Scene,
    template: &fast_reject::TemplateSource,
    options: &MatchOptions,
    gpu: &Gpu,
) -> fast_reject::Result<MatchReport> {
    let executor = Executor::Device(gpu);
    pollster::block_on(search_on(executor, scene, template, options, &mut ()))
}

fn assert_same_search(name: &str, gpu: &Gpu) {
    let scene: Scene = common::scene(name, &SceneOptions::DEFAULT);
    let template = common::template(name, false);
    let options = MatchOptions::DEFAULT;
    let cpu: MatchReport = search(&scene, &template, &options, &mut ()).unwrap();
    let before = gpu.submissions();
    let on_gpu = search_gpu(&scene, &template, &options, gpu).unwrap();
    let after = gpu.submissions();
    let (submissions, kernels) = (after.0 - before.0, after.1 - before.1);
    let info = on_gpu.gpu.as_ref().expect("the report names the GPU");
    assert_eq!(info.fallback, None, "{name}");
    let counts = |r: &MatchReport| -> Vec<(&str, usize, usize, usize)> {
        r.stages
            .iter()
            .map(|s| (s.descriptor, s.layer, s.candidates, s.survivors))
            .collect()
    };
    assert_eq!(counts(&cpu), counts(&on_gpu), "{name}");
    assert!(counts(&cpu).iter().any(|c| c.0 == "harmonics" && c.2 > 100));
    // Its parts fit the memory budget together: each layer is one
    // submission for all of them (the stats hold one line per layer).
    assert!(
        submissions <= on_gpu.stages.len() && submissions < kernels,
        "{name}: {submissions} submissions for {kernels} kernels"
    );
    assert_eq!(cpu.instances.len(), on_gpu.instances.len(), "{name}");
    for (a, b) in cpu.instances.iter().zip(&on_gpu.instances) {
        // Same survivors, so the same blobs, placements and poses; the
        // final distance differs by f32 rounding only.
        assert_eq!(a.position, b.position, "{name}");
        assert_eq!(a.score, b.score, "{name}");
        assert_eq!(a.pose, b.pose, "{name}");
        assert!((a.distance - b.distance).abs() < 1e-4, "{name}");
    }
    common::assert_finds_everything(name, false, &on_gpu);
}

#[test]
#[cfg_attr(skip_gpu_tests, ignore = "FAST_REJECT_SKIP_GPU=1: needs a GPU adapter")]
fn the_gpu_finds_what_the_cpu_finds() {
    let gpu = gpu();
    // Plain copies among other shapes, and copies with clutter beside them
    // (the guard's excused spheres).
    for name in ["zoo-bunny", "cluttered-bunny"] {
        assert_same_search(name, &gpu);
    }
}

#[test]
#[cfg_attr(skip_gpu_tests, ignore = "FAST_REJECT_SKIP_GPU=1: needs a GPU adapter")]
fn a_device_too_small_for_the_grid_hands_its_layers_back_to_the_cpu() {
    use fast_reject::gpu::wgpu;
    // A device made by the caller, with storage bindings of 64 KiB: no
    // part's grid fits, so every layer goes back to the CPU.
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter =
        pollster::block_on(instance.request_adapter(&Default::default())).expect(NO_ADAPTER);
    let descriptor = wgpu::DeviceDescriptor {
        required_limits: wgpu::Limits {
            max_storage_buffer_binding_size: 1 << 16,
            ..wgpu::Limits::defaults()
        },
        ..Default::default()
    };
    let (device, queue) = pollster::block_on(adapter.request_device(&descriptor)).unwrap();
    let small = Gpu::new(device, queue, adapter.get_info()).unwrap();
    let name = "zoo-bunny";
    let scene = common::scene(name, &SceneOptions::DEFAULT);
    let template = common::template(name, false);
    let options = MatchOptions::DEFAULT;
    let cpu = search(&scene, &template, &options, &mut ()).unwrap();
    let report = search_gpu(&scene, &template, &options, &small).unwrap();
    let fallback = report.gpu.as_ref().and_then(|g| g.fallback.clone());
    assert!(
        fallback
            .as_deref()
            .is_some_and(|f| f.contains("binding limit")),
        "{fallback:?}"
    );
    assert_eq!(report.instances, cpu.instances);
}
