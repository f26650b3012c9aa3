//! The curvature descriptor's margins under two scalings of its layers,
//! from every vertex's full descriptor (no rejection), for the curvature
//! issue's choice of a smoother descriptor:
//!
//! - `outer`: every layer's difference scaled by r_k^2 (the search's);
//! - `own`: layer i's difference scaled by its own r_i^2, scale-free layer
//!   by layer, so that the small inner balls, whose curvature changes
//!   steeply as the centre moves, weigh no more than the outer ones;
//! - `kernel-disc`, `kernel-area`: the smooth variant of the layers
//!   ([`kernel_layers_at`]: each edge weighted by a kernel that falls to 0
//!   at the sphere, divided by a constant or by the kernel-weighted area)
//!   under the same two scalings;
//! - `flat-disc`, `flat-area`: the same with a kernel flat out to r / 2
//!   ([`KernelShape::FlatCentre`]);
//! - `wide-area`: the falling kernel with the area norm over a ball sqrt(2)
//!   times wider, so that its weighted mean squared distance from the
//!   centre is the search's (r^2 / 2 on a plane): the same scale, smooth.
//!
//! Per scene and scaling, as shares of the best wrong distance (the
//! smallest distance of a vertex farther than r_k from every true copy's
//! c_T: another object): `true`, the largest over the copies of the best
//! distance within the scorer's tolerance of the copy's c_T (below 1, a
//! threshold exists that keeps every copy and rejects every other object;
//! the smaller, the wider the choice); `on copies`, the best distance on
//! the copies themselves past the tolerance (a mirror image, which the
//! search's handedness test rejects, or a like part); and `rise(rho)`, the
//! largest distance of a vertex within rho r_1 of a copy's best vertex:
//! what a sampled first pass with samples rho r_1 apart must let through.
//! Below 1, a slack exists that keeps every copy from any such sample and
//! still rejects every other object. In brackets, the share of all
//! vertices within that rise: what such a pass keeps. `slack/rise`: the
//! slack the template alone gives (its own largest distance within rho r_1
//! of its centre vertex, plus the worst copy's distance by the triangle
//! inequality) over the rise the scene needs; at least 1 where it covers
//! the scene, and in brackets the share of vertices it keeps.
//!
//! cargo run --release --features internals --example curvature_margin -- [--descriptors
//! exact,kernel-disc,kernel-area,flat-disc,flat-area] SCENE...
//!
//! Model-template scenes of `../shared/scenes` (truth.json's transforms
//! place c_T in the scene). Every vertex's six layers cost about 0.6 ms:
//! a scene of 100k vertices takes half a minute on two cores.

#[path = "../tests/common/mod.rs"]
mod common;

use fast_reject::descriptor::curvature::{
    CurvatureDescriptor, KernelNorm, KernelShape, Surface, VertexGrid, kernel_layers_at,
};
use fast_reject::math::Vec3;
use fast_reject::scene::SceneOptions;
use fast_reject::search::MatchOptions;
use fast_reject::template::CurvatureTemplate;
use rayon::prelude::*;

/// Cover radii, in units of r_1.
const RHOS: [f64; 3] = [0.1, 0.25, 0.5];

/// The descriptors compared: the search's and the kernel variants.
const DESCRIPTORS: [&str; 6] = [
    "exact",
    "kernel-disc",
    "kernel-area",
    "flat-disc",
    "flat-area",
    "wide-area",
];

/// Descriptor `name`'s layers at vertex `v`.
fn layers_of(name: &str, surface: &Surface, v: u32, radii: &[f64]) -> Vec<f64> {
    match name {
        "exact" => CurvatureDescriptor::describe(surface, v, radii),
        "kernel-disc" => {
            kernel_layers_at(surface, v, radii, KernelShape::Falling, KernelNorm::Disc)
        }
        "kernel-area" => {
            kernel_layers_at(surface, v, radii, KernelShape::Falling, KernelNorm::Area)
        }
        "flat-disc" => {
            kernel_layers_at(surface, v, radii, KernelShape::FlatCentre, KernelNorm::Disc)
        }
        "flat-area" => {
            kernel_layers_at(surface, v, radii, KernelShape::FlatCentre, KernelNorm::Area)
        }
        "wide-area" => {
            let wide: Vec<f64> = radii.iter().map(|r| r * std::f64::consts::SQRT_2).collect();
            kernel_layers_at(surface, v, &wide, KernelShape::Falling, KernelNorm::Area)
        }
        _ => unreachable!("descriptor names are checked in main"),
    }
}

fn main() {
    let mut names: Vec<String> = std::env::args().skip(1).collect();
    let mut descriptors: Vec<String> = DESCRIPTORS.map(String::from).to_vec();
    if names.first().map(String::as_str) == Some("--descriptors") && names.len() > 1 {
        descriptors = names[1].split(',').map(String::from).collect();
        names.drain(..2);
        if let Some(d) = descriptors
            .iter()
            .find(|d| !DESCRIPTORS.contains(&d.as_str()))
        {
            eprintln!("unknown descriptor {d}: the descriptors are {DESCRIPTORS:?}");
            std::process::exit(2);
        }
    }
    println!(
        "| scene | scaling | vertices | true / wrong | on copies / wrong | {} |",
        RHOS.map(|r| format!("rise({r}) / wrong")).join(" | ")
    );
    println!("|---|---|---:|---:|---:|{}", "---:|".repeat(RHOS.len()));
    for name in &names {
        margins(name, &descriptors);
    }
}

/// One descriptor under one scaling: every vertex's layers, the template's,
/// the per-layer scale, and how to compute the layers at a vertex.
struct Variant<'a> {
    label: String,
    descriptor: &'a str,
    layers: &'a [Vec<f64>],
    wanted: &'a [f64],
    scale: &'a [f64],
}

/// One descriptor's layers at the template's centre and at every vertex.
struct Computed<'a> {
    descriptor: &'a str,
    wanted: Vec<f64>,
    layers: Vec<Vec<f64>>,
}

fn margins(name: &str, descriptors: &[String]) {
    let scene = common::scene(name, &SceneOptions::DEFAULT);
    let source = common::template(name, false);
    let template = CurvatureTemplate::new(&source, &scene, MatchOptions::DEFAULT.layers).unwrap();
    let radii = template.radii().to_vec();
    let truth = common::truth(name);
    let c = template.center();
    let centres: Vec<Vec3> = truth["instances"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| Vec3::from(common::apply(&i["transform"], [c.x, c.y, c.z])))
        .collect();
    let tolerance = truth["tolerance"].as_f64().unwrap_or(0.2)
        * truth
            .get("template_radius")
            .and_then(|r| r.as_f64())
            .unwrap_or(1.0);
    let surface = scene.surface();
    let used: Vec<u32> = surface.used_vertices().collect();
    let (template_surface, centre_vertex) = (template.surface(&scene), template.vertex());
    // Per descriptor: the template's layers and every vertex's.
    let computed: Vec<Computed> = descriptors
        .iter()
        .map(|d| {
            let wanted = layers_of(d, template_surface, centre_vertex, &radii);
            let layers = used
                .par_iter()
                .map(|&v| layers_of(d, surface, v, &radii))
                .collect();
            Computed {
                descriptor: d,
                wanted,
                layers,
            }
        })
        .collect();
    // Each vertex's distance to the nearest copy's c_T, and its index by
    // vertex id: the same for both scalings.
    let to_copy: Vec<f64> = used
        .iter()
        .map(|&v| {
            let p = surface.position(v);
            centres
                .iter()
                .map(|q| q.distance(p))
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    let index: std::collections::HashMap<u32, usize> =
        used.iter().enumerate().map(|(i, &v)| (v, i)).collect();
    let outer = radii[radii.len() - 1];
    let outer_scale: Vec<f64> = radii.iter().map(|_| outer * outer).collect();
    let own_scale: Vec<f64> = radii.iter().map(|r| r * r).collect();
    let mut variants = Vec::new();
    for Computed {
        descriptor,
        wanted,
        layers,
    } in &computed
    {
        for (scaling, scale) in [("outer", &outer_scale), ("own", &own_scale)] {
            variants.push(Variant {
                label: format!("{descriptor} {scaling}"),
                descriptor,
                layers,
                wanted,
                scale,
            });
        }
    }
    for Variant {
        label,
        descriptor,
        layers,
        wanted,
        scale,
    } in variants
    {
        let distance = |g: &[f64]| -> f64 {
            g.iter()
                .zip(wanted)
                .zip(scale)
                .map(|((g, t), s)| (s * (g - t)).powi(2))
                .sum()
        };
        let d: Vec<f64> = layers.iter().map(|g| distance(g)).collect();
        // Each copy's best vertex within the scorer's tolerance of its c_T
        // (what the exact pass keeps there), and the worst copy's distance.
        let best: Vec<usize> = centres
            .iter()
            .map(|&q| {
                (0..used.len())
                    .filter(|&i| surface.position(used[i]).distance(q) <= tolerance)
                    .min_by(|&a, &b| d[a].total_cmp(&d[b]))
                    .expect("a vertex near every copy")
            })
            .collect();
        let worst_true = best.iter().map(|&i| d[i]).fold(0.0, f64::max);
        // The best wrong vertex on the copies themselves (past the
        // tolerance, within r_k of a c_T: a mirror image, which the
        // search's handedness test rejects, or a like part), and on the
        // rest of the scene.
        let best_among = |keep: &dyn Fn(f64) -> bool| {
            (0..used.len())
                .filter(|&i| keep(to_copy[i]))
                .map(|i| d[i])
                .fold(f64::INFINITY, f64::min)
                .max(1e-300)
        };
        let r_k = template.radius();
        let on_copies = best_among(&|x| x > tolerance && x <= r_k);
        let wrong = best_among(&|x| x > r_k);
        let anchors: Vec<Vec3> = best.iter().map(|&i| surface.position(used[i])).collect();
        let rises: Vec<String> = RHOS
            .iter()
            .map(|rho| {
                let reach = rho * radii[0];
                let grid = VertexGrid::new(surface, reach).unwrap();
                let near = grid.within(surface, &anchors, reach);
                let rise = near
                    .iter()
                    .filter(|&&v| {
                        let p = surface.position(v);
                        anchors.iter().any(|a| a.distance(p) <= reach)
                    })
                    .map(|v| d[index[v]])
                    .fold(0.0, f64::max);
                let kept = d.iter().filter(|&&x| x <= rise).count();
                // What the template alone says: its own distance within
                // reach of its centre vertex, plus the threshold's worth of
                // difference between a copy and the template (the triangle
                // inequality in the layers' space).
                let own_grid = VertexGrid::new(template_surface, reach).unwrap();
                let centre = template_surface.position(centre_vertex);
                let template_rise = own_grid
                    .within(template_surface, &[centre], reach)
                    .iter()
                    .map(|&x| distance(&layers_of(descriptor, template_surface, x, &radii)))
                    .fold(0.0, f64::max);
                // The copies' own difference from the template: the worst
                // copy's best distance (the search would use its threshold,
                // which is larger).
                let noise = worst_true;
                let slack = (template_rise.sqrt() + noise.sqrt()).powi(2);
                let kept_slack = d.iter().filter(|&&x| x <= slack).count();
                format!(
                    "{:.2} ({:.1}%) slack/rise {:.2} ({:.1}%)",
                    rise / wrong,
                    100.0 * kept as f64 / d.len() as f64,
                    slack / rise.max(1e-300),
                    100.0 * kept_slack as f64 / d.len() as f64
                )
            })
            .collect();
        println!(
            "| {name} | {label} | {} | {:.4} | {:.2} | {} |",
            used.len(),
            worst_true / wrong,
            on_copies / wrong,
            rises.join(" | ")
        );
    }
}
