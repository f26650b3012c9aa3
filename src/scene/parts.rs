//! A scene's parts: its connected components, or those joined where their
//! boxes overlap (a template of several shells), each with its bounding
//! sphere and box.

use crate::exec::Threads;
use crate::math::Aabb;
use crate::mesh::{TriMesh, VertexNumbering, connected_components, minimal_bounding_sphere};

/// One connected component of the scene's mesh: the voxel descriptors see
/// a candidate's own part only, so that neighbours touching it or sitting
/// in it do not hide it.
#[derive(Clone, Debug)]
pub struct ScenePart {
    triangles: Vec<u32>,
    radius: f64,
    bounds: Aabb,
}

impl ScenePart {
    /// The parts of `mesh` made of each of `lists`, their spheres and boxes
    /// found on `backend`'s threads.
    fn all(mesh: &TriMesh, lists: Vec<Vec<u32>>, backend: Threads) -> Vec<ScenePart> {
        let shapes = backend.map_each(lists.len(), |k| ScenePart::shape(mesh, &lists[k]));
        lists
            .into_iter()
            .zip(shapes)
            .map(|(triangles, (radius, bounds))| ScenePart {
                triangles,
                radius,
                bounds,
            })
            .collect()
    }

    /// The minimal bounding sphere's radius and the box of `triangles`'
    /// vertices, each read once.
    fn shape(mesh: &TriMesh, triangles: &[u32]) -> (f64, Aabb) {
        let mut numbering = VertexNumbering::for_part(mesh, triangles);
        let mut vertices = Vec::new();
        for &t in triangles {
            for v in mesh.triangles()[t as usize] {
                if numbering.number(v).1 {
                    vertices.push(mesh.vertex(v));
                }
            }
        }
        (
            minimal_bounding_sphere(&vertices).map_or(0.0, |s| s.radius),
            Aabb::around(vertices).expect("a part has vertices"),
        )
    }

    /// The radius of the part's minimal bounding sphere.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// Its triangles in the scene's mesh.
    pub fn triangles(&self) -> &[u32] {
        &self.triangles
    }

    /// Its bounding box.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }
}

/// The connected parts of `mesh` with their bounds and bounding spheres.
pub(super) fn split_parts(mesh: &TriMesh, backend: Threads) -> Vec<ScenePart> {
    ScenePart::all(mesh, connected_components(mesh, backend), backend)
}

/// Joins the parts whose bounding boxes overlap, transitively (a sweep
/// along x, then union-find).
pub(super) fn join_overlapping(
    mesh: &TriMesh,
    parts: &[ScenePart],
    backend: Threads,
) -> Vec<ScenePart> {
    let mut group: Vec<usize> = (0..parts.len()).collect();
    fn root(group: &mut [usize], mut i: usize) -> usize {
        while group[i] != i {
            group[i] = group[group[i]];
            i = group[i];
        }
        i
    }
    let mut by_x: Vec<usize> = (0..parts.len()).collect();
    by_x.sort_by(|&a, &b| parts[a].bounds.min.x.total_cmp(&parts[b].bounds.min.x));
    for (k, &a) in by_x.iter().enumerate() {
        let boxed = parts[a].bounds;
        for &b in &by_x[k + 1..] {
            let other = parts[b].bounds;
            if other.min.x > boxed.max.x {
                break;
            }
            let overlap =
                (0..3).all(|i| other.min[i] <= boxed.max[i] && boxed.min[i] <= other.max[i]);
            if overlap {
                let (ra, rb) = (root(&mut group, a), root(&mut group, b));
                group[ra.max(rb)] = ra.min(rb);
            }
        }
    }
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); parts.len()];
    for i in 0..parts.len() {
        let r = root(&mut group, i);
        members[r].extend_from_slice(&parts[i].triangles);
    }
    let lists = members
        .into_iter()
        .filter(|m| !m.is_empty())
        .map(|mut triangles| {
            triangles.sort_unstable();
            triangles
        })
        .collect();
    ScenePart::all(mesh, lists, backend)
}
