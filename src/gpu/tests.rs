//! The kernels against the CPU code: WGSL validated with no adapter, then
//! run on whatever adapter the machine has (lavapipe in CI).

use super::*;
use crate::descriptor::SphericalTransform;
use crate::descriptor::harmonics::{DEGREES, SphereSampler, describe_sphere};
use crate::exec::Threads;
use crate::math::Vec3;
use crate::mesh::shapes::{cuboid, torus, uv_sphere};
use crate::voxel::{GridSpec, Solid, skin, voxelize};

#[test]
fn every_wgsl_source_is_valid() {
    for (name, source) in SHADERS {
        let module = naga::front::wgsl::parse_str(source)
            .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(source)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::empty(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name}: {e:?}"));
        // Lavapipe (Mesa 22) compiles and keeps a kernel variant for each
        // uniform buffer a dispatch reads: 180 KB a kernel, 4.8 GB on a
        // scene of 3 000 parts. Parameters travel in storage buffers.
        assert!(
            !source.contains("var<uniform>"),
            "{name}: parameters go in a storage buffer"
        );
    }
}

/// A GPU for the tests: any adapter, lavapipe included. A machine without
/// one fails here, with what to install; built with FAST_REJECT_SKIP_GPU=1,
/// the tests that call this are ignored instead (never in CI).
pub(crate) fn test_gpu() -> Gpu {
    match Gpu::request(AdapterChoice::Any) {
        Ok(Some(gpu)) => gpu,
        Ok(None) => panic!(
            "no GPU adapter: install a Vulkan driver (Debian: mesa-vulkan-drivers, for lavapipe) \
             or build the tests with FAST_REJECT_SKIP_GPU=1 to skip them"
        ),
        Err(e) => panic!("{e}"),
    }
}

/// Every `step`-th voxel of `solid`'s skin, at most `most` of them.
fn skin_sample(solid: &Solid, step: usize, most: usize) -> Vec<[u16; 3]> {
    skin(solid.bits(), Threads::Serial)
        .iter_ones()
        .step_by(step)
        .take(most)
        .collect()
}

/// A shape with flat faces, curved ones and a hole, voxelized.
fn lumpy_solid(voxel: f64) -> Solid {
    let mut m = uv_sphere(Vec3::ZERO, 0.6, 48, 96);
    m.append(&cuboid(
        Vec3::new(0.1, -0.15, -0.15),
        Vec3::new(1.0, 0.15, 0.15),
    ));
    m.append(&torus(Vec3::new(-0.2, 0.5, 0.3), 0.35, 0.1, 48, 16));
    let spec = GridSpec::around(m.bounds(), voxel).unwrap();
    Solid::new(voxelize(&m, &spec, Threads::Serial))
}

#[test]
#[cfg_attr(skip_gpu_tests, ignore = "FAST_REJECT_SKIP_GPU=1: needs a GPU adapter")]
fn gpu_signatures_equal_the_cpus_within_the_stated_error() {
    let gpu = test_gpu();
    let solid = lumpy_solid(0.02);
    let t = SphericalTransform::new();
    let voxels = skin_sample(&solid, 97, 300);
    let spheres = GpuSolid::new(&gpu, &solid);
    let mut levels = Vec::new();
    // Radii in voxels from a few (the bit grid) to past the shape (pyramid
    // levels, and samples outside the grid).
    for radius in [3.5, 12.0, 25.0, 47.0, 90.0] {
        let sampler = SphereSampler::new(radius, &solid, Threads::Serial);
        levels.push(sampler.level());
        let got = pollster::block_on(spheres.signatures(&sampler, &voxels)).unwrap();
        let mut worst = 0.0f32;
        for (v, g) in voxels.iter().zip(&got) {
            let want = describe_sphere(&solid, *v, &sampler, &t);
            for l in 0..DEGREES {
                worst = worst.max((g[l] - want[l]).abs());
            }
        }
        eprintln!("radius {radius}: worst {worst:e}");
        // A quarter of the bound the guard band assumes.
        assert!(
            worst <= super::MAX_ERROR / 4.0,
            "radius {radius}: {worst} on {}",
            gpu.description()
        );
    }
    assert!(
        levels.contains(&0) && levels.iter().any(|&l| l >= 2),
        "{levels:?}"
    );
}

/// A sphere's tables depend on its radius and level alone: two parts'
/// solids read the same ones, uploaded once, with the CPU's results.
#[test]
#[cfg_attr(skip_gpu_tests, ignore = "FAST_REJECT_SKIP_GPU=1: needs a GPU adapter")]
fn a_spheres_sample_tables_are_uploaded_once_for_every_part() {
    let gpu = test_gpu();
    let t = SphericalTransform::new();
    for voxel in [0.02, 0.03] {
        let solid = lumpy_solid(voxel);
        let voxels = skin_sample(&solid, 53, 100);
        let on_gpu = GpuSolid::new(&gpu, &solid);
        for radius in [4.5, 30.0] {
            let sampler = SphereSampler::new(radius, &solid, Threads::Serial);
            let got = pollster::block_on(on_gpu.signatures(&sampler, &voxels)).unwrap();
            for (v, g) in voxels.iter().zip(&got) {
                let want = describe_sphere(&solid, *v, &sampler, &t);
                for l in 0..DEGREES {
                    assert!((g[l] - want[l]).abs() <= super::MAX_ERROR / 4.0);
                }
            }
        }
    }
    assert_eq!(gpu.sample_tables.lock().unwrap().len(), 2);
}

#[test]
#[cfg_attr(skip_gpu_tests, ignore = "FAST_REJECT_SKIP_GPU=1: needs a GPU adapter")]
fn gpu_ball_counts_equal_the_cpus() {
    use crate::descriptor::volume::BLOCKS_PER_RADIUS;
    use crate::voxel::{Ball, level_for_radius};
    let gpu = test_gpu();
    let solid = lumpy_solid(0.02);
    let dims = solid.bits().dims().map(|d| d as u16 - 1);
    // Skin voxels, and the grid's corners and an edge's middle, where the
    // balls are clipped on every side.
    let mut voxels = skin_sample(&solid, 13, usize::MAX);
    voxels.extend([[0, 0, 0], dims, [dims[0] / 2, 0, dims[2]], [0, dims[1], 1]]);
    let on_gpu = GpuSolid::new(&gpu, &solid);
    let mut levels = Vec::new();
    for radius in [2.5, 7.0, 12.0, 30.0, 61.0] {
        let level = level_for_radius(radius, BLOCKS_PER_RADIUS);
        levels.push(level);
        let ball = Ball::build(radius, level, Threads::Serial).for_solid(&solid, Threads::Serial);
        let want: Vec<u64> = voxels.iter().map(|&v| ball.count(&solid, v).0).collect();
        // The default lanes for this many candidates, and one lane, a few
        // and a whole workgroup per candidate (a layer's last candidates).
        for lanes in [None, Some(1), Some(4), Some(64)] {
            let got = pollster::block_on(on_gpu.counts_with(&ball, &voxels, lanes)).unwrap();
            assert_eq!(
                got, want,
                "radius {radius} (level {level}), lanes {lanes:?}"
            );
        }
        assert!(want.iter().any(|&n| n > 0));
    }
    assert!(
        levels.contains(&0) && levels.iter().any(|&l| l >= 3),
        "{levels:?}"
    );
}

#[test]
#[cfg_attr(skip_gpu_tests, ignore = "FAST_REJECT_SKIP_GPU=1: needs a GPU adapter")]
fn a_balls_run_tables_are_uploaded_once_for_every_part() {
    use crate::voxel::Ball;
    let gpu = test_gpu();
    let kept = |gpu: &Gpu| gpu.ball_tables.lock().unwrap().len();
    let (small, large) = (Ball::at_level(7.0, 1), Ball::at_level(30.0, 3));
    // Two parts' solids, each searched with the same two balls.
    for voxel in [0.02, 0.03] {
        let solid = lumpy_solid(voxel);
        let on_gpu = GpuSolid::new(&gpu, &solid);
        for ball in [&small, &large] {
            let ball = ball.clone().for_solid(&solid, Threads::Serial);
            let voxels = skin_sample(&solid, 31, usize::MAX);
            let got = pollster::block_on(on_gpu.counts(&ball, &voxels)).unwrap();
            let want: Vec<u64> = voxels.iter().map(|&v| ball.count(&solid, v).0).collect();
            assert_eq!(got, want, "ball of {} voxels", ball.radius());
        }
    }
    assert_eq!(kept(&gpu), 2);
    // The latest used comes first.
    let first = gpu.ball_tables.lock().unwrap()[0].ball;
    assert_eq!(first, (large.radius().to_bits(), large.level()));
    assert_eq!(gpu.ball_tables(&small).ball.0, small.radius().to_bits());
    assert_eq!(kept(&gpu), 2);
}

#[test]
#[cfg_attr(skip_gpu_tests, ignore = "FAST_REJECT_SKIP_GPU=1: needs a GPU adapter")]
fn a_queue_runs_two_solids_kernels_in_one_submission_with_the_same_results() {
    use crate::voxel::Ball;
    let gpu = test_gpu();
    let solids = [lumpy_solid(0.02), lumpy_solid(0.03)];
    let ball = Ball::at_level(9.0, 1);
    let queue = KernelQueue::new(&gpu);
    let work: Vec<(Ball, Vec<[u16; 3]>)> = solids
        .iter()
        .map(|solid| {
            let voxels = skin_sample(solid, 17, usize::MAX);
            (ball.clone().for_solid(solid, Threads::Serial), voxels)
        })
        .collect();
    let on_gpu: Vec<GpuSolid> = solids
        .iter()
        .map(|solid| GpuSolid::queued(&queue, solid))
        .collect();
    let (submissions, kernels) = gpu.submissions();
    let tasks: Vec<crate::descriptor::LocalFuture<'_, Result<Vec<u64>, String>>> = on_gpu
        .iter()
        .zip(&work)
        .map(|(g, (ball, voxels))| {
            Box::pin(g.counts(ball, voxels)) as crate::descriptor::LocalFuture<'_, _>
        })
        .collect();
    let got = pollster::block_on(crate::descriptor::run_together(&queue, tasks)).unwrap();
    assert_eq!(gpu.submissions(), (submissions + 1, kernels + 2));
    for ((solid, (ball, voxels)), got) in solids.iter().zip(&work).zip(got) {
        let want: Vec<u64> = voxels.iter().map(|&v| ball.count(solid, v).0).collect();
        assert_eq!(got, want);
    }
    // The first failure ends the run; what the others queued is dropped.
    let tasks: Vec<crate::descriptor::LocalFuture<'_, Result<Vec<u64>, String>>> = vec![
        Box::pin(on_gpu[0].counts(&work[0].0, &work[0].1)),
        Box::pin(async { Err("refused".to_string()) }),
    ];
    let failed = pollster::block_on(crate::descriptor::run_together(&queue, tasks));
    assert_eq!(failed, Err("refused".to_string()));
    assert_eq!(gpu.submissions().0, submissions + 1);
    // Tasks that never wait end in the first round.
    let tasks: Vec<crate::descriptor::LocalFuture<'_, Result<u32, String>>> =
        vec![Box::pin(async { Ok(1) }), Box::pin(async { Ok(2) })];
    assert_eq!(
        pollster::block_on(crate::descriptor::run_together(&queue, tasks)),
        Ok(vec![1, 2])
    );
}
