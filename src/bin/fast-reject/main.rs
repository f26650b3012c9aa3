//! The `fast-reject` command: search a scene file for a template.

mod folder_resolver;
mod table;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use fast_reject::exec::Backend;
use fast_reject::mesh::TriMesh;
use fast_reject::mesh::io::load_with_resources;
use fast_reject::scene::{Scene, SceneOptions};
use fast_reject::search::{DescriptorKind, MatchOptions, MatchReport, search};
use fast_reject::template::TemplateSource;
use fast_reject::{Error, Format};
use folder_resolver::FolderResolver;

/// Finds every occurrence of a template shape in a 3D scene (Fast Reject,
/// Attene et al. 2010).
#[derive(Parser)]
#[command(version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Search SCENE for a template model or for a part picked with a sphere.
    Match(MatchArgs),
    /// Run on the small scene and template embedded in this program.
    Demo {
        /// Print the result as JSON.
        #[arg(long)]
        json: bool,
    },
}

#[derive(clap::Args)]
struct MatchArgs {
    /// The scene: .glb, .gltf, .obj, .ply or .stl.
    scene: PathBuf,
    /// A separate template model (same formats).
    #[arg(long, conflicts_with = "select", required_unless_present = "select")]
    template: Option<PathBuf>,
    /// A part of the scene: sphere centre and radius, "X,Y,Z,R" in scene units.
    #[arg(long, value_name = "X,Y,Z,R", allow_hyphen_values = true)]
    select: Option<String>,
    /// Descriptors to run.
    #[arg(long, default_value = "volume+harmonics", value_parser = ["volume+harmonics", "volume", "harmonics", "curvature"])]
    descriptor: String,
    /// Voxels along the scene's longest side.
    #[arg(long, default_value_t = SceneOptions::DEFAULT.resolution)]
    resolution: u32,
    /// Memory budget in MiB for the scene and the search: what would need
    /// more is refused before it is allocated.
    #[arg(long, value_name = "MIB", default_value_t = SceneOptions::DEFAULT.memory_budget >> 20)]
    memory_budget: u64,
    /// Worker threads (1 runs the serial backend; default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Number of radii k.
    #[arg(long, default_value_t = MatchOptions::DEFAULT.layers)]
    layers: usize,
    /// Volume stage threshold (sum of fraction differences).
    #[arg(long, default_value_t = MatchOptions::DEFAULT.volume_threshold)]
    volume_threshold: f64,
    /// Harmonics stage threshold (voxels of equivalent deviation).
    #[arg(long, default_value_t = MatchOptions::DEFAULT.harmonics_threshold)]
    harmonics_threshold: f64,
    /// Curvature threshold (sum of squared differences of the Gaussian
    /// curvatures scaled by r_k^2).
    #[arg(long, default_value_t = MatchOptions::DEFAULT.curvature_threshold)]
    curvature_threshold: f64,
    /// Curvature: 0 makes every vertex a candidate; a positive value runs a
    /// first pass on one vertex per grid cell of this side (a fraction of
    /// the innermost radius), then every vertex near its survivors: several
    /// times faster, but it can miss an occurrence.
    #[arg(long, default_value_t = MatchOptions::DEFAULT.curvature_spacing)]
    curvature_spacing: f64,
    /// Verification: least share of the template's visible surface that must
    /// lie on the scene's surface (0..1).
    #[arg(long, default_value_t = MatchOptions::DEFAULT.verify_threshold)]
    verify_threshold: f64,
    /// Verification: largest share of a model template's surface that other
    /// material may hide (0..1).
    #[arg(long, default_value_t = MatchOptions::DEFAULT.clutter.hidden_surface)]
    hidden_surface: f64,
    /// Print the result as one JSON object.
    #[arg(long)]
    json: bool,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Match(args) => run_match(args),
        Command::Demo { json } => run_demo(json),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}

/// More threads than this many per core only add overhead.
const MAX_THREADS_PER_CORE: usize = 4;

fn run_match(args: MatchArgs) -> Result<(), String> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let backend = match args.threads {
        Some(0) => return Err("--threads must be at least 1".into()),
        // Each thread has its own stack and scratch; thousands only cost.
        Some(n) if n > MAX_THREADS_PER_CORE * cores => {
            return Err(format!(
                "--threads {n} is more than {MAX_THREADS_PER_CORE} per core ({cores} cores here): use at most {}",
                MAX_THREADS_PER_CORE * cores
            ));
        }
        Some(1) => Backend::Serial,
        _ => Backend::Parallel,
    };
    let descriptor: DescriptorKind = args.descriptor.parse().map_err(|e: Error| e.to_string())?;
    let mut options = MatchOptions::DEFAULT;
    options.descriptor = descriptor;
    options.layers = args.layers;
    options.volume_threshold = args.volume_threshold;
    options.harmonics_threshold = args.harmonics_threshold;
    options.curvature_threshold = args.curvature_threshold;
    options.curvature_spacing = args.curvature_spacing;
    options.verify_threshold = args.verify_threshold;
    options.clutter.hidden_surface = args.hidden_surface;
    options.backend = backend;
    let scene_options = SceneOptions::DEFAULT
        .with_resolution(args.resolution)
        .with_memory_budget(args.memory_budget.saturating_mul(1 << 20))
        .with_backend(backend);
    let job = || -> Result<MatchReport, String> {
        let start = std::time::Instant::now();
        let scene_mesh = load_file(&args.scene)?;
        let source = match (&args.template, &args.select) {
            (Some(path), _) => TemplateSource::Model(load_file(path)?),
            (None, Some(s)) => parse_select(s)?,
            (None, None) => unreachable!("clap requires one of them"),
        };
        let load = start.elapsed().as_secs_f64() * 1e3;
        let scene = Scene::new(scene_mesh, &scene_options)
            .map_err(|e| format!("scene '{}': {e}", args.scene.display()))?;
        let mut report = search(&scene, &source, &options, &mut ()).map_err(|e| e.to_string())?;
        report.timings.load = load;
        Ok(report)
    };
    let report = match args.threads {
        Some(n) if n > 1 => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| format!("cannot start {n} threads: {e}"))?
            .install(job)?,
        _ => job()?,
    };
    print_report(&report, args.json, descriptor)
}

/// The embedded demo: a few rotated mugs among other objects.
const DEMO_SCENE: &[u8] = include_bytes!("../../../assets/demo/scene.glb");
const DEMO_TEMPLATE: &[u8] = include_bytes!("../../../assets/demo/template.glb");

fn run_demo(json: bool) -> Result<(), String> {
    let start = std::time::Instant::now();
    let scene_mesh =
        fast_reject::mesh::io::load(DEMO_SCENE, Some(Format::Gltf)).map_err(|e| e.to_string())?;
    let template = fast_reject::mesh::io::load(DEMO_TEMPLATE, Some(Format::Gltf))
        .map_err(|e| e.to_string())?;
    let load = start.elapsed().as_secs_f64() * 1e3;
    let scene = Scene::new(scene_mesh, &SceneOptions::DEFAULT).map_err(|e| e.to_string())?;
    let mut report = search(
        &scene,
        &TemplateSource::Model(template),
        &MatchOptions::DEFAULT,
        &mut (),
    )
    .map_err(|e| e.to_string())?;
    report.timings.load = load;
    if !json {
        println!(
            "Demo: searching the embedded scene (mugs among other objects) for the embedded mug.\n"
        );
    }
    print_report(&report, json, DescriptorKind::default())
}

fn parse_select(s: &str) -> Result<TemplateSource, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let values: Vec<f64> = parts.iter().filter_map(|p| p.parse().ok()).collect();
    if parts.len() != 4 || values.len() != 4 {
        return Err(format!(
            "--select takes four numbers X,Y,Z,R (sphere centre and radius), got '{s}'"
        ));
    }
    Ok(TemplateSource::Selection {
        center: [values[0], values[1], values[2]],
        radius: values[3],
    })
}

/// Reads and parses a mesh file; `.gltf` files may refer to buffers beside them.
fn load_file(path: &Path) -> Result<TriMesh, String> {
    let bytes =
        std::fs::read(path).map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
    let format = path
        .extension()
        .and_then(|e| e.to_str())
        .and_then(Format::from_extension);
    let resolver = FolderResolver::beside(path)
        .map_err(|e| format!("cannot find the folder of '{}': {e}", path.display()))?;
    load_with_resources(&bytes, format, &resolver).map_err(|e| format!("'{}': {e}", path.display()))
}

fn print_report(
    report: &MatchReport,
    json: bool,
    descriptor: DescriptorKind,
) -> Result<(), String> {
    if json {
        let text = serde_json::to_string(report).map_err(|e| e.to_string())?;
        println!("{text}");
    } else {
        println!("descriptor: {descriptor}\n{}", table::Table(report));
    }
    Ok(())
}
