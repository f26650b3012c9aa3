//! A part's vertices numbered in the order its triangles first use them,
//! with memory that grows with the part, not the mesh, so that parts can
//! be numbered on several threads at once.

use std::collections::HashMap;
use std::hash::BuildHasherDefault;

use super::{FxHasher, TriMesh};

/// Each vertex of one part's local index (see the module's doc). A part's
/// vertices mostly lie together in the mesh's list (an exporter writes a
/// part at a time), so an array over their span serves; a part whose
/// vertices are strewn through the list takes a hash map.
pub(crate) enum VertexNumbering {
    Span { first: u32, local: Vec<u32> },
    Strewn(HashMap<u32, u32, BuildHasherDefault<FxHasher>>),
}

impl VertexNumbering {
    /// An empty numbering for the vertices of `triangles` of `mesh`.
    pub(crate) fn for_part(mesh: &TriMesh, triangles: &[u32]) -> VertexNumbering {
        let (first, last) = triangles
            .iter()
            .flat_map(|&t| mesh.triangles()[t as usize])
            .fold((u32::MAX, 0), |(lo, hi), v| (lo.min(v), hi.max(v)));
        let span = (last as usize + 1).saturating_sub(first as usize);
        // An array 4 bytes a slot against a map's 16 or more an entry,
        // filled at once: worth it while the span is within a few times
        // the corners.
        match span <= 4 * 3 * triangles.len() {
            true => VertexNumbering::Span {
                first,
                local: vec![u32::MAX; span],
            },
            false => VertexNumbering::Strewn(HashMap::default()),
        }
    }

    /// `v`'s local index, `next` if it has none yet.
    pub(crate) fn local(&mut self, v: u32, next: u32) -> u32 {
        match self {
            VertexNumbering::Span { first, local } => {
                let slot = &mut local[(v - *first) as usize];
                if *slot == u32::MAX {
                    *slot = next;
                }
                *slot
            }
            VertexNumbering::Strewn(map) => *map.entry(v).or_insert(next),
        }
    }

    /// Whether the part's vertices were too strewn for an array.
    #[cfg(test)]
    pub(crate) fn is_strewn(&self) -> bool {
        matches!(self, VertexNumbering::Strewn(_))
    }
}
