//! Triangle meshes: the common form every loader produces and every later
//! stage reads.
//!
//! A [`TriMesh`] is a triangle soup with shared vertices, already in world
//! coordinates (glTF node transforms applied). Construction validates it once,
//! so the rest of the pipeline can trust it: every coordinate is finite, every
//! index is in range, and triangles without area are dropped (counted in
//! [`TriMesh::degenerate_dropped`]) rather than rejected, because real files
//! often carry a few.

mod bounding_sphere;
mod closest_point;
mod components;
pub mod io;
pub mod shapes;
mod vertex_numbering;
mod weld;

pub use bounding_sphere::{Sphere, minimal_bounding_sphere};
pub use closest_point::{ClosestPoint, closest_point_on_triangle};
pub use components::{connected_components, stored_pieces};
pub(crate) use vertex_numbering::VertexNumbering;
pub(crate) use weld::FxHasher;
pub use weld::{weld_vertices, weld_vertices_on};

use crate::error::{Error, Result};
use crate::math::{Aabb, Vec3, from_f32};

/// A validated triangle mesh.
#[derive(Clone, Debug)]
pub struct TriMesh {
    positions: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
    parts: Vec<Part>,
    degenerate_dropped: usize,
    /// The box of the vertices the triangles use, found while they are
    /// validated: a search asks for it several times, and reading every
    /// corner again took 15 ms of a million-triangle scene each time.
    bounds: Aabb,
}

/// A run of vertices and triangles that came from one source mesh: a glTF
/// mesh placed by one node. Parts with the same `source` are instances of
/// one mesh, which lets connectivity be computed once per mesh rather than
/// once per instance; a single-mesh file is one part.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Part {
    /// Index of the part's first vertex.
    pub first_vertex: u32,
    /// Number of its vertices.
    pub vertex_count: u32,
    /// Index of its first triangle.
    pub first_triangle: u32,
    /// Number of its triangles.
    pub triangle_count: u32,
    /// Which source mesh it is an instance of.
    pub source: u32,
}

impl Part {
    /// One part covering a whole mesh of `vertices` and `triangles`.
    fn whole(vertices: usize, triangles: usize) -> Part {
        Part {
            first_vertex: 0,
            vertex_count: vertices as u32,
            first_triangle: 0,
            triangle_count: triangles as u32,
            source: 0,
        }
    }
}

/// A subset whose corners number fewer than the mesh's vertices over this
/// is renumbered through a hash map rather than a table over every vertex.
const SPARSE_SUBSET: usize = 16;

impl TriMesh {
    /// Validates positions and triangles into a mesh.
    ///
    /// Fails on a non-finite coordinate, an index out of range, or when no
    /// triangle with area is left; drops triangles with repeated corners or
    /// zero area.
    pub fn new(positions: Vec<[f32; 3]>, triangles: Vec<[u32; 3]>) -> Result<TriMesh> {
        let part = Part::whole(positions.len(), triangles.len());
        TriMesh::with_parts(positions, triangles, vec![part])
    }

    /// Like [`TriMesh::new`], for a mesh assembled from parts (which must
    /// cover the triangles in order; a part's triangles must use its own
    /// vertices). Dropped triangles shrink their part.
    pub fn with_parts(
        positions: Vec<[f32; 3]>,
        triangles: Vec<[u32; 3]>,
        mut parts: Vec<Part>,
    ) -> Result<TriMesh> {
        let covered: u64 = parts.iter().map(|p| p.triangle_count as u64).sum();
        if covered != triangles.len() as u64 {
            return Err(Error::invalid_option(
                "parts",
                "the parts do not cover the triangles",
            ));
        }
        for (vertex, p) in positions.iter().enumerate() {
            if let Some(&value) = p.iter().find(|c| !c.is_finite()) {
                return Err(Error::NonFiniteCoordinate { vertex, value });
            }
        }
        let n = positions.len();
        let mut kept = Vec::with_capacity(triangles.len());
        let mut degenerate_dropped = 0;
        let mut used = F32Box::EMPTY;
        let mut next = 0usize;
        for part in &mut parts {
            let range = next..next + part.triangle_count as usize;
            next = range.end;
            part.first_triangle = kept.len() as u32;
            for triangle in range {
                let t = triangles[triangle];
                if let Some(&vertex) = t.iter().find(|&&i| i as usize >= n) {
                    return Err(Error::IndexOutOfRange {
                        triangle,
                        vertex: vertex as u64,
                        vertices: n,
                    });
                }
                let own = part.first_vertex..part.first_vertex.saturating_add(part.vertex_count);
                if t.iter().any(|i| !own.contains(i)) {
                    return Err(Error::invalid_option(
                        "parts",
                        format!("triangle {triangle} uses vertices outside its part"),
                    ));
                }
                if is_degenerate(&positions, t) {
                    degenerate_dropped += 1;
                } else {
                    for i in t {
                        used.add(positions[i as usize]);
                    }
                    kept.push(t);
                }
            }
            part.triangle_count = kept.len() as u32 - part.first_triangle;
        }
        if kept.is_empty() {
            return Err(Error::EmptyMesh {
                degenerate: degenerate_dropped,
            });
        }
        parts.retain(|p| p.triangle_count > 0);
        Ok(TriMesh {
            positions,
            triangles: kept,
            parts,
            degenerate_dropped,
            bounds: used.aabb(),
        })
    }

    /// The parts the mesh was assembled from.
    pub fn parts(&self) -> &[Part] {
        &self.parts
    }

    /// Vertex positions.
    pub fn positions(&self) -> &[[f32; 3]] {
        &self.positions
    }

    /// Triangles as vertex index triples.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// How many triangles without area construction dropped.
    pub fn degenerate_dropped(&self) -> usize {
        self.degenerate_dropped
    }

    /// Position of vertex `i`.
    pub fn vertex(&self, i: u32) -> Vec3 {
        from_f32(self.positions[i as usize])
    }

    /// The three corners of triangle `t`.
    pub fn corners(&self, t: usize) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[t];
        [self.vertex(a), self.vertex(b), self.vertex(c)]
    }

    /// The vertices `triangles` use, each once, in ascending order.
    pub fn vertices_of(&self, triangles: &[u32]) -> Vec<u32> {
        let mut used: Vec<u32> = triangles
            .iter()
            .flat_map(|&t| self.triangles[t as usize])
            .collect();
        used.sort_unstable();
        used.dedup();
        used
    }

    /// Bounding box of the vertices that triangles use.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Total surface area.
    pub fn area(&self) -> f64 {
        (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.corners(t);
                (b - a).cross(c - a).length() * 0.5
            })
            .sum()
    }

    /// The point of the surface nearest to `p` (exhaustive: meant for one-off
    /// queries such as snapping a template centre, not for inner loops).
    pub fn closest_point(&self, p: Vec3) -> ClosestPoint {
        (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.corners(t);
                closest_point_on_triangle(p, a, b, c, t)
            })
            .min_by(|x, y| x.distance2.total_cmp(&y.distance2))
            .expect("a TriMesh always has a triangle")
    }

    /// The same mesh with every vertex moved by `f` (rotations and placements
    /// in tests and scene assembly); validated again, since `f` may produce
    /// anything.
    pub fn map_positions(&self, f: impl Fn(Vec3) -> Vec3) -> Result<TriMesh> {
        let positions = self
            .positions
            .iter()
            .map(|&p| {
                let q = f(from_f32(p));
                [q.x as f32, q.y as f32, q.z as f32]
            })
            .collect();
        TriMesh::with_parts(positions, self.triangles.clone(), self.parts.clone())
    }

    /// The mesh with only the triangles for which `keep(index)` holds (cutting
    /// holes in tests).
    pub fn filter_triangles(&self, mut keep: impl FnMut(usize) -> bool) -> Result<TriMesh> {
        let triangles = (0..self.triangles.len())
            .filter(|&i| keep(i))
            .map(|i| self.triangles[i])
            .collect();
        TriMesh::new(self.positions.clone(), triangles)
    }

    /// The mesh of `triangles` alone (a component), with only the vertices
    /// they use.
    pub fn subset(&self, triangles: &[u32]) -> TriMesh {
        let mut positions = Vec::new();
        let mut renumber = |slot: &mut u32, i: u32| {
            if *slot == u32::MAX {
                *slot = positions.len() as u32;
                positions.push(self.positions[i as usize]);
            }
            *slot
        };
        // Vertices numbered in order of first use either way. A small part
        // of a large mesh (one of a building's thousands) maps only what it
        // uses: a table over every vertex of the mesh, filled per part, was
        // a twentieth of searching 3 000 parts.
        let triangles: Vec<[u32; 3]> = if triangles.len() * 3 * SPARSE_SUBSET < self.positions.len()
        {
            let mut new_index = std::collections::HashMap::with_capacity(triangles.len() * 3);
            triangles
                .iter()
                .map(|&t| {
                    self.triangles[t as usize]
                        .map(|i| renumber(new_index.entry(i).or_insert(u32::MAX), i))
                })
                .collect()
        } else {
            let mut new_index = vec![u32::MAX; self.positions.len()];
            triangles
                .iter()
                .map(|&t| {
                    self.triangles[t as usize].map(|i| renumber(&mut new_index[i as usize], i))
                })
                .collect()
        };
        let part = Part::whole(positions.len(), triangles.len());
        let mut used = F32Box::EMPTY;
        for &p in &positions {
            used.add(p);
        }
        // The triangles were validated with these positions, and use every
        // one of them.
        TriMesh {
            positions,
            triangles,
            parts: vec![part],
            degenerate_dropped: 0,
            bounds: used.aabb(),
        }
    }

    /// Appends another mesh (used to merge the primitives of a scene).
    pub fn append(&mut self, other: &TriMesh) {
        let base = self.positions.len() as u32;
        let first_triangle = self.triangles.len() as u32;
        let sources = self.parts.iter().map(|p| p.source + 1).max().unwrap_or(0);
        self.parts.extend(other.parts.iter().map(|p| Part {
            first_vertex: p.first_vertex + base,
            first_triangle: p.first_triangle + first_triangle,
            source: p.source + sources,
            ..*p
        }));
        self.positions.extend_from_slice(&other.positions);
        self.triangles.extend(
            other
                .triangles
                .iter()
                .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
        );
        self.degenerate_dropped += other.degenerate_dropped;
        self.bounds = Aabb {
            min: self.bounds.min.min(other.bounds.min),
            max: self.bounds.max.max(other.bounds.max),
        };
    }
}

/// A box of f32 points, widened exactly to f64 at the end (the widening
/// keeps order, so it is the box of the widened points).
struct F32Box {
    min: [f32; 3],
    max: [f32; 3],
}

impl F32Box {
    const EMPTY: F32Box = F32Box {
        min: [f32::INFINITY; 3],
        max: [f32::NEG_INFINITY; 3],
    };

    /// Widens the box to `p`, whose coordinates are finite (compared, not
    /// `f32::min`: a library call in WebAssembly).
    fn add(&mut self, p: [f32; 3]) {
        for a in 0..3 {
            if p[a] < self.min[a] {
                self.min[a] = p[a];
            }
            if p[a] > self.max[a] {
                self.max[a] = p[a];
            }
        }
    }

    fn aabb(&self) -> Aabb {
        Aabb {
            min: from_f32(self.min),
            max: from_f32(self.max),
        }
    }
}

/// A triangle has no area when two corners coincide or all three are collinear.
pub(crate) fn is_degenerate(positions: &[[f32; 3]], [a, b, c]: [u32; 3]) -> bool {
    if a == b || b == c || a == c {
        return true;
    }
    let pa = from_f32(positions[a as usize]);
    let pb = from_f32(positions[b as usize]);
    let pc = from_f32(positions[c as usize]);
    (pb - pa).cross(pc - pa).length_squared() == 0.0
}

/// Bytes of a mesh: f32 positions and u32 triangles, with room to copy.
pub(crate) fn mesh_bytes(vertices: usize, triangles: usize) -> u64 {
    2 * (12 * vertices as u64 + 12 * triangles as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The box of the corners, read again.
    fn corner_box(m: &TriMesh) -> Aabb {
        Aabb::around((0..m.triangles().len()).flat_map(|t| m.corners(t))).unwrap()
    }

    #[test]
    fn a_subset_is_numbered_in_first_use_order_through_the_table_or_the_map() {
        // A torus of 2 400 vertices: two triangles take the hash map, a
        // third of the triangles the table. Both number the vertices in the
        // order the triangles first use them.
        let torus = crate::mesh::shapes::torus(Vec3::ZERO, 1.0, 0.3, 60, 40);
        let expected = |picked: &[u32]| {
            let mut order: Vec<u32> = Vec::new();
            let triangles: Vec<[u32; 3]> = picked
                .iter()
                .map(|&t| {
                    torus.triangles()[t as usize].map(|i| {
                        let at = order.iter().position(|&o| o == i).unwrap_or_else(|| {
                            order.push(i);
                            order.len() - 1
                        });
                        at as u32
                    })
                })
                .collect();
            let positions: Vec<[f32; 3]> = order
                .iter()
                .map(|&i| torus.positions()[i as usize])
                .collect();
            (positions, triangles)
        };
        let few = [4000u32, 17];
        let many: Vec<u32> = (0..torus.triangles().len() as u32)
            .step_by(3)
            .rev()
            .collect();
        assert!(few.len() * 3 * SPARSE_SUBSET < torus.positions().len());
        assert!(many.len() * 3 * SPARSE_SUBSET >= torus.positions().len());
        for picked in [&few[..], &many[..]] {
            let sub = torus.subset(picked);
            let (positions, triangles) = expected(picked);
            assert_eq!(sub.positions(), &positions[..]);
            assert_eq!(sub.triangles(), &triangles[..]);
        }
    }

    #[test]
    fn bounds_are_the_used_vertices_box_through_every_way_a_mesh_is_made() {
        // Vertex 4 is used by no triangle, vertex 3 by a degenerate one
        // only: neither is in the box.
        let p = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.5, 0.0],
            [0.0, 1.0, -2.0],
            [9.0, 0.0, 0.0],
            [-7.0, 3.0, 1.0],
            [0.5, -1.0, 0.25],
        ];
        let m = TriMesh::new(p, vec![[0, 1, 2], [0, 3, 3], [1, 2, 5]]).unwrap();
        assert_eq!(m.bounds(), corner_box(&m));
        assert_eq!(m.bounds().max.x, 1.0);
        assert_eq!(m.bounds().min.y, -1.0);
        let sub = m.subset(&[1]);
        assert_eq!(sub.bounds(), corner_box(&sub));
        let mut joined = m.clone();
        joined.append(&m.map_positions(|q| q * 3.0 + Vec3::X).unwrap());
        assert_eq!(joined.bounds(), corner_box(&joined));
        let shapes = crate::mesh::shapes::torus(Vec3::new(0.3, -0.2, 0.1), 1.0, 0.3, 24, 12);
        assert_eq!(shapes.bounds(), corner_box(&shapes));
    }

    #[test]
    fn drops_degenerate_triangles_and_keeps_the_rest() {
        let p = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [2.0, 0.0, 0.0],
        ];
        let m = TriMesh::new(p, vec![[0, 1, 2], [0, 1, 1], [0, 1, 3]]).unwrap();
        assert_eq!(m.triangles(), &[[0, 1, 2]]);
        assert_eq!(m.degenerate_dropped(), 2);
    }

    #[test]
    fn parts_shrink_with_their_dropped_triangles() {
        let p = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [2.0, 0.0, 0.0],
        ];
        let part = |first, count, source| Part {
            first_vertex: 0,
            vertex_count: 4,
            first_triangle: first,
            triangle_count: count,
            source,
        };
        let m = TriMesh::with_parts(
            p.clone(),
            vec![[0, 1, 2], [0, 1, 1], [0, 1, 3], [0, 2, 1]],
            vec![part(0, 2, 0), part(2, 2, 1)],
        )
        .unwrap();
        assert_eq!(m.triangles().len(), 2);
        assert_eq!(m.parts(), &[part(0, 1, 0), part(1, 1, 1)]);
        // Parts that do not cover the triangles are refused.
        assert!(TriMesh::with_parts(p, vec![[0, 1, 2]], vec![part(0, 2, 0)]).is_err());
    }

    #[test]
    fn only_degenerate_triangles_is_an_empty_mesh() {
        let p = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        let e = TriMesh::new(p, vec![[0, 1, 2]]).unwrap_err();
        assert!(matches!(e, Error::EmptyMesh { degenerate: 1 }), "{e}");
    }

    #[test]
    fn no_triangles_is_an_empty_mesh() {
        let e = TriMesh::new(vec![[0.0; 3]], vec![]).unwrap_err();
        assert!(matches!(e, Error::EmptyMesh { degenerate: 0 }), "{e}");
    }

    #[test]
    fn nan_and_infinity_are_rejected() {
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let p = vec![[0.0, 0.0, 0.0], [1.0, bad, 0.0], [0.0, 1.0, 0.0]];
            let e = TriMesh::new(p, vec![[0, 1, 2]]).unwrap_err();
            assert!(
                matches!(e, Error::NonFiniteCoordinate { vertex: 1, .. }),
                "{e}"
            );
        }
    }

    #[test]
    fn out_of_range_index_is_rejected() {
        let p = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let e = TriMesh::new(p, vec![[0, 1, 7]]).unwrap_err();
        assert!(matches!(e, Error::IndexOutOfRange { vertex: 7, .. }), "{e}");
    }
}
