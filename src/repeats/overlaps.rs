//! Copies that weld into one component.
//!
//! Copies that overlap with coincident vertices (a saw blade stored again
//! a tooth further on) weld into one connected component that copies
//! nothing, yet the file stores each copy's faces apart. Such a component
//! is taken apart into its copies where its stored pieces are, all of
//! them, copies of one body, and no edge joins two copies as one surface:
//! a box whose two halves are congruent is one box, not two halves.

use std::collections::HashMap;

use super::{MirrorImages, bodies, congruent_parts};
use crate::exec::Threads;
use crate::mesh::TriMesh;

/// The copies `component` is made of, each a list of its triangles, if
/// it is two copies or more of one body. `stored` are the file's pieces
/// within it, `welded` each vertex's number after the weld.
pub(super) fn copies_within(
    mesh: &TriMesh,
    stored: &[Vec<u32>],
    welded: &[u32],
) -> Option<Vec<Vec<u32>>> {
    if stored.len() < 2 {
        return None;
    }
    let lists: Vec<&[u32]> = stored.iter().map(|p| p.as_slice()).collect();
    let copies = congruent_parts(mesh, &lists, Threads::Serial, MirrorImages::Refused);
    let body = bodies::one_body(mesh, stored, &copies)?;
    if body.len() < 2 {
        return None;
    }
    let mut copy_of = HashMap::new();
    let parts: Vec<Vec<u32>> = body
        .iter()
        .enumerate()
        .map(|(c, copy)| {
            let triangles = copy.triangles(stored);
            for &t in &triangles {
                copy_of.insert(t, c);
            }
            triangles
        })
        .collect();
    (!joined_as_one_surface(mesh, &copy_of, welded)).then_some(parts)
}

/// Whether an edge has exactly two triangles, of two different copies:
/// the copies are then pieces of one surface, cut apart.
fn joined_as_one_surface(mesh: &TriMesh, copy_of: &HashMap<u32, usize>, welded: &[u32]) -> bool {
    let mut edges: HashMap<(u32, u32), (u32, usize, usize)> = HashMap::new();
    for (&t, &copy) in copy_of {
        let corners = mesh.triangles()[t as usize].map(|v| welded[v as usize]);
        for k in 0..3 {
            let (a, b) = (corners[k], corners[(k + 1) % 3]);
            let entry = edges.entry((a.min(b), a.max(b))).or_insert((0, copy, copy));
            entry.0 += 1;
            entry.2 = copy;
        }
    }
    edges
        .values()
        .any(|&(count, first, last)| count == 2 && first != last)
}
