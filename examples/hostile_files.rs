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
    let files: [(&str, Vec<u8>); 8] = [
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
    ];
    for (name, bytes) in files {
        std::fs::write(dir.join(name), bytes)?;
    }
    Ok(())
}
