//! fast-reject finds every occurrence of a template shape in a 3D scene,
//! with the Fast Reject schema for part-in-whole matching (Attene, Marini,
//! Spagnuolo, Falcidieno, 2010).
//!
//! The template is described by an *onion descriptor*: layers computed at
//! a centre point c_T over growing radii r_1 < ... < r_k. The scene is not
//! preprocessed: every candidate point gets layer 1, those too far from the
//! template's layer 1 are rejected, layer 2 is computed for the survivors
//! only, and so on.
//!
//! ```text
//!  bytes --load--> TriMesh --Scene::new--> Scene
//!                                          |  voxel pipeline: solid grid, skin voxels
//!                                          |  curvature pipeline: welded mesh, vertices
//!  TemplateSource (a model, or a sphere    v
//!  around part of the scene) ---------> template: c_T, r_1..r_k, its layers
//!                                          |
//!                      cascade: layer 1 on every candidate, layer i on
//!                      the survivors of layer i-1 (volume, harmonics, or
//!                      curvature stages), cancellable between layers
//!                                          |
//!                      verify (placement test) and group survivors
//!                                          v
//!                                     MatchReport: instances, per-layer
//!                                     statistics, stage timings
//! ```
//!
//! The core takes bytes and slices, never paths, and runs the same on
//! native targets and in WebAssembly (the `wasm` module, on
//! `wasm32-unknown-unknown` with the `serde` feature, is the JavaScript
//! binding).
//!
//! ```
//! use fast_reject::{LayerStats, MatchOptions, Scene, SceneOptions, TemplateSource, load, search};
//!
//! fn find(scene_bytes: &[u8], template_bytes: &[u8]) -> fast_reject::Result<()> {
//!     // Bytes in (any supported format); the scene is built once and
//!     // searched any number of times.
//!     let scene = Scene::new(load(scene_bytes, None)?, &SceneOptions::DEFAULT)?;
//!     let template = TemplateSource::Model(load(template_bytes, None)?);
//!     // The observer sees every layer as it completes; Break cancels.
//!     let mut progress = |s: &LayerStats| {
//!         eprintln!("{} layer {}: {} -> {}", s.descriptor, s.layer, s.candidates, s.survivors);
//!         std::ops::ControlFlow::Continue(())
//!     };
//!     let report = search(&scene, &template, &MatchOptions::DEFAULT, &mut progress)?;
//!     for i in &report.instances {
//!         // score: the verified overlap; None for the curvature descriptor.
//!         println!("{:?} distance {:.3} score {:?}", i.position, i.distance, i.score);
//!     }
//!     Ok(())
//! }
//! # let demo = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/demo");
//! # let read = |name: &str| std::fs::read(format!("{demo}/{name}")).unwrap();
//! # find(&read("scene.glb"), &read("template.glb")).unwrap();
//! ```
//!
//! Every failure is a typed [`Error`] whose message says what to change;
//! bad input never panics.

// Numeric kernels index several arrays with one loop index; iterator chains
// would hide the arithmetic.
#![allow(clippy::needless_range_loop)]

pub(crate) mod align;
pub(crate) mod budget;
#[cfg(feature = "internals")]
pub mod cascade;
#[cfg(not(feature = "internals"))]
pub(crate) mod cascade;
pub(crate) mod clock;
#[cfg(feature = "internals")]
pub mod descriptor;
#[cfg(not(feature = "internals"))]
pub(crate) mod descriptor;
pub mod error;
pub mod exec;
#[cfg(feature = "gpu")]
pub mod gpu;
#[cfg(all(feature = "gpu", target_os = "wasi"))]
compile_error!("wgpu has no backend on WASI: build wasm32-wasip1 without the gpu feature");
pub(crate) mod instances;
pub mod math;
pub mod mesh;
pub(crate) mod options;
pub mod repeats;
pub mod scene;
pub mod search;
#[cfg(feature = "internals")]
pub mod template;
#[cfg(not(feature = "internals"))]
pub(crate) mod template;
pub(crate) mod verify;
pub(crate) mod voxel;
// The JavaScript binding, for browsers and Node only (not WASI).
#[cfg(all(target_arch = "wasm32", target_os = "unknown", feature = "serde"))]
pub mod wasm;
#[cfg(all(target_arch = "wasm32", target_os = "unknown", not(feature = "serde")))]
compile_error!(
    "the JavaScript binding reads options and writes reports with serde: build with --features serde"
);

pub use cascade::{LayerStats, Observer, Progress};
pub use descriptor::{ClutterPolicy, LayerDevice};
pub use error::{Error, Format, MemoryEstimate, Result};
pub use exec::Threads;
/// The former name of [`Threads`].
#[deprecated(note = "renamed `Threads`: it says how the CPU's threads run, not which device")]
pub type Backend = exec::Threads;
pub use instances::Instance;
pub use mesh::TriMesh;
pub use mesh::io::load;
pub use repeats::{Family, RepeatCopy, find_repeats, find_repeats_observed};
pub use scene::{Scene, SceneOptions};
pub use search::{
    DescriptorKind, Executor, MatchOptions, MatchReport, SearchPlan, plan, search, search_on,
};
pub use template::TemplateSource;

/// A file of the shared test data: `$FAST_REJECT_SHARED/rel` when that is
/// set (sandboxes such as wasmtime that cannot see `../shared` by its
/// path), else `../shared/rel` beside the crate. Panics, naming the file,
/// when it is not there: a test that needs the shared data must never pass
/// because the data is missing.
#[cfg(test)]
pub(crate) fn shared_path(rel: &str) -> String {
    let path = match std::env::var("FAST_REJECT_SHARED") {
        Ok(root) => format!("{root}/{rel}"),
        Err(_) => format!("{}/../shared/{rel}", env!("CARGO_MANIFEST_DIR")),
    };
    assert!(
        std::path::Path::new(&path).is_file(),
        "shared test data {path} not found: this test needs the benchmark data, \
         as ../shared beside the crate or in the folder FAST_REJECT_SHARED names"
    );
    path
}

/// The bytes of [`shared_path`]`(rel)`; panics, naming the file, when it
/// cannot be read.
#[cfg(test)]
pub(crate) fn shared_bytes(rel: &str) -> Vec<u8> {
    let path = shared_path(rel);
    std::fs::read(&path).unwrap_or_else(|e| panic!("shared test data {path}: {e}"))
}
