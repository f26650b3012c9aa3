//! `fast-reject repeats`: the parts a scene repeats, found without a
//! template.

use std::path::PathBuf;

use fast_reject::exec::Threads;
use fast_reject::{Family, find_repeats};

#[derive(clap::Args)]
pub struct RepeatsArgs {
    /// The scene: .glb, .gltf, .obj, .ply or .stl.
    scene: PathBuf,
    /// Print the families as one JSON object (the RESULT format of
    /// bench/evaluate_families.py).
    #[arg(long)]
    json: bool,
}

pub fn run_repeats(args: RepeatsArgs) -> Result<(), String> {
    let start = std::time::Instant::now();
    let mesh = super::load_file(&args.scene)?;
    let loaded = start.elapsed().as_secs_f64() * 1e3;
    let families = find_repeats(&mesh, Threads::Parallel);
    let found = start.elapsed().as_secs_f64() * 1e3 - loaded;
    if args.json {
        let value = serde_json::json!({
            "families": families,
            "timings_ms": { "load": loaded, "repeats": found },
        });
        return super::write_out(&value.to_string());
    }
    super::write_out(&table(&families, mesh.triangles().len(), loaded, found))
}

/// The families as a table, the largest share of the scene first.
fn table(families: &[Family], triangles: usize, loaded: f64, found: f64) -> String {
    use std::fmt::Write;
    let repeated: usize = families
        .iter()
        .map(|f| f.triangles() * f.copies.len())
        .sum();
    let copies: usize = families.iter().map(|f| f.copies.len()).sum();
    let mut text = format!(
        "{} repeated part{}, {copies} copies, {repeated} of {triangles} triangles \
         ({loaded:.0} ms to load, {found:.0} ms to find)\n",
        families.len(),
        if families.len() == 1 { "" } else { "s" },
    );
    let _ = write!(
        text,
        "{:>6} {:>7} {:>8} {:>9} {:>6} {:>12} {:>10}",
        "family", "copies", "mirrored", "triangles", "pieces", "radius", "residual"
    );
    for (k, f) in families.iter().enumerate() {
        let residual = f.copies.iter().map(|c| c.residual).fold(0.0, f64::max);
        let _ = write!(
            text,
            "\n{k:>6} {:>7} {:>8} {:>9} {:>6} {:>12.4} {residual:>10.2e}",
            f.copies.len(),
            f.copies.iter().filter(|c| c.mirrored).count(),
            f.triangles(),
            f.pieces,
            f.radius
        );
    }
    text
}
