//! Measures how much slack the curvature search's sampled first pass needs:
//! for every survivor s of the one-pass search, the largest distance of any
//! vertex within the cover radius of s. A covering sample puts some sample
//! vertex there, whatever the turning of the scene.
//!
//! cargo run --release --features internals --example sample_slack -- SCENE [--select] [RHO...]
//!
//! RHO is the cover radius in units of r_1; the scenes come from
//! `../shared/scenes`.

#[path = "../tests/common/mod.rs"]
mod common;

use fast_reject::descriptor::OnionDescriptor;
use fast_reject::descriptor::curvature::CurvatureDescriptor;
use fast_reject::descriptor::curvature::{Surface, VertexGrid};
use fast_reject::scene::SceneOptions;
use fast_reject::search::MatchOptions;
use fast_reject::template::CurvatureTemplate;
use rayon::prelude::*;

/// A covering sample, taken greedily in vertex order: every vertex within
/// `radius` of a sample vertex, sample vertices more than `radius` apart.
fn cover(grid: &VertexGrid, surface: &Surface, radius: f64) -> Vec<u32> {
    let mut covered = vec![false; surface.vertex_count()];
    let mut sample = Vec::new();
    for v in surface.used_vertices() {
        if !covered[v as usize] {
            sample.push(v);
            for w in grid.within(surface, &[surface.position(v)], radius) {
                covered[w as usize] = true;
            }
        }
    }
    sample
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = &args[0];
    let select = args.iter().any(|a| a == "--select");
    let rhos: Vec<f64> = args[1..].iter().filter_map(|a| a.parse().ok()).collect();
    // The integration tests' loaders: the same scene, template and
    // selection sphere as tests/curvature.rs.
    let scene = common::scene(name, &SceneOptions::DEFAULT);
    let source = common::template(name, select);
    let options = MatchOptions::DEFAULT;
    let template = CurvatureTemplate::new(&source, &scene, options.layers).unwrap();
    let radii = template.radii().to_vec();
    let gaussians =
        CurvatureDescriptor::describe(template.surface(&scene), template.vertex(), &radii);
    let surface = scene.surface();
    let threshold = options.curvature_threshold;
    let cap = 100.0 * threshold;
    let d = CurvatureDescriptor::new(surface, &radii, &gaussians, cap);
    let distance = |v: u32, limit: f64| {
        let mut state = d.start(v, 1);
        let mut x = 0.0;
        for layer in 0..radii.len() {
            x = d.extend(v, layer, &mut state);
            if x > limit {
                break;
            }
        }
        x
    };
    let used: Vec<u32> = surface.used_vertices().collect();
    let survivors: Vec<u32> = used
        .par_iter()
        .copied()
        .filter(|&v| distance(v, threshold) <= threshold)
        .collect();
    println!(
        "{name}: {} vertices, {} survivors, r1 {:.4}",
        used.len(),
        survivors.len(),
        radii[0]
    );
    for rho in rhos {
        let reach = rho * radii[0];
        let grid = VertexGrid::new(surface, reach).unwrap();
        let cover = cover(&grid, surface, reach);
        let cells = VertexGrid::new(surface, 0.5 * radii[0])
            .unwrap()
            .sample(surface);
        let points: Vec<_> = survivors.iter().map(|&s| surface.position(s)).collect();
        let near = grid.within(surface, &points, reach);
        let values: std::collections::HashMap<u32, f64> = near
            .par_iter()
            .map(|&w| (w, distance(w, cap)))
            .collect::<Vec<_>>()
            .into_iter()
            .collect();
        let need = |s: u32| {
            grid.within(surface, &[surface.position(s)], reach)
                .iter()
                .map(|w| values[w])
                .fold(0.0, f64::max)
                / threshold
        };
        let mut worst: Vec<(f64, u32)> = survivors.iter().map(|&s| (need(s), s)).collect();
        worst.sort_by(|a, b| b.0.total_cmp(&a.0));
        // Where the worst neighbour's distance comes from, layer by layer.
        let (_, s0) = worst[0];
        let (w0, _) = grid
            .within(surface, &[surface.position(s0)], reach)
            .iter()
            .map(|&w| (w, values[&w]))
            .fold((s0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
        let layers = |v: u32| {
            let mut state = d.start(v, 1);
            let mut last = 0.0;
            (0..radii.len())
                .map(|l| {
                    let x = d.extend(v, l, &mut state);
                    let step = x - last;
                    last = x;
                    format!("{step:.2}")
                })
                .collect::<Vec<_>>()
        };
        println!(
            "    survivor {s0} per layer {:?}; neighbour {w0} at {:.4} per layer {:?}",
            layers(s0),
            surface.position(s0).distance(surface.position(w0)),
            layers(w0)
        );
        let best = survivors
            .iter()
            .map(|&s| values[&s])
            .fold(f64::INFINITY, f64::min);
        println!(
            "  rho {rho}: cover {} samples (cells of 0.5 r1: {}), near {} vertices, need max {:.2} (best survivor at {:.2}); worst: {:?}",
            cover.len(),
            cells.len(),
            near.len(),
            worst[0].0,
            best / threshold,
            worst
                .iter()
                .take(5)
                .map(|w| format!("{:.2}", w.0))
                .collect::<Vec<_>>()
        );
    }
}
