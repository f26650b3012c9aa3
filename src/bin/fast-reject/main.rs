//! The `fast-reject` command: search a scene file for a template.

mod folder_resolver;
mod output_file;
mod progress;
mod repeats;
mod table;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use fast_reject::Format;
use fast_reject::TemplateSource;
use fast_reject::error::FileText;
use fast_reject::exec::Threads;
use fast_reject::gpu::{AdapterChoice, Gpu};
use fast_reject::mesh::TriMesh;
use fast_reject::mesh::io::{Model, load_model, load_with_resources, sniff};
use fast_reject::scene::{Scene, SceneOptions};
use fast_reject::search::{
    DescriptorKind, Executor, MatchOptions, MatchReport, SearchPlan, plan, search, search_on,
};
use folder_resolver::FolderResolver;
use progress::ProgressLine;

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
    /// List the parts SCENE repeats as rigid copies, without a template.
    Repeats(repeats::RepeatsArgs),
    /// Run on the small scene and template embedded in this program.
    Demo {
        /// Print the result as JSON.
        #[arg(long)]
        json: bool,
    },
}

#[derive(clap::Args)]
// "--group-radius -1" is a value to check, not an unknown flag "-1".
#[command(allow_negative_numbers = true)]
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
    /// [default: 2048, or less where the machine or `ulimit -v` has less]
    #[arg(long, value_name = "MIB")]
    memory_budget: Option<u64>,
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
    /// Report progress on standard error even when it is not a terminal
    /// (on a terminal it is always shown), a line a second.
    #[arg(long)]
    progress: bool,
    /// Print what the search will take, judged without running it (the
    /// parts it searches and the least time), and stop.
    #[arg(long)]
    plan: bool,
}

fn main() -> ExitCode {
    // A file size limit (`ulimit -f`) is then an error on the write that
    // passes it, reported like a full disk, not a signal that kills.
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to ignore is always sound.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
    // Usage errors, --help and --version exit as clap says (2 for usage);
    // printing them may fail on a closed pipe, which is no reason to panic.
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2));
        }
    };
    let result = match cli.command {
        Command::Match(args) => run_match(*args),
        Command::Repeats(args) => repeats::run_repeats(args),
        Command::Demo { json } => run_demo(json),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            use std::io::Write;
            // Nothing is left to tell if standard error is closed too.
            let _ = writeln!(std::io::stderr(), "error: {message}");
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
        Some(1) => Threads::Serial,
        _ => Threads::Parallel,
    };
    let descriptor = args.options.descriptor;
    let mut options = args.options;
    options.backend = backend;
    let mut scene_options = args.scene_options;
    scene_options.memory_budget = memory_budget(args.memory_budget)?;
    scene_options.backend = backend;
    let gpu = gpu_for(args.backend)?;
    let mut progress = ProgressLine::new(args.progress);
    let mut job = || -> Result<Outcome, String> {
        let start = std::time::Instant::now();
        progress.phase("loading the scene");
        let scene_mesh = load_file(&args.scene)?;
        let source = match (&args.template, &args.select) {
            (Some(path), _) => {
                progress.phase("loading the template");
                TemplateSource::Model(load_file(path)?)
            }
            (None, Some(s)) => parse_select(s)?,
            (None, None) => unreachable!("clap requires one of them"),
        };
        progress.phase("preparing the scene");
        let scene = Scene::new_observed(scene_mesh, &scene_options, &mut progress)
            .map_err(|e| format!("scene '{}': {}", shown(&args.scene), described(&e)))?;
        let load = start.elapsed().as_secs_f64() * 1e3;
        if args.plan {
            progress.phase("planning");
            let plan = plan(&scene, &source, &options).map_err(|e| described(&e))?;
            return Ok(Outcome::Plan(plan));
        }
        progress.phase("searching");
        let mut report = match &gpu {
            Some(gpu) => pollster::block_on(search_on(
                Executor::Device(gpu),
                &scene,
                &source,
                &options,
                &mut progress,
            )),
            None => search(&scene, &source, &options, &mut progress),
        }
        .map_err(|e| described(&e))?;
        report.timings.load = load;
        Ok(Outcome::Report(report))
    };
    let report = match args.threads {
        Some(n) if n > 1 => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| format!("cannot start {n} threads: {e}"))?
            .install(job)?,
        _ => job()?,
    };
    progress.finish();
    let report = match report {
        Outcome::Report(report) => report,
        Outcome::Plan(plan) => return print_plan(plan.as_ref(), &options, args.json),
    };
    // Said in the table, where a reader would otherwise wonder where auto ran.
    let note = (args.backend == Compute::Auto && gpu.is_none())
        .then_some("harmonics layers on the CPU: --backend auto found no hardware GPU adapter");
    print_report(&report, args.json, descriptor, note)
}

/// What `match` did: searched, or only planned (`--plan`).
enum Outcome {
    Report(MatchReport),
    Plan(Option<SearchPlan>),
}

/// `--plan`'s output: the plan, or a line (JSON null) for a search with no
/// plan.
fn print_plan(plan: Option<&SearchPlan>, options: &MatchOptions, json: bool) -> Result<(), String> {
    let text = match (json, plan) {
        (true, plan) => serde_json::to_string(&plan).map_err(|e| e.to_string())?,
        (false, None) => {
            "no plan: the curvature search's work is the welded surface's vertices".into()
        }
        (false, Some(s)) => {
            let copies = s.parts - s.distinct_parts;
            let refused = match s.over_limit {
                true => "\nthe search would be refused: its least work passes --max-part-work",
                false => "",
            };
            format!(
                "parts that can hold a copy: {} ({} distinct, searched; {copies} copies of them)\n\
                 skin voxels of the distinct parts: about {:.0}\n\
                 time: about {:.2} s or more on {} threads (least work {:.3e} of --max-part-work {:.3e}); \
                 parts like the template take several times more{refused}",
                s.parts,
                s.distinct_parts,
                s.skin_voxels,
                s.least_seconds,
                s.threads,
                s.least_work,
                options.max_part_work,
            )
        }
    };
    write_out(&text)
}

/// An error in the command line's words: an option by its flag.
fn described(error: &fast_reject::Error) -> String {
    error.describe_with(|name| format!("--{}", name.replace(' ', "-")))
}

/// The budget in bytes for `--memory-budget MIB`: a budget is a promise
/// that what passes it can be allocated, so it may not exceed what this
/// process can have (the machine's memory, or its address-space limit
/// less what the program itself takes). An allocation past that would
/// abort.
fn memory_budget(mib: Option<u64>) -> Result<u64, String> {
    let ceiling = memory_ceiling();
    let Some(mib) = mib else {
        // The default says "what is reasonable": no more than there is.
        let default = SceneOptions::DEFAULT.memory_budget;
        return Ok(ceiling.map_or(default, |(c, _)| default.min(c)));
    };
    let asked = mib.saturating_mul(1 << 20);
    let Some((ceiling, why)) = ceiling else {
        return Ok(asked);
    };
    if asked <= ceiling {
        return Ok(asked);
    }
    Err(format!(
        "--memory-budget {mib} is more than this process can have ({why}): give at most {}",
        ceiling >> 20
    ))
}

/// Address space the program takes besides what a budget counts: its code,
/// the threads' stacks, the allocator's arenas (measured: a search's peak
/// address space is its largest allocations plus 90-170 MiB).
const ADDRESS_SPACE_RESERVE: u64 = 160 << 20;

/// The most memory this process can be given, and why, where the system
/// says (Linux: the machine's memory and `ulimit -v`).
fn memory_ceiling() -> Option<(u64, String)> {
    let field = |text: &str, key: &str| -> Option<u64> {
        let line = text.lines().find(|l| l.starts_with(key))?;
        line[key.len()..].split_whitespace().next()?.parse().ok()
    };
    let machine = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| field(&t, "MemTotal:"))
        .map(|kib| kib.saturating_mul(1024));
    // "unlimited" does not parse: no limit.
    let address_space = std::fs::read_to_string("/proc/self/limits")
        .ok()
        .and_then(|t| field(&t, "Max address space"))
        .map(|bytes| bytes - (bytes / 8).max(ADDRESS_SPACE_RESERVE).min(bytes / 2));
    let machine = machine.map(|m| (m, format!("the machine has {} MiB of memory", m >> 20)));
    let address_space = address_space.map(|a| {
        let why = format!("its address-space limit, ulimit -v, leaves {} MiB", a >> 20);
        (a, why)
    });
    // The smaller says; the machine's on a tie.
    match (machine, address_space) {
        (Some(m), Some(a)) => Some(if a.0 < m.0 { a } else { m }),
        (m, a) => m.or(a),
    }
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
        write_out(
            "Demo: searching the embedded scene (mugs among other objects) for the embedded mug.\n",
        )?;
    }
    print_report(&report, json, DescriptorKind::default(), None)
}

fn parse_select(s: &str) -> Result<TemplateSource, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let values: Vec<f64> = parts.iter().filter_map(|p| p.parse().ok()).collect();
    if parts.len() != 4 || values.len() != 4 {
        return Err(format!(
            "--select takes four numbers X,Y,Z,R (sphere centre and radius), got '{}'",
            FileText::new(s)
        ));
    }
    Ok(TemplateSource::Selection {
        center: [values[0], values[1], values[2]],
        radius: values[3],
    })
}

/// Reads and parses a mesh file; `.gltf` files may refer to buffers beside them.
fn load_file(path: &Path) -> Result<TriMesh, String> {
    read_file(path, |bytes, format, resolver| {
        load_with_resources(bytes, format, resolver)
    })
}

/// The model in the file at `path`, with what a viewer draws (see
/// [`fast_reject::mesh::io::load_model`]), and every file it was read
/// from: the model's own and those it refers to.
fn load_model_file(path: &Path) -> Result<(Model, output_file::ReadFiles), String> {
    let mut files = output_file::ReadFiles::default();
    files.add(path);
    let model = read_file(path, |bytes, format, resolver| {
        let model = load_model(bytes, format, resolver);
        for file in resolver.read() {
            files.add(&file);
        }
        model
    })?;
    Ok((model, files))
}

/// `load` on the bytes of the file at `path`, with its format and a
/// resolver for the files beside it.
fn read_file<T>(
    path: &Path,
    load: impl FnOnce(&[u8], Option<Format>, &FolderResolver) -> fast_reject::Result<T>,
) -> Result<T, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read '{}': {e}", shown(path)))?;
    // The content first: a .glb saved as .obj is still a glTF. The
    // extension names the parser whose error a user sees when the content
    // is not recognized.
    let format = sniff(&bytes).or_else(|| {
        path.extension()
            .and_then(|e| e.to_str())
            .and_then(Format::from_extension)
    });
    let resolver = FolderResolver::beside(path)
        .map_err(|e| format!("cannot find the folder of '{}': {e}", shown(path)))?;
    load(&bytes, format, &resolver).map_err(|e| format!("'{}': {e}", shown(path)))
}

/// A path for a message: a file's name is anyone's text (a downloaded
/// model's name can hold escape sequences), so it is escaped like a file's
/// content.
fn shown(path: &Path) -> FileText {
    FileText::new(&path.to_string_lossy())
}

fn print_report(
    report: &MatchReport,
    json: bool,
    descriptor: DescriptorKind,
    note: Option<&str>,
) -> Result<(), String> {
    let text = if json {
        serde_json::to_string(report).map_err(|e| e.to_string())?
    } else {
        let note = note.map(|n| format!("{n}\n")).unwrap_or_default();
        format!("descriptor: {descriptor}\n{note}{}", table::Table(report))
    };
    write_out(&text)
}

/// Writes `text` and a newline to standard output. A closed pipe (`| head`)
/// or a full disk is an error to report, not a panic as in `println!`: the
/// report did not reach its reader.
pub(crate) fn write_out(text: &str) -> Result<(), String> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())
        .and_then(|()| out.write_all(b"\n"))
        .and_then(|()| out.flush())
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::BrokenPipe => {
                "cannot write the report: standard output was closed before it was written (a pipe's reader exited)".to_string()
            }
            _ => format!("cannot write the report to standard output: {e}"),
        })
}
