//! Load (format sniffed) and, when that works, a small serial search for a
//! selection on the scene. Errors are fine; a panic, abort, out-of-memory or
//! timeout is a bug.
//!
//! Input layout: 8 parameter bytes, then the mesh file.
//!
//! | byte | meaning |
//! |---|---|
//! | 0 | resolution, 8 + b % 25 (8..=32) |
//! | 1-3 | selection centre: x, y, z across the bounds (b / 255), and a bit beyond |
//! | 4 | radius: b % 16 == 0 is 1e6 x the extent, 1 is 1e-6 x, 2 is 0, else a fraction of it (byte 5) |
//! | 5 | that fraction: 0.02 + b / 255 |
//! | 6 | descriptor: volume+harmonics, volume, harmonics, curvature |
//! | 7 | layers, 1 + b % 6; bit 7 set: a coarse curvature spacing (0.5) |
//!
//! The work is bounded, not the time: a search costs what its candidates
//! do, and AddressSanitizer makes it about 20 times slower than a release
//! build (a cube at resolution 32, a selection of its top face: 5553
//! candidates through six layers, 0.6 s natively, 14 s here). So the
//! resolution stays at 32 or below, a small selection refines it at most
//! [`MAX_REFINEMENT`] times, and the search is cancelled once a layer
//! leaves more than [`MAX_SURVIVORS`] for the next; cancelling is itself a
//! path worth fuzzing.
#![no_main]

mod common;

use std::ops::ControlFlow;

use fast_reject::LayerStats;
use fast_reject::exec::Threads;
use fast_reject::mesh::io::load;
use fast_reject::scene::{Scene, SceneOptions};
use fast_reject::search::{DescriptorKind, MatchOptions, search};
use fast_reject::TemplateSource;
use libfuzzer_sys::fuzz_target;

/// Below the fuzzer's RSS limit (2 GiB, with AddressSanitizer's overhead on
/// top): whatever the library agrees to build within this budget must fit.
const MEMORY_BUDGET: u64 = 512 << 20;

/// More survivors than this after a layer cancel the search.
const MAX_SURVIVORS: usize = 2000;

/// The grid is refined for a small selection to at most this many times
/// the resolution byte's: a 1.5% selection at the default 32 template
/// voxels would refine it 43 times, 80000 candidates in a layer (1.7 s
/// natively, over a minute here).
const MAX_REFINEMENT: f64 = 1.5;

fuzz_target!(|data: &[u8]| {
    let Some((params, file)) = data.split_first_chunk::<8>() else {
        return;
    };
    let Ok(mesh) = load(file, None) else {
        return;
    };
    common::check_mesh(&mesh);
    let bounds = mesh.bounds();
    let (min, max) = (bounds.min, bounds.max);
    let extent = (max.x - min.x).max(max.y - min.y).max(max.z - min.z);

    let resolution = 8 + u32::from(params[0]) % 25;
    let scene_options = SceneOptions::DEFAULT
        .with_resolution(resolution)
        .with_backend(Threads::Serial)
        .with_memory_budget(MEMORY_BUDGET);
    let Ok(scene) = Scene::new(mesh, &scene_options) else {
        return;
    };

    // -0.1 .. 1.1 across each axis: mostly inside, sometimes just outside.
    let along = |b: u8, lo: f64, hi: f64| lo + (hi - lo) * (f64::from(b) / 255.0 * 1.2 - 0.1);
    let center = [
        along(params[1], min.x, max.x),
        along(params[2], min.y, max.y),
        along(params[3], min.z, max.z),
    ];
    let radius = match params[4] % 16 {
        0 => extent * 1e6,
        1 => extent * 1e-6,
        2 => 0.0,
        _ => extent * (0.02 + f64::from(params[5]) / 255.0),
    };

    let mut opts = MatchOptions::DEFAULT;
    opts.backend = Threads::Serial;
    opts.descriptor = match params[6] % 4 {
        0 => DescriptorKind::VolumeHarmonics,
        1 => DescriptorKind::Volume,
        2 => DescriptorKind::Harmonics,
        _ => DescriptorKind::Curvature,
    };
    // A small selection refines the grid (MatchOptions::template_voxels)
    // past the resolution byte, and the candidates with it: refining up to
    // MAX_REFINEMENT times keeps that path fuzzed and the work bounded.
    let refined = MAX_REFINEMENT * f64::from(resolution) * radius / extent;
    if refined.is_finite() && refined < opts.template_voxels {
        opts.template_voxels = refined.max(0.0);
    }
    opts.layers = 1 + usize::from(params[7] & 0x7f) % 6;
    if params[7] & 0x80 != 0 {
        opts.curvature_spacing = 0.5;
    }
    let _ = search(
        &scene,
        &TemplateSource::Selection { center, radius },
        &opts,
        &mut |stats: &LayerStats| {
            if stats.survivors > MAX_SURVIVORS {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        },
    );
});
