//! Whole copy, or part of a larger whole. Part-in-whole (the paper's case)
//! reports a larger part that holds the template, a taller variant of a
//! building or an assembly fused around a bracket, as a copy; a user who
//! deduplicates a CAD or BIM export wants whole copies only.
//!
//! An instance is a whole copy when the scene's own parts it lies on are
//! themselves explained by the template: the connected components it
//! touches that lie, for [`WHOLE_SHARE`] of their own surface, within
//! the tolerance of the template's surface at the instance's pose, must
//! hold as much of the template's landed surface. Components, not the part the
//! search looked at: a CAD body arrives as many unwelded pieces, each
//! explained, and a bolt's head may rest on a plate whose box the search
//! joined to the bolt's, which holds a few of the template's samples and is
//! not the bolt's own.
//!
//! The tolerance is the verdict's, both ways, so a whole copy is one the
//! template could replace: a copy bent by 30 degrees (twisted-homer) keeps
//! 89% of the template's surface within it and 83-85% of its own, and is
//! reported as an occurrence but not as a whole copy.

use std::borrow::Cow;
use std::collections::HashMap;

use crate::align::{Rigid, SurfaceIndex, SurfaceSamples};
use crate::math::{Aabb, Vec3};
use crate::mesh::TriMesh;

/// The least share of a component's own surface the template must explain
/// for the component to belong to a whole copy, and of the template's
/// landed surface that must lie on such components. Not one: a sample on
/// an edge may sit a rounding past the tolerance.
const WHOLE_SHARE: f64 = 0.98;

/// Samples taken on each component to tell how much of it the template
/// explains: a feature of 2% of its surface is seen by about ten.
const COMPONENT_SAMPLES: usize = 512;

/// A scene part's connected components (triangles joined through vertices
/// at exactly the same position, as the scene's parts are).
pub(super) struct Components<'a> {
    /// Each component's triangles (mesh numbering).
    triangles: Vec<Cow<'a, [u32]>>,
    /// The component of each triangle; empty when there is one component.
    of: HashMap<u32, usize>,
}

impl<'a> Components<'a> {
    /// The components of `part` (mesh numbering); `one` when the part is
    /// known to be a single component.
    pub(super) fn of(mesh: &TriMesh, part: &'a [u32], one: bool) -> Components<'a> {
        if one {
            return Components {
                triangles: vec![Cow::Borrowed(part)],
                of: HashMap::new(),
            };
        }
        let mut vertex_of: HashMap<[u32; 3], usize> = HashMap::new();
        let mut parent: Vec<usize> = Vec::new();
        fn root(parent: &mut [usize], mut i: usize) -> usize {
            while parent[i] != i {
                parent[i] = parent[parent[i]];
                i = parent[i];
            }
            i
        }
        let mut first_vertex = Vec::with_capacity(part.len());
        for &t in part {
            let ids = mesh.triangles()[t as usize].map(|v| {
                let key = mesh.positions()[v as usize].map(f32::to_bits);
                *vertex_of.entry(key).or_insert_with(|| {
                    parent.push(parent.len());
                    parent.len() - 1
                })
            });
            for k in 1..3 {
                let (a, b) = (root(&mut parent, ids[0]), root(&mut parent, ids[k]));
                parent[a.max(b)] = a.min(b);
            }
            first_vertex.push(ids[0]);
        }
        let mut number: HashMap<usize, usize> = HashMap::new();
        let mut triangles: Vec<Vec<u32>> = Vec::new();
        let mut of = HashMap::with_capacity(part.len());
        for (&t, &v) in part.iter().zip(&first_vertex) {
            let r = root(&mut parent, v);
            let c = *number.entry(r).or_insert_with(|| {
                triangles.push(Vec::new());
                triangles.len() - 1
            });
            triangles[c].push(t);
            of.insert(t, c);
        }
        Components {
            triangles: triangles.into_iter().map(Cow::Owned).collect(),
            of,
        }
    }

    fn component(&self, triangle: u32) -> usize {
        self.of.get(&triangle).copied().unwrap_or(0)
    }
}

/// The template's surface in its own coordinates, indexed for "is there
/// template surface within the tolerance of this point?".
pub(super) fn template_index(template: &TriMesh, tolerance: f64) -> SurfaceIndex<'_> {
    let bounds = template.bounds();
    let bounds = Aabb {
        min: bounds.min - Vec3::splat(tolerance),
        max: bounds.max + Vec3::splat(tolerance),
    };
    // Queries reach one tolerance: cells of two, or a 48th of the box.
    let cell = (2.0 * tolerance).max(bounds.extent().max_element() / 48.0);
    let all = (0..template.triangles().len() as u32).collect();
    SurfaceIndex::new(template, all, bounds, cell)
}

/// Whether the copy at `pose` (template to scene), whose template
/// `samples` landed on the scene triangles `landed`, is a whole copy (see
/// the module's documentation). `template` is [`template_index`]'s.
pub(super) fn is_whole(
    mesh: &TriMesh,
    components: &Components,
    landed: &[u32],
    samples: &SurfaceSamples,
    template: &SurfaceIndex,
    pose: &Rigid,
    tolerance: f64,
) -> bool {
    let mut touched: Vec<usize> = landed.iter().map(|&t| components.component(t)).collect();
    touched.sort_unstable();
    touched.dedup();
    let back = pose.inverse();
    let own: Vec<u32> = touched
        .into_iter()
        .filter(|&c| {
            explained(mesh, &components.triangles[c], template, &back, tolerance) >= WHOLE_SHARE
        })
        .flat_map(|c| components.triangles[c].iter().copied())
        .collect();
    let Some(bounds) = Aabb::around(own.iter().flat_map(|&t| mesh.corners(t as usize))) else {
        return false;
    };
    // Where the template's surface coincides with a neighbour's (a head on
    // a plate), a sample may have landed on either: it counts as the
    // copy's when the copy's own surface is as near.
    let bounds = Aabb {
        min: bounds.min - Vec3::splat(tolerance),
        max: bounds.max + Vec3::splat(tolerance),
    };
    let cell = (2.0 * tolerance).max(bounds.extent().max_element() / 48.0);
    let own = SurfaceIndex::new(mesh, own, bounds, cell);
    let on_own = samples
        .points()
        .iter()
        .filter(|&&p| own.reaches(pose.apply(p), tolerance))
        .count();
    on_own as f64 >= WHOLE_SHARE * landed.len() as f64
}

/// The share of the surface of `triangles` (scene) that lies within
/// `tolerance` of the template's, taken back into the template by `back`.
fn explained(
    mesh: &TriMesh,
    triangles: &[u32],
    template: &SurfaceIndex,
    back: &Rigid,
    tolerance: f64,
) -> f64 {
    let corners: Vec<[Vec3; 3]> = triangles
        .iter()
        .map(|&t| mesh.corners(t as usize))
        .collect();
    let samples = SurfaceSamples::new(&corners, COMPONENT_SAMPLES, |_| true);
    let points = samples.points();
    if points.is_empty() {
        return 1.0;
    }
    let near = points
        .iter()
        .filter(|&&q| template.reaches(back.apply(q), tolerance))
        .count();
    near as f64 / points.len() as f64
}
