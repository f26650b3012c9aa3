//! Writes the reliability issue's hostile inputs to a folder: seeds for the
//! fuzz targets and the files the npm package's test feeds the module.
//! Declared sizes stay below 2^32, so that a wasm32 build reaches the same
//! checks as a native one (the gltf crate refuses larger ones first, as
//! "Size exceeds system limits").
//!
//! `cargo run --example hostile_files -- DIR`

#[path = "../tests/common/hostile.rs"]
mod hostile;

fn main() -> std::io::Result<()> {
    let dir = std::path::PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| {
        eprintln!("usage: hostile_files DIR");
        std::process::exit(2)
    }));
    std::fs::create_dir_all(&dir)?;
    // Round two: raw in the parsed string, JSON escapes in the file.
    let attack_uri = hostile::TERMINAL_ATTACK
        .replace('\u{1b}', "\\u001b")
        .replace('\u{7}', "\\u0007");
    let files: [(&str, Vec<u8>); 17] = [
        (
            "escape-absolute.gltf",
            hostile::gltf_with_buffer("/etc/passwd", 1 << 30).into_bytes(),
        ),
        (
            "escape-parent.gltf",
            hostile::gltf_with_buffer("../../../../etc/passwd", 1 << 30).into_bytes(),
        ),
        (
            "sparse-1e9.gltf",
            hostile::sparse_without_view(1_000_000_000).into_bytes(),
        ),
        (
            "instanced-2000.gltf",
            hostile::instanced(2000, 20_000).into_bytes(),
        ),
        ("tetrahedron.stl", hostile::tetrahedron(1.0)),
        ("tetrahedron-1e30.stl", hostile::tetrahedron(1e30)),
        ("random-2000.stl", hostile::random_triangles(2000, 7)),
        ("tiny-in-wide.stl", hostile::tiny_part_in_a_wide_scene()),
        (
            "escape-sequences.gltf",
            hostile::gltf_with_buffer(&attack_uri, 42).into_bytes(),
        ),
        // Just past the loaders' 2^25 triangles, from 34 MB.
        (
            "wide-faces.ply",
            hostile::ply_of_wide_faces((1 << 25) / 253 + 1),
        ),
        (
            "header-gltf.stl",
            hostile::stl_with_header(b"glTF? no: STL", &hostile::tetrahedron_faces(1.0)),
        ),
        (
            "quantized.gltf",
            hostile::quantized_tetrahedron(true, r#""a string""#).into_bytes(),
        ),
        // The curvature descriptor's work: 1.5e9 triangles measured.
        (
            "fanned-cylinder-24000.stl",
            hostile::fanned_cylinder(24_000),
        ),
        // The work of many distinct parts: 20 000 near twins.
        (
            "tetrahedra-jittered-20000.stl",
            hostile::jittered_tetrahedra(20_000, 2),
        ),
        // Nodes that glTF's matrices cannot hold as they are.
        (
            "boxes-hidden-flat-sheared.gltf",
            hostile::hidden_flat_and_sheared_boxes().into_bytes(),
        ),
        (
            "boxes-gpu-instanced.gltf",
            hostile::gpu_instanced_boxes().into_bytes(),
        ),
        (
            "right-tetrahedron.stl",
            hostile::stl(&hostile::right_tetrahedron([0.575, 0.498, 0.425], [0.0; 3])),
        ),
    ];
    for (name, bytes) in files {
        std::fs::write(dir.join(name), bytes)?;
    }
    Ok(())
}
