//! The reliability issue's hostile inputs, one named test each: every one
//! ends in a typed error (or a result) instead of reading files outside the
//! model, aborting, or running for minutes. The CLI runs under a 1 GiB
//! address-space limit (`ulimit -v`), so an allocation past it fails the
//! test instead of passing unnoticed.

#[path = "common/hostile.rs"]
mod hostile;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use fast_reject::Observer;
use fast_reject::TemplateSource;
use fast_reject::exec::Threads;
use fast_reject::mesh::io::load;
use fast_reject::scene::{Scene, SceneOptions};
use fast_reject::search::{DescriptorKind, MatchOptions, search};
use fast_reject::{Error, Format};

/// The CLI with `args`, in at most 1 GiB of address space; fails the test
/// when it runs past `limit` (a hang) or dies of a signal (an abort).
fn cli_within(args: &[&str], limit: Duration) -> Output {
    let start = Instant::now();
    let out = Command::new("bash")
        .arg("-c")
        .arg(r#"ulimit -v 1048576 && exec timeout -s KILL "$0" "$@""#)
        .arg(format!("{}", limit.as_secs()))
        .arg(env!("CARGO_BIN_EXE_fast-reject"))
        .args(args)
        .output()
        .expect("bash runs");
    let took = start.elapsed();
    assert!(
        out.status.code().is_some_and(|c| c != 124 && c != 137),
        "{args:?} was killed or ran past {limit:?} ({took:?}): {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// The CLI's error message for `args`, which must fail cleanly (exit 1).
fn cli_error(args: &[&str]) -> String {
    let out = cli_within(args, Duration::from_secs(60));
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
    assert!(err.starts_with("error: "), "{args:?}: {err}");
    err
}

/// The embedded demo's scene and template files.
fn demo() -> (String, String) {
    let demo = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/demo");
    (format!("{demo}/scene.glb"), format!("{demo}/template.glb"))
}

fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("hostile")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn write(dir: &Path, name: &str, bytes: impl AsRef<[u8]>) -> String {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path.to_str().unwrap().to_string()
}

/// Case 1: a buffer URI may name only a regular file inside the model's
/// folder, and nothing of another file reaches the message.
#[test]
fn case_1_gltf_buffers_outside_the_folder_are_refused() {
    let root = scratch("escape");
    let secret = "SECRET-CONTENT-0123456789";
    write(&root, "outside.bin", secret.repeat(10));
    let dir = root.join("model");
    std::fs::create_dir_all(dir.join("folder.bin")).unwrap();
    let tet = write(&root, "tet.stl", hostile::tetrahedron(1.0));
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(root.join("outside.bin"), dir.join("link.bin")).unwrap();
        std::os::unix::fs::symlink("/dev/zero", dir.join("zero.bin")).unwrap();
    }
    let cases = [
        ("/etc/passwd", "absolute path"),
        ("../outside.bin", "'..'"),
        ("../../../../../../../../etc/passwd", "'..'"),
        ("%2e%2e/outside.bin", "'..'"),
        ("%2Fetc%2Fpasswd", "absolute path"),
        ("file:///etc/passwd", "scheme"),
        ("/dev/zero", "absolute path"),
        ("/dev/urandom", "absolute path"),
        ("..%5coutside.bin", "backslash"),
        ("folder.bin", "not a regular file"),
        #[cfg(unix)]
        ("link.bin", "outside the model's folder"),
        #[cfg(unix)]
        ("zero.bin", "outside the model's folder"),
    ];
    for (uri, why) in cases {
        let model = write(&dir, "model.gltf", hostile::gltf_with_buffer(uri, 1 << 40));
        for args in [
            vec!["match", model.as_str(), "--select", "0,0,0,0.5"],
            vec!["match", tet.as_str(), "--template", model.as_str()],
        ] {
            let err = cli_error(&args);
            assert!(
                err.contains("is not read") && err.contains(why),
                "{uri}: {err}"
            );
            assert!(
                !err.contains("SECRET") && !err.contains("root:"),
                "{uri}: {err}"
            );
        }
    }
    // A plain name inside the folder is read, no further than byteLength.
    let mut bin = hostile::triangle_buffer();
    bin.extend_from_slice(&[0xff; 1000]);
    write(&dir, "ok.bin", &bin);
    let model = write(&dir, "model.gltf", hostile::gltf_with_buffer("ok.bin", 42));
    let out = cli_within(
        &["match", &model, "--select", "0,0,0,0.5", "--json"],
        Duration::from_secs(60),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Case 2: an accessor with no buffer view cannot declare more elements
/// than its file has bytes.
#[test]
fn case_2_a_sparse_accessor_cannot_declare_unstored_elements() {
    for count in [1_000_000_000_000_000u64, 100_000_000] {
        let doc = hostile::sparse_without_view(count);
        let e = load(doc.as_bytes(), Some(Format::Gltf)).unwrap_err();
        assert!(matches!(e, Error::Malformed { .. }), "{e}");
        assert!(e.to_string().contains("no buffer view"), "{e}");
    }
    // A count the file can stand for still loads (zeros and one triangle).
    let doc = hostile::sparse_without_view(3);
    assert!(matches!(
        load(doc.as_bytes(), Some(Format::Gltf)),
        Err(Error::EmptyMesh { .. })
    ));
    let dir = scratch("sparse");
    let file = write(&dir, "sparse.gltf", hostile::sparse_without_view(1 << 50));
    let err = cli_error(&["match", &file, "--select", "0,0,0,1"]);
    assert!(err.contains("no buffer view"), "{err}");
}

/// Case 3: the vertex budget is checked before a node's copy is made.
#[test]
fn case_3_instancing_is_counted_before_copying() {
    // 2000 nodes x 20000 triangles: past 2^25 triangles, from 170 KB.
    let doc = hostile::instanced(2000, 20_000);
    assert!(doc.len() < 200_000);
    let e = load(doc.as_bytes(), Some(Format::Gltf)).unwrap_err();
    assert!(matches!(e, Error::MeshTooLarge { .. }), "{e}");
    let dir = scratch("instanced");
    let file = write(&dir, "instanced.gltf", &doc);
    let err = cli_error(&["match", &file, "--select", "0.5,0.5,0.5,0.4"]);
    assert!(err.contains("place fewer copies"), "{err}");
    // Within the budget, instances load as parts and are searched.
    let doc = hostile::instanced(20, 200);
    let mesh = load(doc.as_bytes(), Some(Format::Gltf)).unwrap();
    assert_eq!(mesh.triangles().len() + mesh.degenerate_dropped(), 4000);
    // A host with little memory passes its own cap.
    let e = fast_reject::mesh::io::load_within(
        doc.as_bytes(),
        Some(Format::Gltf),
        &fast_reject::mesh::io::NoResources,
        10_000,
    )
    .unwrap_err();
    assert!(matches!(e, Error::MeshTooLarge { .. }), "{e}");
}

fn small_scene(resolution: u32) -> Scene {
    let mesh = load(&hostile::tetrahedron(1.0), None).unwrap();
    Scene::new(mesh, &SceneOptions::DEFAULT.with_resolution(resolution)).unwrap()
}

/// Cases 4 and 7: a template 10^30 times the scene is said to be larger
/// than the scene (no resolution would help), not a wrapped grid.
#[test]
fn case_4_a_template_far_larger_than_the_scene_is_refused() {
    let scene = small_scene(64);
    let huge = TemplateSource::Model(load(&hostile::tetrahedron(1e30), None).unwrap());
    for descriptor in ["volume+harmonics", "curvature"] {
        let mut options = MatchOptions::DEFAULT;
        options.descriptor = descriptor.parse().unwrap();
        let e = search(&scene, &huge, &options, &mut ()).unwrap_err();
        assert!(matches!(e, Error::TemplateLargerThanScene { .. }), "{e}");
        assert!(e.to_string().contains("same units"), "{e}");
        assert!(!e.to_string().contains("resolution"), "{e}");
    }
    let dir = scratch("huge-template");
    let (scene, template) = (
        write(&dir, "tet.stl", hostile::tetrahedron(1.0)),
        write(&dir, "huge.stl", hostile::tetrahedron(1e30)),
    );
    let err = cli_error(&["match", &scene, "--template", &template]);
    assert!(err.contains("larger than the whole scene"), "{err}");
}

/// Case 5: the ball tables count in the memory budget: a selection wider
/// than the scene is refused, and radii too many voxels wide stop before
/// their tables are built.
#[test]
fn case_5_ball_tables_are_counted_before_they_are_built() {
    let scene = small_scene(64);
    let wide = TemplateSource::Selection {
        center: [0.0; 3],
        radius: 1e6,
    };
    let e = search(&scene, &wide, &MatchOptions::DEFAULT, &mut ()).unwrap_err();
    assert!(matches!(e, Error::TemplateLargerThanScene { .. }), "{e}");
    // A radius of the scene's size at resolution 1024, kept there: a
    // thousand voxels.
    let scene = small_scene(1024);
    let whole = TemplateSource::Selection {
        center: [0.0; 3],
        radius: 1.0,
    };
    let mut kept = MatchOptions::DEFAULT;
    kept.template_voxels = 0.0;
    let e = search(&scene, &whole, &kept, &mut ()).unwrap_err();
    assert!(matches!(e, Error::OverBudget { .. }), "{e}");
    assert!(e.to_string().contains("ball tables"), "{e}");
    // By default the lattice is coarsened until it spans 96, and the
    // selection is found where it was taken.
    let found = search(&scene, &whole, &MatchOptions::DEFAULT, &mut ()).unwrap();
    let grid = found.grid.expect("a voxel search");
    assert!(grid.resolution < 1024, "{grid:?}");
    assert_eq!(found.instances.len(), 1, "{:?}", found.instances);
    let dir = scratch("ball-tables");
    let tet = write(&dir, "tet.stl", hostile::tetrahedron(1.0));
    for args in [
        vec!["match", tet.as_str(), "--select", "0,0,0,1e6"],
        vec![
            "match",
            tet.as_str(),
            "--select",
            "0,0,0,100",
            "--resolution",
            "16",
        ],
        vec![
            "match",
            tet.as_str(),
            "--select",
            "0,0,0,1",
            "--resolution",
            "2048",
            "--template-voxels",
            "0",
        ],
    ] {
        let err = cli_error(&args);
        assert!(
            err.contains("larger than the whole scene") || err.contains("not enough memory"),
            "{args:?}: {err}"
        );
    }
}

/// Case 6: thousands of threads are refused; random large triangles end
/// within the time limit.
#[test]
fn case_6_work_is_bounded() {
    let (scene, template) = demo();
    let err = cli_error(&[
        "match",
        &scene,
        "--template",
        &template,
        "--threads",
        "4000",
    ]);
    assert!(err.contains("use at most"), "{err}");
    let dir = scratch("random");
    let random = write(&dir, "random.stl", hostile::random_triangles(2000, 7));
    let out = cli_within(
        &["match", &random, "--select", "0,0,0,30", "--json"],
        Duration::from_secs(60),
    );
    assert!(
        out.status.success() || String::from_utf8_lossy(&out.stderr).starts_with("error: "),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Triangles spanning the scene: the voxelizer's work is refused before
    // it starts, naming the resolution that fits.
    let mesh = load(&hostile::cube_spanning_tents(1000), None).unwrap();
    let e = Scene::new(mesh.clone(), &SceneOptions::DEFAULT).unwrap_err();
    assert!(matches!(e, Error::TooMuchWork { .. }), "{e}");
    let fits: u32 = e
        .to_string()
        .split("at most ")
        .nth(1)
        .unwrap()
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(Scene::new(mesh, &SceneOptions::DEFAULT.with_resolution(fits)).is_ok());
}

/// Case 7: a template too small for any resolution says so.
#[test]
fn case_7_a_template_no_resolution_fits_says_so() {
    let mesh = load(&hostile::tiny_part_in_a_wide_scene(), None).unwrap();
    let scene = Scene::new(mesh, &SceneOptions::DEFAULT).unwrap();
    let tiny = TemplateSource::Selection {
        center: [0.0; 3],
        radius: 2e-6,
    };
    let e = search(&scene, &tiny, &MatchOptions::DEFAULT, &mut ()).unwrap_err();
    assert!(matches!(e, Error::TemplateTooSmall { .. }), "{e}");
    assert!(e.to_string().contains("no resolution fits"), "{e}");
    // Where a resolution would do, it is named (the search refines the
    // grid for a small template itself unless told not to).
    let scene = small_scene(64);
    let small = TemplateSource::Selection {
        center: [0.0; 3],
        radius: 0.05,
    };
    let mut fixed = MatchOptions::DEFAULT;
    fixed.template_voxels = 0.0;
    let e = search(&scene, &small, &fixed, &mut ()).unwrap_err();
    assert!(
        e.to_string().contains("raise the resolution to at least"),
        "{e}"
    );
}

// Round two: what the first round missed.

/// Whether `text` has a character a terminal would act on: any control
/// but the newline that ends a message, or a bidirectional override.
fn has_unsafe_char(text: &str) -> bool {
    text.trim_end_matches('\n')
        .chars()
        .any(|c| c.is_control() || matches!(c, '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}'))
}

/// Case 8: nothing a file says reaches the terminal raw, in the CLI or in
/// the library's messages, whatever the loader; and it is bounded.
#[test]
fn case_8_file_text_is_escaped_and_bounded_in_every_message() {
    let attack = hostile::TERMINAL_ATTACK;
    let dir = scratch("escapes");
    let long = format!("{attack}{}", "x".repeat(100_000));
    // Raw in the parsed string, written as JSON escapes in the file.
    let json = |text: &str| {
        text.replace('\u{1b}', "\\u001b")
            .replace('\u{7}', "\\u0007")
    };
    let uri = json(&long);
    let files: Vec<(&str, Vec<u8>)> = vec![
        // A buffer uri: missing, then refused.
        (
            "missing.gltf",
            hostile::gltf_with_buffer(&uri, 42).into_bytes(),
        ),
        (
            "refused.gltf",
            hostile::gltf_with_buffer(&format!("../{uri}"), 42).into_bytes(),
        ),
        // A JSON value serde quotes in its message.
        (
            "value.gltf",
            format!(
                r#"{{"asset":{{"version":"2.0"}},"scenes":"{}"}}"#,
                json(attack)
            )
            .into_bytes(),
        ),
        (
            "header.ply",
            format!("ply\nformat ascii 1.0\n{attack} 1\nend_header\n").into_bytes(),
        ),
        (
            "vertex.obj",
            format!("v 1 {attack} 3\nf 1 1 1\n").into_bytes(),
        ),
        (
            "facet.stl",
            format!("solid x\nfacet {attack}\nendsolid\n").into_bytes(),
        ),
    ];
    for (name, bytes) in files {
        let path = write(&dir, name, &bytes);
        let err = cli_error(&["match", &path, "--select", "0,0,0,1"]);
        assert!(!has_unsafe_char(&err), "{name}: {err:?}");
        assert!(err.len() < 2_000, "{name}: {} bytes of message", err.len());
        assert!(
            err.contains("\\u{1b}"),
            "{name}: the escape is not shown: {err}"
        );
        if let Err(e) = load(&bytes, None) {
            let message = e.to_string();
            assert!(!has_unsafe_char(&message), "{name}: {message:?}");
        }
    }
    // A file's name is anyone's text too.
    let named = write(
        &dir,
        &format!("{}.stl", attack.replace('/', "")),
        b"solid\nfacet x\n",
    );
    let err = cli_error(&["match", &named, "--select", "0,0,0,1"]);
    assert!(!has_unsafe_char(&err), "{err:?}");
}

/// Case 9: a binary PLY of 255-corner faces makes twelve times its bytes
/// of triangles: refused by the loaders' limit before it is built, in the
/// CLI under 1 GiB, and against a small cap in the library.
#[test]
fn case_9_polygon_amplification_is_refused_before_it_is_built() {
    let dir = scratch("amplification");
    // 2^25 triangles and a few more: at the loaders' own limit.
    let faces = (1 << 25) / 253 + 1;
    let file = write(&dir, "wide.ply", hostile::ply_of_wide_faces(faces));
    let err = cli_error(&["match", &file, "--select", "0,0,0,1"]);
    assert!(err.contains("above the limit"), "{err}");
    let small = hostile::ply_of_wide_faces(64);
    let e = fast_reject::mesh::io::load_within(
        &small,
        None,
        &fast_reject::mesh::io::NoResources,
        64 * 253 * 12 / 2,
    )
    .unwrap_err();
    assert!(matches!(e, Error::MeshTooLarge { .. }), "{e}");
    // What loading it may take, as the wasm module asks before copying it
    // in: at least what the mesh would be.
    let peak = fast_reject::mesh::io::peak_load_bytes(&small, small.len() as u64, u64::MAX);
    assert!(peak >= 12 * 64 * 253 + small.len() as u64, "{peak}");
    assert!(load(&small, None).is_ok());
}

/// Case 10: a budget past what the process can have is refused, not
/// taken at its word until an allocation aborts.
#[test]
fn case_10_a_budget_past_the_machine_is_refused() {
    let (scene, template) = demo();
    let err = cli_error(&[
        "match",
        &scene,
        "--template",
        &template,
        "--memory-budget",
        "18446744073709551615",
    ]);
    assert!(err.contains("more than this process can have"), "{err}");
    // The default fits what `ulimit -v` leaves, and the demo runs in it.
    let out = cli_within(
        &["match", &scene, "--template", &template, "--json"],
        Duration::from_secs(60),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Case 11: a closed pipe or a full disk on standard output is a message
/// and exit 1, not a panic.
#[cfg(unix)]
#[test]
fn case_11_a_closed_output_is_an_error_not_a_panic() {
    use std::process::Stdio;
    let (reader, writer) = std::io::pipe().expect("a pipe");
    drop(reader);
    let out = Command::new(env!("CARGO_BIN_EXE_fast-reject"))
        .args(["demo", "--json"])
        .stdout(Stdio::from(writer))
        .stderr(Stdio::piped())
        .output()
        .expect("runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.starts_with("error: cannot write the report"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    if Path::new("/dev/full").exists() {
        let full = std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_fast-reject"))
            .args(["demo", "--json"])
            .stdout(Stdio::from(full))
            .output()
            .expect("runs");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert!(err.contains("No space left"), "{err}");
    }
}

/// Case 12: a glTF buffer that is a named pipe is refused without being
/// opened (opening it blocked until a writer came); buffers naming one
/// file read it once.
#[cfg(unix)]
#[test]
fn case_12_resources_are_checked_before_opening_and_read_once() {
    let dir = scratch("fifo");
    let fifo = dir.join("pipe.bin");
    let made = Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .expect("mkfifo runs");
    assert!(made.success());
    let model = write(
        &dir,
        "model.gltf",
        hostile::gltf_with_buffer("pipe.bin", 42),
    );
    let err = cli_error(&["match", &model, "--select", "0,0,0,1"]);
    assert!(err.contains("not a regular file"), "{err}");

    let reads = std::cell::Cell::new(0);
    let resolver = |path: &str| {
        reads.set(reads.get() + 1);
        (path == "big.bin").then(|| {
            let mut bytes = hostile::triangle_buffer();
            bytes.resize(1 << 20, 0);
            bytes
        })
    };
    let doc = hostile::gltf_with_buffers_naming_one_file("big.bin", 40, 1 << 20);
    let mesh = fast_reject::mesh::io::load_with_resources(doc.as_bytes(), None, &resolver)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(mesh.triangles().len(), 40);
    assert_eq!(reads.get(), 1, "one file, read {} times", reads.get());
}

/// Case 13: messages that were wrong: separate tiles on a floor are
/// searched (they were told to weld the mesh), and a negative value is the
/// option's own error (clap said to write '-- -1').
#[test]
fn case_13_tiles_are_searched_and_negative_values_are_checked() {
    let mesh = load(&hostile::flat_tiles(10), None).unwrap();
    let scene = Scene::new(mesh, &SceneOptions::DEFAULT).unwrap();
    let tile = TemplateSource::Selection {
        center: [0.5, 0.5, 0.0],
        radius: 0.6,
    };
    let report =
        search(&scene, &tile, &MatchOptions::DEFAULT, &mut ()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(report.instances.len(), 100);
    let (scene, _) = demo();
    let err = cli_error(&[
        "match",
        &scene,
        "--select",
        "0,0,0,1",
        "--group-radius",
        "-1",
    ]);
    assert!(err.contains("invalid option --group-radius"), "{err}");
}

/// Case 14: valid files that were refused: quantized positions
/// (KHR_mesh_quantization), `extras` of any JSON type, a binary STL whose
/// header starts like another format.
#[test]
fn case_14_valid_files_that_were_refused_are_read() {
    for normalized in [false, true] {
        for extras in [r#""a string""#, "[1, 2.5, null]", "true", r#"{"k": "v"}"#] {
            let doc = hostile::quantized_tetrahedron(normalized, extras);
            let mesh = load(doc.as_bytes(), None)
                .unwrap_or_else(|e| panic!("normalized {normalized}, extras {extras}: {e}"));
            assert_eq!(mesh.triangles().len(), 4);
            let b = mesh.bounds();
            assert!((b.max.x - 100.0).abs() < 0.01, "{b:?}");
            assert!(b.min.x.abs() < 1e-6, "{b:?}");
        }
    }
    // Compressed geometry is refused by name.
    let draco = hostile::quantized_tetrahedron(false, "1").replace(
        r#""extensionsRequired":["KHR_mesh_quantization"]"#,
        r#""extensionsRequired":["KHR_draco_mesh_compression"]"#,
    );
    let e = load(draco.as_bytes(), None).unwrap_err().to_string();
    assert!(
        e.contains("KHR_draco_mesh_compression") && e.contains("compress"),
        "{e}"
    );
    for header in [&b"glTF binary? no"[..], b"ply\nexported by a CAD tool"] {
        let stl = hostile::stl_with_header(header, &hostile::tetrahedron_faces(1.0));
        assert_eq!(fast_reject::mesh::io::sniff(&stl), Some(Format::Stl));
        let mesh = load(&stl, None).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(mesh.triangles().len(), 4);
        assert!(load(&stl, Some(Format::Stl)).is_ok());
    }
}

/// Case 15: a tiny template in a part thousands of times its size: the
/// windows on its lattice are far too many to list (a 12 GB list aborted
/// the process), so only those near a vertex are listed; past the
/// budget's share the list is refused.
#[test]
fn case_15_a_huge_part_lists_only_the_windows_it_needs() {
    let dir = scratch("huge-part");
    let cube = write(&dir, "cube.stl", hostile::cube(10.0));
    let tet = write(&dir, "tet.stl", hostile::tetrahedron(0.05));
    let out = cli_within(
        &[
            "match",
            &cube,
            "--template",
            &tet,
            "--memory-budget",
            "64",
            "--resolution",
            "256",
            "--json",
        ],
        Duration::from_secs(60),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
}

/// Case 16: the curvature descriptor on a cylinder of slivers and fans,
/// where every vertex's ball holds thousands of triangles and the work
/// grows with the square of the mesh (80 s at 24 000 segments): refused
/// from a sample of the vertices before the search starts, and, where
/// the mesh is too small to sample, once the work passes the limit. A
/// search within the limit finds what an unlimited one finds.
#[test]
fn case_16_the_curvature_search_bounds_its_work() {
    let dir = scratch("fanned");
    let fanned = write(&dir, "fanned.stl", hostile::fanned_cylinder(24_000));
    // Past 20 s, cli_within fails the test.
    let out = cli_within(
        &[
            "match",
            &fanned,
            "--descriptor",
            "curvature",
            "--select",
            "1,0,2,0.3",
        ],
        Duration::from_secs(20),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("curvature search would measure") && err.contains("remesh"),
        "{err}"
    );

    let search_fan = |segments, limit: f64, backend, observer: &mut dyn Observer| {
        let mesh = load(&hostile::fanned_cylinder(segments), None).unwrap();
        let scene = Scene::new(mesh, &SceneOptions::DEFAULT).unwrap();
        let mut options = MatchOptions::DEFAULT;
        options.descriptor = DescriptorKind::Curvature;
        options.max_curvature_work = limit;
        options.backend = backend;
        let selection = TemplateSource::Selection {
            center: [1.0, 0.0, 2.0],
            radius: 0.3,
        };
        search(&scene, &selection, &options, observer)
    };
    // Too few vertices to sample (1 202): the count stops the pass, on any
    // number of threads.
    for backend in [Threads::Serial, Threads::Parallel] {
        let e = search_fan(600, 1e5, backend, &mut ()).unwrap_err();
        assert!(matches!(e, Error::CurvatureTooMuchWork { .. }), "{e}");
    }
    let unlimited = search_fan(600, f64::INFINITY, Threads::Parallel, &mut ()).unwrap();
    let within = search_fan(600, 1e8, Threads::Parallel, &mut ()).unwrap();
    assert!(!unlimited.instances.is_empty());
    assert_eq!(within.instances, unlimited.instances);
    // Enough to sample (6 002): refused before any layer is reported.
    let mut layers = 0;
    let mut count = |_: &fast_reject::LayerStats| {
        layers += 1;
        std::ops::ControlFlow::Continue(())
    };
    let e = search_fan(3000, 1e6, Threads::Parallel, &mut count).unwrap_err();
    assert!(matches!(e, Error::CurvatureTooMuchWork { .. }), "{e}");
    assert_eq!(layers, 0, "the search started before it was refused");
}

/// Case 17: twenty thousand distinct near twins of a tetrahedron, each its
/// own part. Each part is searched on its own (about 25 ms of one core,
/// most of it verifying and aligning the near twin), so the search would
/// take minutes. Refused from a sample of the parts searched first; with
/// parts too few to sample, stopped by the work counted as it is done. A
/// search within the limit, sample and all, finds what an unlimited one
/// finds.
#[test]
fn case_17_the_parts_search_bounds_its_work() {
    let dir = scratch("jittered");
    let scene = write(
        &dir,
        "tetrahedra.stl",
        hostile::jittered_tetrahedra(20_000, 2),
    );
    let template_faces = hostile::right_tetrahedron([0.575, 0.498, 0.425], [0.0; 3]);
    let template = write(&dir, "template.stl", hostile::stl(&template_faces));
    // Past 20 s, cli_within fails the test.
    let out = cli_within(
        &["match", &scene, "--template", &template],
        Duration::from_secs(20),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("distinct parts would take") && err.contains("select it with a sphere"),
        "{err}"
    );

    let search_tetrahedra = |count, limit: f64, observer: &mut dyn Observer| {
        let mesh = load(&hostile::jittered_tetrahedra(count, 3), None).unwrap();
        let scene = Scene::new(mesh, &SceneOptions::DEFAULT).unwrap();
        let template = load(&hostile::stl(&template_faces), None).unwrap();
        let mut options = MatchOptions::DEFAULT;
        options.max_part_work = limit;
        search(&scene, &TemplateSource::Model(template), &options, observer)
    };
    // Enough parts to sample: refused once the sample is searched (the
    // CLI above shows it is refused early).
    let e = search_tetrahedra(200, 1e9, &mut ()).unwrap_err();
    assert!(
        matches!(e, Error::PartsTooMuchWork { parts: 190.., .. }),
        "{e}"
    );
    // Too few to sample: the work counted stops the search.
    let e = search_tetrahedra(60, 1e8, &mut ()).unwrap_err();
    assert!(
        matches!(e, Error::PartsTooMuchWork { parts: 50..=60, .. }),
        "{e}"
    );
    // Within the limit, the sampled parts' instances are the same.
    let unlimited = search_tetrahedra(200, f64::INFINITY, &mut ()).unwrap();
    let within = search_tetrahedra(200, 1e11, &mut ()).unwrap();
    assert!(!unlimited.instances.is_empty());
    assert_eq!(within.instances, unlimited.instances);
}
