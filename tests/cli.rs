//! The command-line tool: the JSON contract of DESIGN.md, the demo, and
//! errors a person can act on.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn cli(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fast-reject"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn path_str(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn match_prints_the_json_contract() {
    let dir = common::scene_dir("select-cow-head");
    let scene = dir.join("scene.glb");
    let select = common::select_arg("select-cow-head");
    let out = cli(&["match", path_str(&scene), "--select", &select, "--json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("one JSON object on stdout");
    assert_eq!(v["template"]["center"].as_array().unwrap().len(), 3);
    assert!(v["template"]["radius"].as_f64().unwrap() > 0.0);
    let inst = v["instances"].as_array().unwrap();
    assert_eq!(inst.len(), 5);
    for i in inst {
        assert_eq!(i["position"].as_array().unwrap().len(), 3);
        assert!(i["distance"].is_number() && i["support"].is_u64());
    }
    let stages = v["stages"].as_array().unwrap();
    assert_eq!(
        stages.len(),
        18,
        "six layers each of volume, centroid and harmonics"
    );
    for key in [
        "descriptor",
        "layer",
        "radius",
        "candidates",
        "survivors",
        "ms",
    ] {
        assert!(
            stages.iter().all(|s| !s[key].is_null()),
            "stages lack {key}"
        );
    }
    assert_eq!(stages[0]["descriptor"], "volume");
    // The scene's 512, or finer where the template is small.
    assert!(v["grid"]["resolution"].as_u64().unwrap() >= 512);
    assert!(
        v["grid"]["voxel_size"].as_f64().unwrap() > 0.0
            && v["grid"]["skin_voxels"].as_u64().unwrap() > 0
    );
    for key in ["load", "voxelize", "template", "match", "group", "total"] {
        assert!(
            v["timings_ms"][key].as_f64().unwrap() >= 0.0,
            "timings lack {key}"
        );
    }
}

#[test]
fn the_demo_finds_its_three_mugs() {
    let out = cli(&["demo", "--json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_finds_the_demo_mugs(&v, 0.2);
    // Without --json it prints a readable table.
    let out = cli(&["demo"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("3 instance(s)") && text.contains("harmonics"),
        "{text}"
    );
}

#[test]
fn curvature_finds_the_demo_mugs_on_the_mesh() {
    let demo = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/demo");
    let (scene, template) = (format!("{demo}/scene.glb"), format!("{demo}/template.glb"));
    let out = cli(&[
        "match",
        &scene,
        "--template",
        &template,
        "--descriptor",
        "curvature",
        "--json",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // The mug's body is a surface of revolution: every point around it has
    // the same curvatures, so the instance's point may lie anywhere on its
    // mug (within the mug's radius of c_T), but each mug once.
    assert_finds_the_demo_mugs(&v, 1.0);
    assert!(v["grid"].is_null(), "no voxels for curvature");
    assert!(v["surface"]["vertices"].as_u64().unwrap() > 0);
    assert_eq!(v["stages"][0]["descriptor"], "curvature");
    assert!(v["instances"][0]["score"].is_null());
}

/// Every mug has an instance within `tolerance` of its c_T.
fn assert_finds_the_demo_mugs(v: &serde_json::Value, tolerance: f64) {
    let truth: serde_json::Value = serde_json::from_slice(
        &std::fs::read(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/assets/demo/truth.json"
        ))
        .unwrap(),
    )
    .unwrap();
    let c: Vec<f64> = v["template"]["center"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let targets: Vec<[f64; 3]> = truth["instances"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| {
            let t = &i["transform"];
            let m = |r: usize, k: usize| t[r][k].as_f64().unwrap();
            [0, 1, 2].map(|r| m(r, 0) * c[0] + m(r, 1) * c[1] + m(r, 2) * c[2] + m(r, 3))
        })
        .collect();
    let found: Vec<[f64; 3]> = v["instances"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| [0, 1, 2].map(|k| i["position"][k].as_f64().unwrap()))
        .collect();
    assert_eq!(found.len(), 3, "{found:?}");
    for t in &targets {
        assert!(
            found
                .iter()
                .any(|f| (0..3).map(|k| (f[k] - t[k]).powi(2)).sum::<f64>().sqrt() < tolerance),
            "no instance near {t:?}"
        );
    }
}

/// Splits a .glb into a .gltf with its buffer in a .bin beside it.
fn glb_to_gltf(glb: &[u8], dir: &Path, stem: &str) -> PathBuf {
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let mut json: serde_json::Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    let bin_start = 20 + json_len;
    let bin_len = u32::from_le_bytes(glb[bin_start..bin_start + 4].try_into().unwrap()) as usize;
    let bin = &glb[bin_start + 8..bin_start + 8 + bin_len];
    json["buffers"][0]["uri"] = serde_json::Value::String(format!("{stem}.bin"));
    std::fs::write(dir.join(format!("{stem}.bin")), bin).unwrap();
    let path = dir.join(format!("{stem}.gltf"));
    std::fs::write(&path, serde_json::to_vec(&json).unwrap()).unwrap();
    path
}

#[test]
fn a_gltf_reads_the_bin_beside_it() {
    let demo = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/demo");
    let dir = scratch("gltf-beside");
    let scene = glb_to_gltf(
        &std::fs::read(format!("{demo}/scene.glb")).unwrap(),
        &dir,
        "scene",
    );
    let template = glb_to_gltf(
        &std::fs::read(format!("{demo}/template.glb")).unwrap(),
        &dir,
        "template",
    );
    let out = cli(&[
        "match",
        path_str(&scene),
        "--template",
        path_str(&template),
        "--json",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["instances"].as_array().unwrap().len(), 3);
    // Without its .bin, the message says what is missing and what to do.
    std::fs::remove_file(dir.join("template.bin")).unwrap();
    let out = cli(&["match", path_str(&scene), "--template", path_str(&template)]);
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("template.bin") && stderr(&out).contains("beside"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn the_parts_work_limit_is_set_on_the_command_line() {
    // The demo's seven distinct parts take about 1e8 units to search: a
    // limit of 1 refuses them (within the first part's layers) and says
    // which flag raises it; a limit far above finds the mugs as the
    // default does.
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/demo/scene.glb");
    let template = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/demo/template.glb");
    let args = |limit| {
        [
            "match",
            scene,
            "--template",
            template,
            "--json",
            "--max-part-work",
            limit,
        ]
    };
    let out = cli(&args("1"));
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("passed its work limit") && stderr(&out).contains("--max-part-work"),
        "{}",
        stderr(&out)
    );
    let out = cli(&args("1e15"));
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_finds_the_demo_mugs(&v, 0.2);
}

#[test]
fn plan_tells_the_parts_and_the_least_time_without_searching() {
    // The demo's seven distinct parts; a limit below their least work is
    // said to refuse the search, which --plan does not run.
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/demo/scene.glb");
    let template = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/demo/template.glb");
    let plan = |more: &[&str]| {
        let mut args = vec!["match", scene, "--template", template, "--plan"];
        args.extend_from_slice(more);
        cli(&args)
    };
    let out = plan(&["--json", "--threads", "1"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["distinct_parts"], 7, "{v}");
    assert!(v["parts"].as_u64().unwrap() >= 7, "{v}");
    assert_eq!(v["threads"], 1);
    let (work, seconds) = (
        v["least_work"].as_f64().unwrap(),
        v["least_seconds"].as_f64().unwrap(),
    );
    assert!(work > 0.0 && (seconds - work / 1e9).abs() < 1e-9, "{v}");
    assert_eq!(v["over_limit"], false);
    let refused = plan(&["--json", "--max-part-work", "1"]);
    let v: serde_json::Value = serde_json::from_slice(&refused.stdout).unwrap();
    assert_eq!(v["over_limit"], true);
    let table = plan(&[]);
    let text = String::from_utf8_lossy(&table.stdout);
    assert!(
        text.starts_with("parts that can hold a copy:") && !text.contains("instances"),
        "{text}"
    );
    let curvature = plan(&["--json", "--descriptor", "curvature"]);
    assert_eq!(String::from_utf8_lossy(&curvature.stdout).trim(), "null");
}

#[test]
fn errors_exit_non_zero_with_a_message() {
    let dir = scratch("cli-errors");
    let garbage = dir.join("garbage.glb");
    std::fs::write(&garbage, b"glTF\x02\x00\x00\x00not really").unwrap();
    let demo_scene = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/demo/scene.glb");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["match", "/no/such/scene.glb", "--template", demo_scene],
            "cannot read '/no/such/scene.glb'",
        ),
        (
            vec!["match", path_str(&garbage), "--template", demo_scene],
            "malformed glTF",
        ),
        (
            vec!["match", demo_scene, "--select", "1,2,3"],
            "four numbers",
        ),
        (
            vec!["match", demo_scene, "--select", "100,100,100,0.5"],
            "touches no surface",
        ),
        (
            vec![
                "match",
                demo_scene,
                "--select",
                "0,0,0,0.5",
                "--resolution",
                "16384",
            ],
            "lower the resolution",
        ),
        (
            vec![
                "match",
                demo_scene,
                "--select",
                "0,0,0,0.5",
                "--threads",
                "0",
            ],
            "--threads",
        ),
        // An option is named by its flag, not in the core's words.
        (
            vec![
                "match",
                demo_scene,
                "--select",
                "0,0,0,0.5",
                "--volume-threshold=-1",
            ],
            "invalid option --volume-threshold: must be a positive number",
        ),
    ];
    for (args, expected) in cases {
        let out = cli(&args);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(out.stdout.is_empty(), "{args:?} printed to stdout");
        assert!(
            stderr(&out).contains(expected),
            "{args:?}: {}",
            stderr(&out)
        );
    }
    // Neither --template nor --select: a usage error from the parser.
    let out = cli(&["match", demo_scene]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("--template"), "{}", stderr(&out));
}

#[test]
fn one_thread_gives_the_same_instances() {
    let demo = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/demo");
    let args = |threads: &'static str| {
        vec![
            "match".to_string(),
            format!("{demo}/scene.glb"),
            "--template".into(),
            format!("{demo}/template.glb"),
            "--json".into(),
            "--threads".into(),
            threads.into(),
        ]
    };
    let run = |t| {
        let a = args(t);
        let out = Command::new(env!("CARGO_BIN_EXE_fast-reject"))
            .args(&a)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", stderr(&out));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        v["instances"].clone()
    };
    assert_eq!(run("1"), run("2"));
}

#[test]
fn a_file_is_read_by_its_content_before_its_extension() {
    // A binary glTF saved as .obj is still found in.
    let dir = common::scene_dir("zoo-bunny");
    let misnamed = scratch("misnamed").join("scene.obj");
    std::fs::copy(dir.join("scene.glb"), &misnamed).unwrap();
    let template = dir.join("template.glb");
    let out = cli(&[
        "match",
        path_str(&misnamed),
        "--template",
        path_str(&template),
        "--json",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["instances"].as_array().unwrap().len(), 4);
    // Content no loader recognizes is left to the extension's parser.
    let text = scratch("misnamed").join("notes.obj");
    std::fs::write(&text, "hello\n").unwrap();
    let out = cli(&["match", path_str(&text), "--template", path_str(&template)]);
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("notes.obj': the mesh has no triangles"),
        "{}",
        stderr(&out)
    );
}

#[test]
#[cfg_attr(skip_gpu_tests, ignore = "FAST_REJECT_SKIP_GPU=1: needs a GPU adapter")]
fn the_gpu_backend_names_its_adapter_and_finds_the_same_mugs() {
    let demo = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/demo");
    let (scene, template) = (format!("{demo}/scene.glb"), format!("{demo}/template.glb"));
    let search = |backend: &str, json: bool| {
        let mut args = vec![
            "match",
            &scene,
            "--template",
            &template,
            "--backend",
            backend,
        ];
        args.extend(json.then_some("--json"));
        cli(&args)
    };
    let run = |backend: &str| -> serde_json::Value {
        let out = search(backend, true);
        assert!(
            out.status.success(),
            "--backend {backend}: {}",
            stderr(&out)
        );
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let (cpu, gpu) = (run("cpu"), run("gpu"));
    assert!(cpu["gpu"].is_null());
    // auto takes a hardware adapter only: lavapipe, the tests' one, is
    // software, so the CPU runs.
    if gpu["gpu"]["adapter"].as_str().unwrap().contains("software") {
        assert!(run("auto")["gpu"].is_null());
        // The table says where auto ran.
        let table = String::from_utf8_lossy(&search("auto", false).stdout).into_owned();
        assert!(
            table.contains(
                "harmonics layers on the CPU: --backend auto found no hardware GPU adapter"
            ),
            "{table}"
        );
    }
    assert!(!gpu["gpu"]["adapter"].as_str().unwrap().is_empty());
    assert!(gpu["gpu"]["fallback"].is_null());
    let harmonics = cpu["stages"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| s["descriptor"] == "harmonics");
    assert_eq!(harmonics.count(), 6);
    let positions = |v: &serde_json::Value| -> Vec<serde_json::Value> {
        v["instances"]
            .as_array()
            .unwrap()
            .iter()
            .map(|i| i["position"].clone())
            .collect()
    };
    assert_eq!(positions(&cpu), positions(&gpu));
    assert_finds_the_demo_mugs(&gpu, 0.2);
}

#[test]
fn progress_goes_to_standard_error_when_asked_and_only_then() {
    let demo = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/demo");
    let (scene, template) = (format!("{demo}/scene.glb"), format!("{demo}/template.glb"));
    let args = ["match", &scene, "--template", &template, "--json"];
    // Standard error is a pipe here, not a terminal: silent by default.
    let quiet = cli(&args);
    assert!(quiet.status.success(), "{}", stderr(&quiet));
    assert_eq!(stderr(&quiet), "");
    let told = cli(&[&args[..], &["--progress"]].concat());
    assert!(told.status.success(), "{}", stderr(&told));
    let log = stderr(&told);
    for phase in [
        "loading the scene",
        "loading the template",
        "preparing the scene",
        "searching",
    ] {
        assert!(log.contains(phase), "no '{phase}' in:\n{log}");
    }
    // Plain lines for a log: no carriage return, no escape sequence.
    assert!(!log.contains(['\r', '\x1b']), "{log:?}");
    // The report itself is the same.
    let report = |o: &Output| {
        let mut v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        v.as_object_mut().unwrap().remove("timings_ms");
        v["stages"]
            .as_array_mut()
            .unwrap()
            .iter_mut()
            .for_each(|s| {
                s.as_object_mut().unwrap().remove("ms");
            });
        v
    };
    assert_eq!(report(&quiet), report(&told));
}

#[test]
fn repeats_lists_the_demo_mugs_as_one_part_of_three_copies() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/demo/scene.glb");
    let out = cli(&["repeats", scene, "--json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let families = v["families"].as_array().unwrap();
    assert_eq!(families.len(), 1);
    let copies = families[0]["copies"].as_array().unwrap();
    assert_eq!(copies.len(), 3);
    // Each pose is a rigid motion, and the three put the mug in three
    // places.
    let mut places = Vec::new();
    for copy in copies {
        let m: Vec<Vec<f64>> = serde_json::from_value(copy["pose"].clone()).unwrap();
        let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        assert!((det - 1.0).abs() < 1e-9, "{m:?}");
        places.push([m[0][3], m[1][3], m[2][3]]);
    }
    assert!(
        places
            .iter()
            .enumerate()
            .all(|(i, p)| places[..i].iter().all(|q| p != q))
    );

    // Silent on a pipe; with --progress, each phase on standard error.
    assert_eq!(stderr(&out), "");
    let out_glb = std::env::temp_dir().join(format!("fr-repeats-{}.glb", std::process::id()));
    let out_path = out_glb.to_str().unwrap();
    let told = cli(&["repeats", scene, "--progress", "--out", out_path]);
    let _ = std::fs::remove_file(&out_glb);
    assert!(told.status.success(), "{}", stderr(&told));
    let log = stderr(&told);
    for phase in [
        "loading the scene",
        "finding repeated parts",
        "writing the instanced file",
    ] {
        assert!(log.contains(phase), "no '{phase}' in:\n{log}");
    }

    let out = cli(&["repeats", scene]);
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("1 repeated part, 3 copies"));
    let out = cli(&["repeats", "/no/such/scene.glb"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("cannot read"), "{}", stderr(&out));
}
