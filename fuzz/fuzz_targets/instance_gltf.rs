//! A glTF read as a model with its attributes and materials, its repeated
//! parts found and written back instanced: an error is fine, a panic,
//! abort, out-of-memory or timeout is a bug, and what is written must load
//! again with as many triangles.
#![no_main]

mod common;

use fast_reject::Format;
use fast_reject::exec::Threads;
use fast_reject::find_repeats;
use fast_reject::mesh::io::{NoResources, load, load_model, write_glb};
use fast_reject::repeats::{Placement, instanced_model, split_by_material};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(model) = load_model(data, Some(Format::Gltf), &NoResources) else {
        return;
    };
    let Ok((mesh, sources)) = model.placed() else {
        return;
    };
    common::check_mesh(&mesh);
    let families = split_by_material(&model, &mesh, &sources, find_repeats(&mesh, Threads::Serial));
    for placement in [Placement::Nodes, Placement::GpuInstancing] {
        let instanced = instanced_model(&model, &mesh, &sources, &families, placement);
        let bytes = write_glb(&instanced.model).expect("a model read is written");
        if placement == Placement::Nodes {
            let back = load(&bytes, None).expect("a written model loads");
            assert_eq!(back.triangles().len(), mesh.triangles().len());
        }
    }
});
