//! Does a search depend on where the voxel grid falls? A scene moved by
//! random sub-voxel offsets and turned about its centre, searched and
//! scored against the truth moved the same way (the real-scenes issue's
//! phase test; `experiments/grid_phase.rs` prints it, `tests/phase.rs`
//! asserts it).

use std::path::Path;
use std::time::Instant;

use fast_reject::math::Vec3;
use fast_reject::{MatchOptions, Scene, SceneOptions, TemplateSource, load, search};
use serde_json::Value;

/// A row-major 4x4 transform.
type Matrix = [[f64; 4]; 4];

/// One placement's outcome.
pub struct Trial {
    /// The sub-voxel offset, in voxels.
    pub offset: Vec3,
    /// Copies found, of how many.
    pub found: usize,
    pub copies: usize,
    /// Each false hit: its distance to the nearest copy (a share of the
    /// template's radius) and its verification score.
    pub false_hits: Vec<(f64, f64)>,
    /// Milliseconds from the moved mesh to the report.
    pub ms: f64,
    /// The search's error, if it failed.
    pub error: Option<String>,
}

impl Trial {
    /// Every copy found and nothing else.
    pub fn clean(&self) -> bool {
        self.error.is_none() && self.found == self.copies && self.false_hits.is_empty()
    }
}

/// `trials` placements of the scene in `dir` (scene.glb, truth.json, and
/// template.glb unless truth.json holds a selection), from `seed`: each
/// moved by a random offset of up to a voxel of `scene_options`' grid
/// and, with `turn`, turned about the scene's centre. `each` sees every
/// trial as it ends.
pub fn placements(
    dir: &Path,
    trials: usize,
    seed: u64,
    turn: bool,
    scene_options: &SceneOptions,
    options: &MatchOptions,
    mut each: impl FnMut(usize, &Trial),
) -> Vec<Trial> {
    let read = |file: &str| {
        std::fs::read(dir.join(file))
            .unwrap_or_else(|e| panic!("{}: {e}", dir.join(file).display()))
    };
    let mesh = load(&read("scene.glb"), None).expect("the scene loads");
    let truth: Value = serde_json::from_slice(&read("truth.json")).expect("truth.json");
    let selection = truth.get("select").cloned();
    let template_mesh = match selection {
        None => Some(load(&read("template.glb"), None).expect("the template loads")),
        Some(_) => None,
    };
    let bounds = mesh.bounds();
    let middle = (bounds.min + bounds.max) * 0.5;
    let voxel = bounds.extent().max_element() / f64::from(scene_options.resolution);
    // Never 0, which xorshift keeps at 0.
    let mut rng = Rng(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1);
    let mut out = Vec::new();
    for trial in 0..trials {
        let offset = Vec3::new(rng.unit(), rng.unit(), rng.unit());
        let rotation = if turn {
            rng.rotation()
        } else {
            [Vec3::X, Vec3::Y, Vec3::Z]
        };
        // x -> R (x - m) + m + offset * voxel
        let shift = middle + offset * voxel - rotate(&rotation, middle);
        let place = |p: Vec3| rotate(&rotation, p) + shift;
        let moved = mesh.map_positions(place).expect("a moved scene is a mesh");
        let moved_truth = |t: &Value| compose(&matrix(&rotation, shift), &to_matrix(t));
        let source = match (&selection, &template_mesh) {
            (Some(s), _) => TemplateSource::Selection {
                center: place(vec3(&s["center"])).to_array(),
                radius: s["radius"].as_f64().unwrap(),
            },
            (None, Some(m)) => TemplateSource::Model(m.clone()),
            (None, None) => unreachable!(),
        };
        let start = Instant::now();
        let scene = Scene::new(moved, scene_options).expect("the scene fits");
        let result = search(&scene, &source, options, &mut ());
        let ms = start.elapsed().as_secs_f64() * 1e3;
        let report = match result {
            Ok(report) => report,
            Err(e) => {
                let t = Trial {
                    offset,
                    found: 0,
                    copies: 0,
                    false_hits: Vec::new(),
                    ms,
                    error: Some(e.to_string()),
                };
                each(trial, &t);
                out.push(t);
                continue;
            }
        };
        let (targets, radius): (Vec<Vec3>, f64) = match &selection {
            Some(s) => (
                s["expected"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|e| place(vec3(e)))
                    .collect(),
                s["radius"].as_f64().unwrap(),
            ),
            None => {
                let c = Vec3::from_array(report.template.center);
                let placed: Vec<Vec3> = truth["instances"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|t| apply(&moved_truth(&t["transform"]), c))
                    .collect();
                (
                    placed,
                    truth
                        .get("template_radius")
                        .and_then(Value::as_f64)
                        .unwrap_or(1.0),
                )
            }
        };
        let tolerance = truth
            .get("tolerance")
            .and_then(Value::as_f64)
            .unwrap_or(0.2)
            * radius;
        let found: Vec<Vec3> = report
            .instances
            .iter()
            .map(|i| Vec3::from_array(i.position))
            .collect();
        let hit = targets
            .iter()
            .filter(|t| found.iter().any(|p| p.distance(**t) < tolerance))
            .count();
        let false_hits = report
            .instances
            .iter()
            .filter_map(|i| {
                let p = Vec3::from_array(i.position);
                let nearest = targets
                    .iter()
                    .map(|t| p.distance(*t))
                    .fold(f64::INFINITY, f64::min);
                (nearest >= tolerance).then(|| (nearest / radius, i.score.unwrap_or(f64::NAN)))
            })
            .collect();
        let t = Trial {
            offset,
            found: hit,
            copies: targets.len(),
            false_hits,
            ms,
            error: None,
        };
        each(trial, &t);
        out.push(t);
    }
    out
}

fn vec3(v: &Value) -> Vec3 {
    Vec3::new(
        v[0].as_f64().unwrap(),
        v[1].as_f64().unwrap(),
        v[2].as_f64().unwrap(),
    )
}

fn rotate(rows: &[Vec3; 3], v: Vec3) -> Vec3 {
    Vec3::new(rows[0].dot(v), rows[1].dot(v), rows[2].dot(v))
}

fn matrix(rows: &[Vec3; 3], shift: Vec3) -> Matrix {
    let row = |i: usize| [rows[i].x, rows[i].y, rows[i].z, shift[i]];
    [row(0), row(1), row(2), [0.0, 0.0, 0.0, 1.0]]
}

fn to_matrix(t: &Value) -> Matrix {
    let mut m = [[0.0; 4]; 4];
    for (r, row) in m.iter_mut().enumerate() {
        for (c, value) in row.iter_mut().enumerate() {
            *value = t[r][c].as_f64().unwrap();
        }
    }
    m
}

fn compose(a: &Matrix, b: &Matrix) -> Matrix {
    let mut m = [[0.0; 4]; 4];
    for (r, row) in m.iter_mut().enumerate() {
        for (c, value) in row.iter_mut().enumerate() {
            *value = (0..4).map(|k| a[r][k] * b[k][c]).sum();
        }
    }
    m
}

fn apply(m: &Matrix, p: Vec3) -> Vec3 {
    let row = |r: usize| m[r][0] * p.x + m[r][1] * p.y + m[r][2] * p.z + m[r][3];
    Vec3::new(row(0), row(1), row(2))
}

/// xorshift64*: reproducible placements from a seed, no dependency.
struct Rng(u64);

impl Rng {
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A uniformly random rotation (rows), from a random unit quaternion.
    fn rotation(&mut self) -> [Vec3; 3] {
        let (u1, u2, u3) = (self.unit(), self.unit(), self.unit());
        let tau = std::f64::consts::TAU;
        let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
        let (w, x, y, z) = (
            a * (tau * u2).sin(),
            a * (tau * u2).cos(),
            b * (tau * u3).sin(),
            b * (tau * u3).cos(),
        );
        [
            Vec3::new(
                1.0 - 2.0 * (y * y + z * z),
                2.0 * (x * y - w * z),
                2.0 * (x * z + w * y),
            ),
            Vec3::new(
                2.0 * (x * y + w * z),
                1.0 - 2.0 * (x * x + z * z),
                2.0 * (y * z - w * x),
            ),
            Vec3::new(
                2.0 * (x * z - w * y),
                2.0 * (y * z + w * x),
                1.0 - 2.0 * (x * x + y * y),
            ),
        ]
    }
}
