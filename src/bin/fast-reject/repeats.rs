//! `fast-reject repeats`: the parts a scene repeats, found without a
//! template.

use std::path::PathBuf;

use fast_reject::error::FileText;
use fast_reject::exec::Threads;
use fast_reject::mesh::io::model::ImageData;
use fast_reject::mesh::io::write_glb;
use fast_reject::repeats::{Placement, instanced_model, split_by_material};
use fast_reject::{Family, find_repeats_observed};

use crate::output_file::write_atomically;
use crate::progress::ProgressLine;

#[derive(clap::Args)]
pub struct RepeatsArgs {
    /// The scene: .glb, .gltf, .obj, .ply or .stl.
    scene: PathBuf,
    /// Print the families as one JSON object (the RESULT format of
    /// bench/evaluate_families.py).
    #[arg(long)]
    json: bool,
    /// Write the scene as an instanced binary glTF: each repeated part
    /// stored once, every copy a node that places it, the rest as it was.
    #[arg(long, value_name = "FILE.glb")]
    out: Option<PathBuf>,
    /// With --out: place each repeated part's copies with
    /// EXT_mesh_gpu_instancing, one node per part.
    #[arg(long, requires = "out")]
    gpu_instancing: bool,
    /// With --out: let the output replace the scene or a file it reads
    /// (refused without this, since the input would be lost).
    #[arg(long, requires = "out")]
    replace_input: bool,
    /// Progress lines on standard error even when it is not a terminal (a
    /// terminal shows a line redrawn in place without this).
    #[arg(long)]
    progress: bool,
}

pub fn run_repeats(args: RepeatsArgs) -> Result<(), String> {
    let start = std::time::Instant::now();
    let mut progress = ProgressLine::new(args.progress);
    progress.phase("loading the scene");
    let (model, read) = super::load_model_file(&args.scene)?;
    // Before the work, not after it: the answer is already known.
    if let Some(out) = &args.out {
        read.refuse_overwrite(out, args.replace_input)?;
    }
    let (mesh, sources) = model
        .placed()
        .map_err(|e| format!("'{}': {e}", super::shown(&args.scene)))?;
    let loaded = start.elapsed().as_secs_f64() * 1e3;
    progress.phase("finding repeated parts");
    let families = find_repeats_observed(&mesh, Threads::Parallel, &mut progress)
        .map_err(|e| format!("'{}': {e}", super::shown(&args.scene)))?;
    // Parts with different materials are different parts.
    let families = split_by_material(&model, &mesh, &sources, families);
    let found = start.elapsed().as_secs_f64() * 1e3 - loaded;
    let mut written = None;
    let mut kept_copies = 0;
    if let Some(out) = &args.out {
        progress.phase("writing the instanced file");
        let placement = match args.gpu_instancing {
            true => Placement::GpuInstancing,
            false => Placement::Nodes,
        };
        let instanced = instanced_model(&model, &mesh, &sources, &families, placement);
        kept_copies = instanced.kept_copies;
        let instanced = instanced.model;
        let bytes =
            write_glb(&instanced).map_err(|e| format!("cannot write the instanced model: {e}"))?;
        write_atomically(out, &bytes)?;
        for image in &model.materials.images {
            if let ImageData::Unread { uri, reason } = &image.data {
                use std::io::Write;
                let _ = writeln!(
                    std::io::stderr(),
                    "note: the image '{}' is not in the written file, only named by it: {}",
                    FileText::new(uri),
                    FileText::new(reason)
                );
            }
        }
        let nodes: usize = instanced.nodes.iter().map(|n| n.placements.len()).sum();
        written = Some((bytes.len(), instanced.meshes.len(), nodes));
    }
    let wrote = start.elapsed().as_secs_f64() * 1e3 - loaded - found;
    progress.finish();
    if args.json {
        let mut value = serde_json::json!({
            "families": families,
            "timings_ms": { "load": loaded, "repeats": found },
        });
        if let Some((bytes, meshes, nodes)) = written {
            value["written"] = serde_json::json!({
                "bytes": bytes,
                "meshes": meshes,
                "nodes": nodes,
                "copies_kept_as_they_were": kept_copies,
            });
            value["timings_ms"]["write"] = serde_json::json!(wrote);
        }
        return super::write_out(&value.to_string());
    }
    let mut text = table(&families, mesh.triangles().len(), loaded, found);
    if let (Some(out), Some((bytes, meshes, nodes))) = (&args.out, written) {
        text += &format!(
            "\nwrote '{}': {bytes} bytes, {meshes} meshes, {nodes} placements ({wrote:.0} ms)",
            super::shown(out)
        );
        if kept_copies > 0 {
            text += &format!(
                "; {kept_copies} cop{} kept as {} were: a turned symmetric piece meshed otherwise",
                if kept_copies == 1 { "y" } else { "ies" },
                if kept_copies == 1 { "it" } else { "they" }
            );
        }
    }
    super::write_out(&text)
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
            "\n{k:>6} {:>7} {:>8} {:>9} {:>6} {:>12} {residual:>10.2e}",
            f.copies.len(),
            f.copies.iter().filter(|c| c.mirrored).count(),
            f.triangles(),
            f.pieces,
            crate::table::num(f.radius)
        );
    }
    text
}
