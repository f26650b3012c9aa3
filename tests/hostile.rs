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

use fast_reject::mesh::io::load;
use fast_reject::scene::{Scene, SceneOptions};
use fast_reject::search::{MatchOptions, search};
use fast_reject::template::TemplateSource;
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
    // A radius of the scene's size at resolution 1024: a thousand voxels.
    let scene = small_scene(1024);
    let whole = TemplateSource::Selection {
        center: [0.0; 3],
        radius: 1.0,
    };
    let e = search(&scene, &whole, &MatchOptions::DEFAULT, &mut ()).unwrap_err();
    assert!(matches!(e, Error::OverBudget { .. }), "{e}");
    assert!(e.to_string().contains("ball tables"), "{e}");
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
    let demo = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/demo");
    let (scene, template) = (format!("{demo}/scene.glb"), format!("{demo}/template.glb"));
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
