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
pub(crate) struct VertexNumbering {
    index: Index,
    /// Vertices numbered so far.
    count: u32,
}

enum Index {
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
        let index = match span <= 4 * 3 * triangles.len() {
            true => Index::Span {
                first,
                local: vec![u32::MAX; span],
            },
            false => Index::Strewn(HashMap::default()),
        };
        VertexNumbering { index, count: 0 }
    }

    /// `v`'s local index, and whether this is its first use (it takes the
    /// next number).
    pub(crate) fn number(&mut self, v: u32) -> (u32, bool) {
        let next = self.count;
        let local = match &mut self.index {
            Index::Span { first, local } => {
                let slot = &mut local[(v - *first) as usize];
                if *slot == u32::MAX {
                    *slot = next;
                }
                *slot
            }
            Index::Strewn(map) => *map.entry(v).or_insert(next),
        };
        let first_use = local == next;
        self.count += u32::from(first_use);
        (local, first_use)
    }

    /// Whether the part's vertices were too strewn for an array.
    #[cfg(test)]
    pub(crate) fn is_strewn(&self) -> bool {
        matches!(self.index, Index::Strewn(_))
    }
}
