//! Helpers shared by the integration tests: the shared scenes and a scorer
//! that follows `../shared/bench/evaluate.py` exactly.

#![allow(dead_code)]

pub mod phase;

use std::path::PathBuf;

use fast_reject::TemplateSource;
use fast_reject::mesh::io::load;
use fast_reject::scene::{Scene, SceneOptions};
use fast_reject::search::{MatchOptions, MatchReport, search};

/// The folder of a shared scene; fails loudly when the shared data is absent,
/// so that a missing checkout can never pass as success.
pub fn scene_dir(name: &str) -> PathBuf {
    let dir = shared_dir().join("scenes").join(name);
    assert!(
        dir.join("truth.json").exists(),
        "shared scene {} not found: this test needs the benchmark data, as ../shared beside \
         the crate or in the folder FAST_REJECT_SHARED names",
        dir.display()
    );
    dir
}

/// `../shared`, or FAST_REJECT_SHARED: for sandboxes (wasmtime) that
/// cannot follow ../shared by its path, and binaries run elsewhere.
pub fn shared_dir() -> PathBuf {
    std::env::var("FAST_REJECT_SHARED").map_or_else(
        |_| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared"),
        PathBuf::from,
    )
}

/// The bytes of a shared model (`../shared/models`), failing loudly when
/// the shared data is absent.
pub fn model_bytes(file: &str) -> Vec<u8> {
    let path = shared_dir().join("models").join(file);
    std::fs::read(&path).unwrap_or_else(|e| panic!("shared model {}: {e}", path.display()))
}

pub fn truth(name: &str) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(scene_dir(name).join("truth.json")).unwrap()).unwrap()
}

/// A scene's selection sphere: centre and radius.
pub fn selection(name: &str) -> ([f64; 3], f64) {
    let s = &truth(name)["select"];
    let c = &s["center"];
    (
        [0, 1, 2].map(|i| c[i].as_f64().unwrap()),
        s["radius"].as_f64().unwrap(),
    )
}

/// A scene's selection sphere as the CLI's "X,Y,Z,R".
pub fn select_arg(name: &str) -> String {
    let (c, r) = selection(name);
    format!("{},{},{},{r}", c[0], c[1], c[2])
}

/// The template of a scene: its model, or with `select` its selection sphere.
pub fn template(name: &str, select: bool) -> TemplateSource {
    let dir = scene_dir(name);
    if select {
        let (center, radius) = selection(name);
        TemplateSource::Selection { center, radius }
    } else {
        TemplateSource::Model(
            load(&std::fs::read(dir.join("template.glb")).unwrap(), None).unwrap(),
        )
    }
}

pub fn scene(name: &str, options: &SceneOptions) -> Scene {
    let mesh = load(
        &std::fs::read(scene_dir(name).join("scene.glb")).unwrap(),
        None,
    )
    .unwrap();
    Scene::new(mesh, options).unwrap()
}

/// Runs the matcher with default parameters.
pub fn run(name: &str, select: bool) -> MatchReport {
    run_with(name, select, &MatchOptions::DEFAULT)
}

/// Runs the matcher with `options`.
pub fn run_with(name: &str, select: bool, options: &MatchOptions) -> MatchReport {
    search(
        &scene(name, &SceneOptions::DEFAULT),
        &template(name, select),
        options,
        &mut (),
    )
    .unwrap()
}

/// What evaluate.py prints: recall, true positives, false positives, targets.
#[derive(Debug, PartialEq)]
pub struct Score {
    pub recall: f64,
    pub tp: usize,
    pub fp: usize,
    pub targets: usize,
}

/// `p` moved by the row-major 4x4 transform `t` (a truth's or a pose).
pub fn apply(t: &serde_json::Value, p: [f64; 3]) -> [f64; 3] {
    let m = |r: usize, c: usize| t[r][c].as_f64().unwrap();
    [0, 1, 2].map(|r| m(r, 0) * p[0] + m(r, 1) * p[1] + m(r, 2) * p[2] + m(r, 3))
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

fn compose(a: &serde_json::Value, b: &serde_json::Value) -> serde_json::Value {
    let m = |t: &serde_json::Value, r: usize, c: usize| t[r][c].as_f64().unwrap();
    serde_json::json!(
        (0..4)
            .map(|r| (0..4)
                .map(|c| (0..4).map(|k| m(a, r, k) * m(b, k, c)).sum::<f64>())
                .collect::<Vec<f64>>())
            .collect::<Vec<_>>()
    )
}

/// How far the reported poses are from the truth: for every instance, the
/// truth placement (through any of the template's symmetries) that puts
/// c_T nearest to where the pose puts it, and among those that put it
/// there, the nearest rotation. Returns the worst rotation (degrees) and
/// the worst distance between the two c_T (a share of r_k). Panics when an
/// instance has no pose.
pub fn worst_pose_error(truth: &serde_json::Value, report: &MatchReport) -> (f64, f64) {
    let (c, r) = (report.template.center, report.template.radius);
    let symmetries: Vec<Option<&serde_json::Value>> = match truth.get("template_symmetries") {
        Some(serde_json::Value::Array(s)) if !s.is_empty() => s.iter().map(Some).collect(),
        _ => vec![None],
    };
    let mut truths = Vec::new();
    for t in truth["instances"].as_array().unwrap() {
        for s in &symmetries {
            truths.push(match s {
                None => t["transform"].clone(),
                Some(s) => compose(&t["transform"], s),
            });
        }
    }
    let (mut angle, mut shift): (f64, f64) = (0.0, 0.0);
    for instance in &report.instances {
        let pose = serde_json::json!(instance.pose.expect("a voxel search reports a pose"));
        let at = apply(&pose, c);
        let nearest = truths
            .iter()
            .map(|t| dist(at, apply(t, c)))
            .fold(f64::INFINITY, f64::min);
        let turn = truths
            .iter()
            .filter(|t| dist(at, apply(t, c)) <= nearest + 1e-9 * r.max(1.0))
            .map(|t| rotation_angle(&pose, t))
            .fold(f64::INFINITY, f64::min);
        angle = angle.max(turn);
        shift = shift.max(nearest / r);
    }
    (angle, shift)
}

/// The angle (degrees) of the rotation between two transforms' rotation
/// parts, each normalized column by column (a truth may carry a scale).
fn rotation_angle(a: &serde_json::Value, b: &serde_json::Value) -> f64 {
    let unit = |t: &serde_json::Value| {
        let m = |r: usize, c: usize| t[r][c].as_f64().unwrap();
        let norm = |c: usize| (0..3).map(|r| m(r, c).powi(2)).sum::<f64>().sqrt();
        [0, 1, 2].map(|r| [0, 1, 2].map(|c| m(r, c) / norm(c)))
    };
    let (a, b) = (unit(a), unit(b));
    let trace: f64 = (0..3)
        .flat_map(|r| (0..3).map(move |k| (r, k)))
        .map(|(r, k)| a[r][k] * b[r][k])
        .sum();
    ((trace - 1.0) / 2.0).clamp(-1.0, 1.0).acos().to_degrees()
}

/// Scores a report against a scene's truth the way evaluate.py does.
pub fn score(truth: &serde_json::Value, report: &MatchReport, select: bool) -> Score {
    let tol = truth
        .get("tolerance")
        .and_then(|t| t.as_f64())
        .unwrap_or(0.2);
    // Per target, the places its c_T may be reported at: through any of
    // the template's symmetries.
    let (targets, radius): (Vec<Vec<[f64; 3]>>, f64) = if select {
        let s = &truth["select"];
        let t = s["expected"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| vec![[0, 1, 2].map(|i| e[i].as_f64().unwrap())])
            .collect();
        (t, s["radius"].as_f64().unwrap())
    } else {
        let c = report.template.center;
        let centres: Vec<[f64; 3]> = match truth.get("template_symmetries") {
            Some(serde_json::Value::Array(s)) if !s.is_empty() => {
                s.iter().map(|s| apply(s, c)).collect()
            }
            _ => vec![c],
        };
        let t = truth["instances"]
            .as_array()
            .unwrap()
            .iter()
            .map(|i| centres.iter().map(|&c| apply(&i["transform"], c)).collect())
            .collect();
        (
            t,
            truth
                .get("template_radius")
                .and_then(|r| r.as_f64())
                .unwrap_or(1.0),
        )
    };
    let near: Vec<Vec<bool>> = report
        .instances
        .iter()
        .map(|i| {
            targets
                .iter()
                .map(|t| t.iter().any(|&t| dist(i.position, t) < tol * radius))
                .collect()
        })
        .collect();
    let tp = (0..targets.len())
        .filter(|&j| near.iter().any(|row| row[j]))
        .count();
    let fp = near.iter().filter(|row| !row.iter().any(|&b| b)).count();
    Score {
        recall: tp as f64 / targets.len() as f64,
        tp,
        fp,
        targets: targets.len(),
    }
}

/// Asserts that `report` found every instance of scene `name` and nothing
/// else, as evaluate.py would.
pub fn assert_finds_everything(name: &str, select: bool, report: &MatchReport) {
    let s = score(&truth(name), report, select);
    assert_eq!(
        (s.tp, s.fp),
        (s.targets, 0),
        "{name}: {s:?}; instances reported: {:#?}",
        report.instances
    );
}

/// `model` searched in `scene` with the default options.
pub fn search_model(scene: &Scene, model: fast_reject::TriMesh) -> MatchReport {
    search(
        scene,
        &TemplateSource::Model(model),
        &MatchOptions::DEFAULT,
        &mut (),
    )
    .unwrap()
}

/// A shared model centred on its box and scaled so that half the box's
/// diagonal is `radius`.
pub fn scaled_model(file: &str, radius: f64) -> fast_reject::TriMesh {
    let mesh = load(&model_bytes(file), None).unwrap();
    let b = mesh.bounds();
    let (centre, half) = (b.center(), b.extent().length() / 2.0);
    mesh.map_positions(|p| (p - centre) * (radius / half))
        .unwrap()
}

/// Asserts that every point of `truth` has an instance within `tolerance`
/// of it, and that nothing else was found.
pub fn assert_found_exactly(
    report: &MatchReport,
    truth: &[fast_reject::math::Vec3],
    tolerance: f64,
) {
    let found: Vec<fast_reject::math::Vec3> = report
        .instances
        .iter()
        .map(|i| fast_reject::math::Vec3::from_array(i.position))
        .collect();
    for (i, t) in truth.iter().enumerate() {
        assert!(
            found.iter().any(|p| p.distance(*t) < tolerance),
            "copy {i} missed: found {found:?}"
        );
    }
    assert_eq!(found.len(), truth.len(), "a false hit: {found:?}");
}

/// Whether every node of a written GLB is placed as glTF allows: a matrix
/// of perpendicular axes none of zero length (anything else is written
/// as translation, rotation and scale).
pub fn nodes_are_turns_and_scales(glb: &[u8]) -> Result<(), String> {
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let json: serde_json::Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    for (n, node) in json["nodes"].as_array().unwrap().iter().enumerate() {
        let Some(m) = node["matrix"].as_array() else {
            continue;
        };
        let m: Vec<f64> = m.iter().map(|v| v.as_f64().unwrap()).collect();
        let axes: Vec<fast_reject::math::Vec3> = (0..3)
            .map(|c| fast_reject::math::Vec3::new(m[4 * c], m[4 * c + 1], m[4 * c + 2]))
            .collect();
        if axes.iter().any(|a| a.length() == 0.0) {
            return Err(format!("node {n}: a singular matrix {m:?}"));
        }
        for (i, j) in [(0, 1), (0, 2), (1, 2)] {
            let cos = axes[i].normalize().dot(axes[j].normalize());
            if cos.abs() > 1e-5 {
                return Err(format!("node {n}: a sheared matrix {m:?}"));
            }
        }
    }
    Ok(())
}
