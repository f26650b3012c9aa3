//! How much slack the curvature search's sampled first pass needs, over
//! turnings of a scene. The sample (one vertex per grid cell) depends on
//! where the cells fall, so each turning samples a different set of
//! vertices. For every occurrence the exact search finds, the final pass
//! reaches its best point from any sample vertex within its reach; the
//! turning needs the smallest distance among those, in thresholds. A
//! sampled pass whose slack is at least every turning's need finds every
//! occurrence the exact pass finds.
//!
//! cargo run --release --features internals --example sample_turnings -- SCENE [--select]
//!     [--turnings N] [--spacing S]
//!
//! SCENE is a folder under `../shared/scenes` (or `$FAST_REJECT_SHARED/scenes`,
//! for scenes made with scripts/make-more-scenes.sh); S is the cell side in
//! units of r_1 (the search's `--curvature-spacing`, default 0.5).

#[path = "../tests/common/mod.rs"]
mod common;

use fast_reject::descriptor::OnionDescriptor;
use fast_reject::descriptor::curvature::{CurvatureDescriptor, VertexGrid};
use fast_reject::math::Vec3;
use fast_reject::scene::{Scene, SceneOptions};
use fast_reject::search::{DescriptorKind, MatchOptions, search};
use fast_reject::template::{CurvatureTemplate, TemplateSource};
use rayon::prelude::*;

/// The final pass's reach from a sample survivor, in cells (the search's
/// SAMPLE_REACH).
const REACH_CELLS: f64 = 2.0;

/// Rotation number `k` of a deterministic, well spread set: axes on a
/// golden-angle spiral, angles by the golden ratio (k = 0 is no turn).
fn turning(k: usize, count: usize) -> (Vec3, f64) {
    if k == 0 {
        return (Vec3::new(0.0, 0.0, 1.0), 0.0);
    }
    let golden = (5f64.sqrt() - 1.0) / 2.0;
    let z = 1.0 - 2.0 * (k as f64 + 0.5) / count as f64;
    let around = std::f64::consts::TAU * golden * k as f64;
    let ring = (1.0 - z * z).max(0.0).sqrt();
    let axis = Vec3::new(ring * around.cos(), ring * around.sin(), z);
    let angle = std::f64::consts::TAU * (k as f64 * golden).fract();
    (axis, angle)
}

/// Rodrigues' rotation of `p` about the unit `axis`.
fn turn(p: Vec3, (axis, angle): (Vec3, f64)) -> Vec3 {
    let (s, c) = angle.sin_cos();
    p * c + axis.cross(p) * s + axis * (axis.dot(p) * (1.0 - c))
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(name) = args.first() else {
        eprintln!("usage: sample_turnings SCENE [--select] [--turnings N] [--spacing S]");
        std::process::exit(2);
    };
    let select = args.iter().any(|a| a == "--select");
    let value = |flag: &str, default: f64| {
        args.iter()
            .position(|a| a == flag)
            .and_then(|i| args.get(i + 1))
            .and_then(|v| v.parse().ok())
            .unwrap_or(default)
    };
    let turnings = value("--turnings", 16.0) as usize;
    let spacing = value("--spacing", 0.5);
    let mut options = MatchOptions::DEFAULT;
    options.descriptor = DescriptorKind::Curvature;
    let threshold = options.curvature_threshold;
    let cap = 100.0 * threshold;

    let upright = common::scene(name, &SceneOptions::DEFAULT);
    let source = common::template(name, select);
    let exact = search(&upright, &source, &options, &mut ()).unwrap();
    let points: Vec<Vec3> = exact
        .instances
        .iter()
        .map(|i| Vec3::new(i.position[0], i.position[1], i.position[2]))
        .collect();
    println!(
        "{name}: {} vertices, exact pass {} instances in {:.0} ms, spacing {spacing} r1",
        upright.surface().vertex_count(),
        points.len(),
        exact.timings.total()
    );
    let mesh = upright.mesh().clone();
    drop(upright);

    let mut needs = Vec::new();
    for k in 0..turnings {
        let rotation = turning(k, turnings);
        let scene = Scene::new(
            mesh.map_positions(|p| turn(p, rotation)).unwrap(),
            &SceneOptions::DEFAULT,
        )
        .unwrap();
        let source = match &source {
            TemplateSource::Selection { center, radius } => {
                let c = turn(Vec3::new(center[0], center[1], center[2]), rotation);
                TemplateSource::Selection {
                    center: [c.x, c.y, c.z],
                    radius: *radius,
                }
            }
            model => model.clone(),
        };
        let template = CurvatureTemplate::new(&source, &scene, options.layers).unwrap();
        let radii = template.radii().to_vec();
        let gaussians =
            CurvatureDescriptor::describe(template.surface(&scene), template.vertex(), &radii);
        let surface = scene.surface();
        let d = CurvatureDescriptor::new(surface, &radii, &gaussians, cap);
        let distance = |v: u32| {
            let mut state = d.start(v, 1);
            let mut x = 0.0;
            for layer in 0..radii.len() {
                x = d.extend(v, layer, &mut state);
                if x > cap {
                    break;
                }
            }
            x
        };
        let cell = spacing * radii[0];
        let grid = VertexGrid::new(surface, cell).unwrap();
        let sample: std::collections::HashSet<u32> = grid.sample(surface).into_iter().collect();
        // Per occurrence: the best sample vertex the final pass reaches it from.
        let per_instance: Vec<f64> = points
            .par_iter()
            .map(|&p| {
                grid.within(surface, &[turn(p, rotation)], REACH_CELLS * cell)
                    .into_iter()
                    .filter(|v| sample.contains(v))
                    .map(distance)
                    .fold(f64::INFINITY, f64::min)
                    / threshold
            })
            .collect();
        let need = per_instance.iter().copied().fold(0.0, f64::max);
        println!(
            "  turning {k:2} (angle {:.2}): {} samples, need {need:.2} (per instance {:?})",
            rotation.1,
            sample.len(),
            per_instance
                .iter()
                .map(|x| format!("{x:.2}"))
                .collect::<Vec<_>>()
        );
        needs.push(need);
    }
    needs.sort_by(f64::total_cmp);
    let over = |s: f64| needs.iter().filter(|&&n| n > s).count();
    println!(
        "{name}: need over {} turnings: median {:.2}, max {:.2}; turnings over 5: {}, over 10: {}",
        needs.len(),
        needs[needs.len() / 2],
        needs[needs.len() - 1],
        over(5.0),
        over(10.0)
    );
}
