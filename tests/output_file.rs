//! `repeats --out` never destroys data: it refuses to write over the
//! input or a file the input reads, whatever the spelling, and a write
//! that fails or is killed leaves the previous file whole and no
//! fragment beside it.

mod common;
#[path = "common/hostile.rs"]
mod hostile;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use fast_reject::mesh::io::load;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_fast-reject"))
}

fn run(args: &[&str], dir: &Path) -> Output {
    bin().args(args).current_dir(dir).output().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// An empty folder of its own for each test.
fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("output-file")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The embedded demo's scene: three mugs, so `repeats --out` writes.
fn demo_scene() -> Vec<u8> {
    std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/demo/scene.glb")).unwrap()
}

/// The names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// A GLB's JSON and binary chunks.
fn glb_chunks(glb: &[u8]) -> (serde_json::Value, Vec<u8>) {
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let json = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    let bin_at = 20 + json_len;
    let bin_len = u32::from_le_bytes(glb[bin_at..bin_at + 4].try_into().unwrap()) as usize;
    (json, glb[bin_at + 8..bin_at + 8 + bin_len].to_vec())
}

#[test]
fn the_input_is_never_written_over_by_any_spelling_or_link() {
    let dir = scratch("refused");
    let scene = demo_scene();
    std::fs::write(dir.join("in.glb"), &scene).unwrap();
    std::fs::create_dir(dir.join("sub")).unwrap();
    std::fs::write(dir.join("sub/in.glb"), &scene).unwrap();
    #[cfg(unix)]
    std::os::unix::fs::symlink(dir.join("in.glb"), dir.join("link.glb")).unwrap();
    std::fs::hard_link(dir.join("in.glb"), dir.join("hard.glb")).unwrap();
    let mut spellings = vec![
        ("in.glb", "in.glb"),
        ("in.glb", "./in.glb"),
        ("sub/in.glb", "sub/../sub/in.glb"),
        ("in.glb", "hard.glb"),
    ];
    if cfg!(unix) {
        spellings.push(("in.glb", "link.glb"));
        spellings.push(("link.glb", "in.glb"));
    }
    for (input, out) in spellings {
        let told = run(&["repeats", input, "--out", out], &dir);
        assert_eq!(told.status.code(), Some(1), "{input} --out {out}");
        assert!(
            stderr(&told).contains("--replace-input"),
            "{input} --out {out}: {}",
            stderr(&told)
        );
        for file in ["in.glb", "sub/in.glb"] {
            assert_eq!(
                std::fs::read(dir.join(file)).unwrap(),
                scene,
                "{input} --out {out}"
            );
        }
    }
    // An OBJ onto itself, refused before any work.
    let obj = dir.join("part.obj");
    let bytes =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/icosphere.obj"))
            .unwrap();
    std::fs::write(&obj, &bytes).unwrap();
    let told = run(&["repeats", "part.obj", "--out", "part.obj"], &dir);
    assert_eq!(told.status.code(), Some(1), "{}", stderr(&told));
    assert_eq!(std::fs::read(&obj).unwrap(), bytes);

    // Said on purpose, the input is replaced, by a whole file.
    let told = run(
        &["repeats", "in.glb", "--out", "in.glb", "--replace-input"],
        &dir,
    );
    assert!(told.status.success(), "{}", stderr(&told));
    let written = std::fs::read(dir.join("in.glb")).unwrap();
    assert_ne!(written, scene);
    assert_eq!(
        load(&written, None).unwrap().triangles().len(),
        load(&scene, None).unwrap().triangles().len()
    );
    // The hard link still holds the old file: a new file took the name.
    assert_eq!(std::fs::read(dir.join("hard.glb")).unwrap(), scene);
    assert_eq!(
        names(&dir),
        ["hard.glb", "in.glb", "link.glb", "part.obj", "sub"]
    );
}

#[test]
fn a_gltf_s_own_buffer_is_not_written_over() {
    let dir = scratch("buffer");
    let (mut json, bin) = glb_chunks(&demo_scene());
    json["buffers"][0]["uri"] = "scene.bin".into();
    std::fs::write(dir.join("scene.gltf"), json.to_string()).unwrap();
    std::fs::write(dir.join("scene.bin"), &bin).unwrap();
    let told = run(&["repeats", "scene.gltf", "--out", "scene.bin"], &dir);
    assert_eq!(told.status.code(), Some(1), "{}", stderr(&told));
    assert!(stderr(&told).contains("scene.bin"), "{}", stderr(&told));
    assert_eq!(std::fs::read(dir.join("scene.bin")).unwrap(), bin);
    // And the .gltf still loads.
    let told = run(&["repeats", "scene.gltf", "--out", "out.glb"], &dir);
    assert!(told.status.success(), "{}", stderr(&told));
}

#[test]
fn a_write_past_the_file_size_limit_leaves_the_previous_output_whole() {
    let dir = scratch("size-limit");
    std::fs::write(dir.join("in.glb"), demo_scene()).unwrap();
    let before = b"the previous output".repeat(10);
    std::fs::write(dir.join("out.glb"), &before).unwrap();
    let bin = env!("CARGO_BIN_EXE_fast-reject");
    // 8 blocks: kilobytes, far less than the instanced demo.
    let told = Command::new("sh")
        .args([
            "-c",
            &format!("ulimit -f 8 && exec '{bin}' repeats in.glb --out out.glb"),
        ])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert_eq!(told.status.code(), Some(1), "{}", stderr(&told));
    assert!(
        stderr(&told).contains("cannot write 'out.glb'"),
        "{}",
        stderr(&told)
    );
    assert_eq!(std::fs::read(dir.join("out.glb")).unwrap(), before);
    assert_eq!(names(&dir), ["in.glb", "out.glb"]);
}

#[test]
fn a_write_killed_as_it_starts_leaves_the_previous_output_whole() {
    let dir = scratch("killed");
    let scene = common::scene_dir("real-saw-roller").join("scene.glb");
    let before = b"the previous output".repeat(10);
    // The signal as the write phase begins, and a few milliseconds into it
    // (the GLB built, then the file written).
    let delays = [0, 2, 5, 10, 20];
    for (signal, delay) in ["TERM", "INT", "KILL", "HUP"]
        .into_iter()
        .flat_map(|s| delays.map(|d| (s, d)))
    {
        std::fs::write(dir.join("out.glb"), &before).unwrap();
        let mut child = bin()
            .args([
                "repeats",
                scene.to_str().unwrap(),
                "--progress",
                "--out",
                "out.glb",
            ])
            .current_dir(&dir)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let lines = BufReader::new(child.stderr.take().unwrap());
        for line in lines.lines() {
            if line.unwrap().contains("writing the instanced file") {
                break;
            }
        }
        std::thread::sleep(std::time::Duration::from_millis(delay));
        let killed = Command::new("kill")
            .args([&format!("-{signal}"), &child.id().to_string()])
            .status()
            .unwrap();
        assert!(killed.success());
        let status = child.wait().unwrap();
        let now = std::fs::read(dir.join("out.glb")).unwrap();
        // Killed before the rename: the old file; after it: a whole one.
        if now != before {
            assert!(
                load(&now, None).is_ok(),
                "{signal} +{delay} ms: a fragment at the target"
            );
        }
        assert_eq!(names(&dir), ["out.glb"], "{signal} +{delay} ms: {status:?}");
    }
}

#[test]
fn hidden_flat_sheared_and_gpu_instanced_nodes_are_written_valid_and_whole() {
    let dir = scratch("nodes");
    let inputs = [
        ("sheared.gltf", hostile::hidden_flat_and_sheared_boxes()),
        ("instanced.gltf", hostile::gpu_instanced_boxes()),
    ];
    for (name, text) in inputs {
        std::fs::write(dir.join(name), &text).unwrap();
        let input = load(text.as_bytes(), None).unwrap();
        for gpu in [false, true] {
            let mut args = vec!["repeats", name, "--json", "--out", "out.glb"];
            if gpu {
                args.push("--gpu-instancing");
            }
            let told = run(&args, &dir);
            assert!(told.status.success(), "{name}: {}", stderr(&told));
            let report: serde_json::Value = serde_json::from_slice(&told.stdout).unwrap();
            // The three plain boxes (all three instances) are one part.
            assert_eq!(
                report["families"][0]["copies"].as_array().unwrap().len(),
                3,
                "{name}"
            );
            let written = std::fs::read(dir.join("out.glb")).unwrap();
            common::nodes_are_turns_and_scales(&written).unwrap_or_else(|e| panic!("{name}: {e}"));
            let output = load(&written, None).unwrap();
            assert_eq!(output.triangles().len(), input.triangles().len(), "{name}");
            let sorted = |m: &fast_reject::mesh::TriMesh| {
                let mut corners: Vec<[i64; 3]> = m
                    .positions()
                    .iter()
                    .map(|p| p.map(|x| (f64::from(x) * 1e4).round() as i64))
                    .collect();
                corners.sort_unstable();
                corners.dedup();
                corners
            };
            assert_eq!(sorted(&output), sorted(&input), "{name}: drawn elsewhere");
        }
    }
}
