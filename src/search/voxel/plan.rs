//! The voxel search's plan: its first steps, up to which parts are
//! searched, and their work judged from their areas (see
//! [`crate::search::SearchPlan`]).

use super::parts::parts_to_search;
use super::prepare::search_lattice;
use super::work::least_work;
use crate::error::Result;
use crate::options::MatchOptions;
use crate::repeats::{MirrorImages, congruent_parts};
use crate::scene::Scene;
use crate::search::SearchPlan;
use crate::template::{TemplateSource, VoxelTemplate};
use crate::voxel::part_voxel_work;

/// The plan of searching `scene` for `source` with the voxel descriptors:
/// the same parts and copies as the search finds.
pub(in crate::search) fn plan_voxels(
    scene: &Scene,
    source: &TemplateSource,
    options: &MatchOptions,
) -> Result<SearchPlan> {
    let lattice = search_lattice(scene, source, options)?;
    let template = VoxelTemplate::new(source, scene, &lattice, options)?;
    let all = scene.parts_for(template.parts());
    let parts = parts_to_search(scene, &template, &lattice, &all)?;
    let lists: Vec<&[u32]> = parts.iter().map(|(_, p)| p.triangles()).collect();
    let copies = congruent_parts(scene.mesh(), &lists, options.backend, MirrorImages::Refused);
    let voxel = lattice.spec.voxel_size;
    let (mut distinct_parts, mut skin_voxels, mut work) = (0, 0.0, 0.0);
    for ((_, part), copy) in parts.iter().zip(&copies) {
        if copy.is_none() {
            let (skin, least) = least_work(part_voxel_work(scene.mesh(), part.triangles(), voxel));
            distinct_parts += 1;
            skin_voxels += skin;
            work += least;
        }
    }
    let threads = options.backend.count();
    Ok(SearchPlan {
        parts: parts.len(),
        distinct_parts,
        skin_voxels: skin_voxels.round(),
        least_work: work,
        threads,
        least_seconds: work / 1e9 / threads as f64,
        over_limit: work > options.max_part_work,
    })
}
