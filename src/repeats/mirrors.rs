//! Mirror images join the family of what they mirror.
//!
//! Bodies are found from turned copies first, so that a pair of wheels,
//! each the other's mirror image, stays one part of two copies rather
//! than one wheel of four. A piece found once that mirrors another piece
//! joins that piece's family before the bodies are built, so that a
//! mirrored copy of a body of several pieces is one copy; and a family
//! whose representative mirrors another family's joins it after. Their
//! copies are marked mirrored: an instanced model places a left and a
//! right part by one mesh and a reflecting node.

use std::collections::BTreeMap;

use super::bodies::compose;
use super::{CopyOf, Family, MirrorImages, RepeatCopy, congruent_parts};
use crate::align::Rigid;
use crate::exec::Threads;
use crate::mesh::TriMesh;

/// `copies` (what each of `pieces` turned copies) with the mirror images
/// among the pieces that copy nothing and that nothing copies: each is
/// made a copy of the piece it mirrors.
pub(super) fn mirror_lone_pieces(
    mesh: &TriMesh,
    pieces: &[Vec<u32>],
    copies: &mut [Option<CopyOf>],
    backend: Threads,
) {
    let mut copied = vec![false; pieces.len()];
    for copy in copies.iter().flatten() {
        copied[copy.original] = true;
    }
    // Originals first, so that a lone piece is a copy of one where it
    // can be.
    let originals = (0..pieces.len()).filter(|&p| copied[p]);
    let lone = (0..pieces.len()).filter(|&p| !copied[p] && copies[p].is_none());
    let units: Vec<usize> = originals.chain(lone).collect();
    let lists: Vec<&[u32]> = units.iter().map(|&p| pieces[p].as_slice()).collect();
    let found = congruent_parts(mesh, &lists, backend, MirrorImages::Accepted);
    for (unit, copy) in found.into_iter().enumerate() {
        let piece = units[unit];
        if let Some(copy) = copy.filter(|c| c.mirrored() && !copied[piece]) {
            copies[piece] = Some(CopyOf {
                original: units[copy.original],
                ..copy
            });
        }
    }
}

/// `families` with those whose representative mirrors another's joined:
/// the family mirrored takes the other's copies.
pub(super) fn with_mirror_images(
    mesh: &TriMesh,
    families: Vec<Family>,
    backend: Threads,
) -> Vec<Family> {
    let lists: Vec<&[u32]> = families
        .iter()
        .map(|f| f.copies[0].triangles.as_slice())
        .collect();
    let copies = congruent_parts(mesh, &lists, backend, MirrorImages::Accepted);
    // What each original's mirror images are, and the motion onto each.
    let mut mirrors: BTreeMap<usize, Vec<(usize, Rigid, f64)>> = BTreeMap::new();
    for (unit, copy) in copies.iter().enumerate() {
        if let Some(copy) = copy.filter(|c| c.mirrored()) {
            let images = mirrors.entry(copy.original).or_default();
            images.push((unit, copy.motion, copy.residual));
        }
    }
    if mirrors.is_empty() {
        return families;
    }
    let mut families: Vec<Option<Family>> = families.into_iter().map(Some).collect();
    let mut joined = Vec::new();
    for (original, images) in mirrors {
        let mut family = families[original].take().expect("an original is no image");
        for (unit, motion, residual) in images {
            let theirs = families[unit].take().expect("an image is no original");
            for copy in theirs.copies {
                let pose = compose(&Rigid::from_rows(&copy.pose), &motion);
                family.copies.push(RepeatCopy {
                    pose: pose.to_rows(),
                    residual: copy.residual + residual,
                    mirrored: pose.rotation.determinant() < 0.0,
                    triangles: copy.triangles,
                });
            }
        }
        joined.push(family);
    }
    families.into_iter().flatten().chain(joined).collect()
}
