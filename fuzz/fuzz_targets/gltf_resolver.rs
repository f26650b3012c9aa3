//! External glTF buffers: a `.gltf`/`.glb` document and a few in-memory
//! files, loaded through a closure resolver; and `ResourcePath::parse` on
//! arbitrary strings, with its invariants.
//!
//! Input layout: the document, then any number of files, each introduced by
//! `\n@@file NAME\n` and running to the next such line (or the end):
//!
//! ```text
//! {"asset":{"version":"2.0"},"buffers":[{"uri":"a/tri.bin",...}],...}
//! @@file a/tri.bin
//! <bytes>
//! ```
#![no_main]

mod common;

use std::cell::Cell;

use fast_reject::Format;
use fast_reject::mesh::io::{ResourcePath, load_with_resources};
use libfuzzer_sys::fuzz_target;

const SEPARATOR: &[u8] = b"\n@@file ";
const MAX_FILES: usize = 8;

/// What a parsed path promises: plain names below the model's folder.
fn check_path(uri: &str) {
    let Ok(path) = ResourcePath::parse(uri) else {
        return;
    };
    let components: Vec<&str> = path.components().collect();
    assert!(!components.is_empty(), "{uri:?}: no component");
    for c in &components {
        assert!(!c.is_empty(), "{uri:?}: empty component");
        assert!(*c != "." && *c != "..", "{uri:?}: component {c:?}");
        assert!(!c.contains(['/', '\\', '\0']), "{uri:?}: component {c:?}");
    }
    let shown = path.to_string();
    assert!(!shown.starts_with('/'), "{uri:?} shows as {shown:?}");
    assert_eq!(shown.split('/').collect::<Vec<_>>(), components, "{uri:?}");
}

/// What a name handed to a resolver must look like (it came from a
/// `ResourcePath`).
fn check_resolved_name(name: &str) {
    assert!(
        !name.is_empty() && !name.starts_with('/'),
        "resolver asked for {name:?}"
    );
    for c in name.split('/') {
        assert!(
            !c.is_empty() && c != "." && c != ".." && !c.contains(['\\', '\0']),
            "resolver asked for {name:?}"
        );
    }
}

fn split(data: &[u8]) -> (&[u8], Vec<(&[u8], &[u8])>) {
    let mut parts = Vec::new();
    let mut rest = data;
    let mut doc = None;
    while let Some(at) = find(rest, SEPARATOR) {
        parts.push(&rest[..at]);
        rest = &rest[at + SEPARATOR.len()..];
    }
    parts.push(rest);
    let mut files = Vec::new();
    for (i, part) in parts.into_iter().enumerate() {
        if i == 0 {
            doc = Some(part);
            continue;
        }
        if files.len() == MAX_FILES {
            break;
        }
        let (name, content) = match part.iter().position(|&b| b == b'\n') {
            Some(nl) => (&part[..nl], &part[nl + 1..]),
            None => (part, &[][..]),
        };
        files.push((name, content));
    }
    (doc.unwrap_or_default(), files)
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

fuzz_target!(|data: &[u8]| {
    // The path parser on the whole input and on each line of it (a fuzzed
    // `.gltf` has its URIs on lines of their own in the seeds).
    if let Ok(text) = std::str::from_utf8(data) {
        check_path(text);
    }
    for line in data.split(|&b| b == b'\n') {
        if let Ok(line) = std::str::from_utf8(line) {
            check_path(line);
            // A JSON string value on the line: `"uri": "..."`.
            if let Some(value) = line.split('"').nth(3) {
                check_path(value);
            }
        }
    }

    let (doc, files) = split(data);
    let files: Vec<(String, Vec<u8>)> = files
        .into_iter()
        .filter_map(|(name, content)| {
            Some((
                std::str::from_utf8(name).ok()?.to_string(),
                content.to_vec(),
            ))
        })
        .collect();
    for (name, _) in &files {
        check_path(name);
    }
    let calls = Cell::new(0usize);
    let resolver = |name: &str| -> Option<Vec<u8>> {
        check_resolved_name(name);
        calls.set(calls.get() + 1);
        files
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, c)| c.clone())
    };
    if let Ok(mesh) = load_with_resources(doc, Some(Format::Gltf), &resolver) {
        common::check_mesh(&mesh);
    }
    // Buffers are resolved once each, whatever the number of primitives.
    assert!(
        calls.get() <= 1 + doc.len() / 4,
        "{} resolver calls",
        calls.get()
    );
});
