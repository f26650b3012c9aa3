//! The `fast-reject` command: search a scene file for a template.

mod folder_resolver;
mod table;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use fast_reject::Format;
use fast_reject::exec::Backend;
use fast_reject::gpu::{AdapterChoice, Gpu};
use fast_reject::mesh::TriMesh;
use fast_reject::mesh::io::{load_with_resources, sniff};
use fast_reject::scene::{Scene, SceneOptions};
use fast_reject::search::{DescriptorKind, MatchOptions, MatchReport, search, search_on_gpu};
use fast_reject::template::TemplateSource;
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
    Match(Box<MatchArgs>),
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
    #[command(flatten)]
    scene_options: SceneOptions,
    /// Memory budget in MiB for the scene and the search: what would need
    /// more is refused before it is allocated.
    #[arg(long, value_name = "MIB", default_value_t = SceneOptions::DEFAULT.memory_budget >> 20)]
    memory_budget: u64,
    /// Worker threads (1 runs the serial backend; default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Where the harmonics layers run: the CPU; a GPU (any adapter, a
    /// software one such as lavapipe included; an error when there is
    /// none); or auto (a hardware GPU if there is one, else the CPU). The
    /// instances are the same.
    #[arg(long, value_enum, default_value_t = Compute::Cpu)]
    backend: Compute,
    #[command(flatten)]
    options: MatchOptions,
    /// Print the result as one JSON object.
    #[arg(long)]
    json: bool,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Match(args) => run_match(*args),
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

/// The `--backend` choices.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Compute {
    Cpu,
    Gpu,
    Auto,
}

/// The GPU `choice` asks for, if any.
fn gpu_for(choice: Compute) -> Result<Option<Gpu>, String> {
    let adapters = match choice {
        Compute::Cpu => return Ok(None),
        Compute::Gpu => AdapterChoice::Any,
        Compute::Auto => AdapterChoice::Hardware,
    };
    let gpu = Gpu::request(adapters).map_err(|e| e.to_string())?;
    if gpu.is_none() && choice == Compute::Gpu {
        return Err(
            "--backend gpu: no GPU adapter was found (on Linux without a GPU, the Vulkan driver \
             lavapipe from Debian's mesa-vulkan-drivers gives a software one); use --backend cpu or auto"
                .into(),
        );
    }
    Ok(gpu)
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
    let descriptor = args.options.descriptor;
    let mut options = args.options;
    options.backend = backend;
    let mut scene_options = args.scene_options;
    scene_options.memory_budget = args.memory_budget.saturating_mul(1 << 20);
    scene_options.backend = backend;
    let gpu = gpu_for(args.backend)?;
    let job = || -> Result<MatchReport, String> {
        let start = std::time::Instant::now();
        let scene_mesh = load_file(&args.scene)?;
        let source = match (&args.template, &args.select) {
            (Some(path), _) => TemplateSource::Model(load_file(path)?),
            (None, Some(s)) => parse_select(s)?,
            (None, None) => unreachable!("clap requires one of them"),
        };
        let scene = Scene::new(scene_mesh, &scene_options)
            .map_err(|e| format!("scene '{}': {}", args.scene.display(), described(&e)))?;
        let load = start.elapsed().as_secs_f64() * 1e3;
        let mut report = match &gpu {
            Some(gpu) => search_on_gpu(&scene, &source, &options, &mut (), gpu),
            None => search(&scene, &source, &options, &mut ()),
        }
        .map_err(|e| described(&e))?;
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

/// An error in the command line's words: an option by its flag.
fn described(error: &fast_reject::Error) -> String {
    error.describe_with(|name| format!("--{}", name.replace(' ', "-")))
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
    let scene = Scene::new(scene_mesh, &SceneOptions::DEFAULT).map_err(|e| e.to_string())?;
    let load = start.elapsed().as_secs_f64() * 1e3;
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
    // The content first: a .glb saved as .obj is still a glTF. The
    // extension names the parser whose error a user sees when the content
    // is not recognized.
    let format = sniff(&bytes).or_else(|| {
        path.extension()
            .and_then(|e| e.to_str())
            .and_then(Format::from_extension)
    });
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
