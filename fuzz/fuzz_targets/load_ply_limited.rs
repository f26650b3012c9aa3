//! The PLY loader on arbitrary bytes under a small mesh limit: polygons
//! of one-byte corners make twelve times their bytes of triangles, and
//! the limit must stop them before they are built. An error is fine; a
//! mesh over the limit, a panic or an allocation past it is a bug.
#![no_main]

mod common;

use fast_reject::Format;
use fast_reject::mesh::io::{NoResources, load_within};
use libfuzzer_sys::fuzz_target;

/// Small enough that a few kilobytes of wide faces pass it.
const LIMIT: u64 = 1 << 16;

fuzz_target!(|data: &[u8]| {
    if let Ok(mesh) = load_within(data, Some(Format::Ply), &NoResources, LIMIT) {
        common::check_mesh(&mesh);
        let bytes = 12 * (mesh.positions().len() + mesh.triangles().len()) as u64;
        assert!(
            bytes <= LIMIT,
            "a mesh of {bytes} bytes passed the limit of {LIMIT}"
        );
    }
});
