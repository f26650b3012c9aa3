//! Format sniffing, then the loader it picks, on arbitrary bytes. When the
//! sniffer names a format, loading by that name must give the same outcome.
#![no_main]

mod common;

use fast_reject::mesh::io::{load, sniff};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let sniffed = load(data, None);
    if let Ok(mesh) = &sniffed {
        common::check_mesh(mesh);
    }
    match sniff(data) {
        None => assert!(sniffed.is_err(), "loaded without a recognized format"),
        Some(format) => {
            let named = load(data, Some(format));
            assert_eq!(named.is_ok(), sniffed.is_ok(), "sniffed as {format:?}");
        }
    }
});
