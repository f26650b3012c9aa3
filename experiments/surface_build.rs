//! Times the curvature descriptor's surface build (weld, adjacency,
//! patches) alone: the fastest of N builds of one file's mesh.
//!
//! cargo run --release --features internals --example surface_build -- FILE [N] [serial]

use fast_reject::Threads;
use fast_reject::descriptor::curvature::Surface;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: surface_build FILE [N] [serial]");
        std::process::exit(2);
    };
    let runs: usize = args.get(1).and_then(|n| n.parse().ok()).unwrap_or(5);
    let backend = if args.iter().any(|a| a == "serial") {
        Threads::Serial
    } else {
        Threads::Parallel
    };
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let mesh = fast_reject::load(&bytes, None).unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut best = f64::INFINITY;
    for _ in 0..runs.max(1) {
        let start = std::time::Instant::now();
        let surface = Surface::new(&mesh, backend);
        best = best.min(start.elapsed().as_secs_f64() * 1e3);
        std::hint::black_box(&surface);
    }
    println!(
        "{path}: {} triangles, {} welded vertices, fastest build {best:.1} ms ({backend:?})",
        mesh.triangles().len(),
        Surface::new(&mesh, backend).vertex_count()
    );
}
