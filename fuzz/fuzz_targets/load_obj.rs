//! The Obj loader on arbitrary bytes: an error is fine, a panic, abort,
//! out-of-memory or timeout is a bug.
#![no_main]

mod common;

use fast_reject::Format;
use fast_reject::mesh::io::load;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(mesh) = load(data, Some(Format::Obj)) {
        common::check_mesh(&mesh);
    }
});
