//! The voxel pipeline, in the order it runs:
//! - `prepare`: the template's side, once: its lattice, grid, signatures
//!   (`signatures`: a model's averaged over the grid's phase) and a
//!   verifier per anchor;
//! - the plan: which parts can hold a copy and which are searched side by
//!   side (`parts`, `waves`), which copy others and are not searched
//!   (`congruent_parts`), which are too large for one grid (`windows`);
//! - `grid`: one grid's cascade of volume and harmonics layers on its skin
//!   voxels, the candidates thinned to those near a vertex
//!   (`near_vertices`);
//! - `place`: the survivors verified by placement, grouped, and aligned on
//!   the meshes;
//! - `work`: what searching the distinct parts takes, judged from a sample
//!   first and refused past the limit; `plan` judges it from the parts'
//!   areas before the search runs.

mod grid;
mod near_vertices;
mod parts;
mod place;
mod plan;
mod prepare;
mod signatures;
mod waves;
mod whole;
mod windows;
mod work;

use std::cell::RefCell;

use crate::cascade::Observer;
use crate::clock::now_ms;
use crate::descriptor::LayerDevice;
use crate::error::Result;
use crate::instances::{best_first, merge_duplicates, refuse_near_twins};
use crate::options::MatchOptions;
use crate::repeats::{MirrorImages, congruent_parts};
use crate::scene::{Parts, Scene};
use crate::search::report::{GpuInfo, GridInfo, MatchReport, TemplateInfo, Timings};
use crate::template::TemplateSource;
use parts::parts_to_search;
use place::moved_instance;
pub(super) use plan::plan_voxels;
use prepare::PartSearch;
use waves::Found;

/// Searches `scene`'s skin voxels for `source` with the voxel descriptors,
/// part by part: each connected part of the scene large enough to hold a
/// copy is voxelized on its own, so that what touches it or sits in it does
/// not hide it.
pub(super) async fn search_voxels(
    scene: &Scene,
    source: &TemplateSource,
    options: &MatchOptions,
    observer: &mut dyn Observer,
    device: Option<&dyn LayerDevice>,
) -> Result<MatchReport> {
    let t0 = now_ms();
    let searcher = PartSearch::new(scene, source, options)?;
    let all_parts = scene.parts_for(searcher.template.parts());
    let parts = parts_to_search(scene, &searcher.template, &searcher.lattice, &all_parts)?;
    let template_ms = now_ms() - t0;
    // What a part's copies take from it, moved.
    let lists: Vec<&[u32]> = parts.iter().map(|(_, p)| p.triangles()).collect();
    let copies_from = now_ms();
    let copies = congruent_parts(scene.mesh(), &lists, options.backend, MirrorImages::Refused);
    let copies_ms = now_ms() - copies_from;
    let originals: Vec<usize> = (0..parts.len()).filter(|&k| copies[k].is_none()).collect();
    let observer = RefCell::new(observer);
    let searched = searcher
        .search_parts(&parts, &originals, &observer, device)
        .await?;
    // In the parts' order, whether searched one by one or side by side.
    let mut found = Found::default();
    for (k, copy) in copies.iter().enumerate() {
        match (copy, &searched[k]) {
            (Some(copy), _) => {
                let moved = searched[copy.original]
                    .iter()
                    .flat_map(|f| &f.instances)
                    .map(|instance| moved_instance(instance, &copy.motion));
                found.instances.extend(moved);
            }
            (None, Some(part)) => found.merge(part),
            (None, None) => {}
        }
    }
    let (template, lattice) = (&searcher.template, &searcher.lattice);
    if matches!(template.parts(), Parts::Shells(_)) {
        // A shell inside a larger part is searched with it and alone.
        let reach = options.group_radius * template.radius();
        let instances = std::mem::take(&mut found.instances);
        found.instances = merge_duplicates(instances, reach, Some(&searcher.extent));
    }
    if !options.keep_near_twins {
        let in_scene = matches!(source, TemplateSource::Selection { .. });
        refuse_near_twins(
            &mut found.instances,
            template.center(),
            template.radius(),
            in_scene,
        );
    }
    // Best first over all parts, as within one.
    found.instances.sort_by(best_first);
    Ok(MatchReport {
        template: TemplateInfo::of(template.center(), template.radius()),
        instances: found.instances,
        stages: found.stages,
        grid: Some(GridInfo {
            resolution: lattice.resolution,
            voxel_size: lattice.spec.voxel_size,
            skin_voxels: found.skin_voxels,
            windows: found.windows,
        }),
        surface: None,
        gpu: device.map(|d| GpuInfo {
            adapter: d.description(),
            fallback: found.gpu_fallback,
        }),
        timings: Timings {
            template: template_ms,
            // Finding which parts copy others is part of matching: their
            // instances come from it.
            match_: found.timings.match_ + copies_ms,
            ..found.timings
        },
    })
}
