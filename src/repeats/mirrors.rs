//! Mirror images join the family of what they mirror.
//!
//! Bodies are found from turned copies alone, so that a pair of wheels,
//! each the other's mirror image, stays one part of two copies rather
//! than one wheel of four. Then a family's representative, or a piece
//! found once, that is the mirror image of another joins it, its copies
//! marked mirrored: an instanced model places a left and a right part by
//! one mesh and a reflecting node.

use std::collections::BTreeMap;

use super::bodies::{IDENTITY, compose};
use super::{Family, MirrorImages, RepeatCopy, bounding_sphere, congruent_parts};
use crate::align::Rigid;
use crate::exec::Threads;
use crate::mesh::TriMesh;

/// `families` with the mirror images among them and among `lone` (the
/// pieces in no family) joined: a family mirrored by another takes its
/// copies, and two lone pieces, each the other's mirror image, are a
/// family of two.
pub(super) fn with_mirror_images(
    mesh: &TriMesh,
    families: Vec<Family>,
    lone: &[Vec<u32>],
    backend: Threads,
) -> Vec<Family> {
    let count = families.len();
    let lists: Vec<&[u32]> = families
        .iter()
        .map(|f| f.copies[0].triangles.as_slice())
        .chain(lone.iter().map(|p| p.as_slice()))
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
        let mut family = match original.checked_sub(count) {
            None => families[original].take().expect("an original is no image"),
            Some(piece) => lone_family(mesh, &lone[piece]),
        };
        for (unit, motion, residual) in images {
            let theirs = match unit.checked_sub(count) {
                None => {
                    families[unit]
                        .take()
                        .expect("an image is no original")
                        .copies
                }
                Some(piece) => vec![RepeatCopy {
                    pose: IDENTITY.to_rows(),
                    residual: 0.0,
                    mirrored: false,
                    triangles: lone[piece].clone(),
                }],
            };
            for copy in theirs {
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

/// A piece found once, as a family of that one copy.
fn lone_family(mesh: &TriMesh, triangles: &[u32]) -> Family {
    let (center, radius) = bounding_sphere(mesh, triangles);
    Family {
        center,
        radius,
        pieces: 1,
        copies: vec![RepeatCopy {
            pose: IDENTITY.to_rows(),
            residual: 0.0,
            mirrored: false,
            triangles: triangles.to_vec(),
        }],
    }
}
