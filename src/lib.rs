//! fast-reject: find every occurrence of a template shape in a 3D scene.

// Numeric kernels index several arrays with one loop index; iterator chains
// would hide the arithmetic.
#![allow(clippy::needless_range_loop)]

pub mod budget;
pub mod cascade;
pub mod clock;
pub mod descriptor;
pub mod error;
pub mod exec;
pub mod instances;
pub mod math;
pub mod mesh;
pub mod scene;
pub mod search;
pub mod template;
pub mod verify;
pub mod voxel;
// The JavaScript binding, for browsers and Node only (not WASI).
#[cfg(all(target_arch = "wasm32", target_os = "unknown"))]
pub mod wasm;

pub use error::{Error, Format, Result};

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
