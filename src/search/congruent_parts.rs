//! Parts that are rigid copies of each other are searched once.
//!
//! A CAD assembly or a building model repeats its parts: two dozen rollers,
//! hundreds of one fitting, baked into one mesh with the same triangles in
//! the same order, each moved. The voxel search describes a point by its
//! own part alone, so what it finds on a part is a function of that part's
//! shape: found on one copy, it holds on every other, moved with it. So a
//! part whose triangles, vertex for vertex, are another's moved rigidly
//! (within float rounding) takes that part's instances, moved. A part of
//! the same shape meshed differently is searched on its own, as before.

use std::collections::HashMap;

use crate::align::Rigid;
use crate::math::Vec3;
use crate::mesh::TriMesh;
use glam::DMat3;

/// Vertices may differ by this share of the part's radius, plus the
/// rounding of their f32 coordinates: far below a voxel.
const TOLERANCE: f64 = 1e-4;

/// A part's vertices in the order its triangles first use them, and its
/// triangles in those local indices.
struct Local {
    vertices: Vec<Vec3>,
    centroid: Vec3,
    /// Root mean square distance of the vertices from the centroid: equal
    /// for rigid copies.
    spread: f64,
    /// The largest coordinate's magnitude: what f32 rounding scales with.
    magnitude: f64,
}

impl Local {
    fn new(mesh: &TriMesh, triangles: &[u32], index: &mut LocalIndex) -> (Local, Vec<u32>) {
        index.begin();
        let mut vertices = Vec::new();
        let mut pattern = Vec::with_capacity(3 * triangles.len());
        for &t in triangles {
            for v in mesh.triangles()[t as usize] {
                let local = index.local(v, vertices.len() as u32);
                if local as usize == vertices.len() {
                    vertices.push(mesh.vertex(v));
                }
                pattern.push(local);
            }
        }
        let centroid = vertices.iter().copied().sum::<Vec3>() / vertices.len().max(1) as f64;
        let spread = (vertices
            .iter()
            .map(|v| v.distance_squared(centroid))
            .sum::<f64>()
            / vertices.len().max(1) as f64)
            .sqrt();
        let magnitude = vertices
            .iter()
            .map(|v| v.abs().max_element())
            .fold(0.0, f64::max);
        (
            Local {
                vertices,
                centroid,
                spread,
                magnitude,
            },
            pattern,
        )
    }

    /// Indices of two vertices that, with the centroid, make a frame:
    /// the farthest from the centroid, then the farthest from its line.
    fn frame_vertices(&self) -> Option<(usize, usize)> {
        let c = self.centroid;
        let (a, da) = self
            .vertices
            .iter()
            .enumerate()
            .map(|(i, v)| (i, v.distance(c)))
            .max_by(|x, y| x.1.total_cmp(&y.1))?;
        let axis = (self.vertices[a] - c) / da;
        let (b, db) = self
            .vertices
            .iter()
            .enumerate()
            .map(|(i, v)| (i, (*v - c).cross(axis).length()))
            .max_by(|x, y| x.1.total_cmp(&y.1))?;
        (da > 0.0 && db > 1e-6 * da).then_some((a, b))
    }

    /// The orthonormal frame of vertices `a` and `b` about the centroid.
    fn frame(&self, (a, b): (usize, usize)) -> DMat3 {
        let x = (self.vertices[a] - self.centroid).normalize();
        let z = x.cross(self.vertices[b] - self.centroid).normalize();
        DMat3::from_cols(x, z.cross(x), z)
    }

    /// The rigid motion taking `self` onto `other` vertex by vertex, if
    /// every vertex lands within the tolerance.
    fn motion_to(&self, other: &Local, pair: (usize, usize)) -> Option<Rigid> {
        let rotation = other.frame(pair) * self.frame(pair).transpose();
        let motion = Rigid {
            rotation,
            translation: other.centroid - rotation * self.centroid,
        };
        let tolerance = TOLERANCE * self.spread.max(other.spread)
            + 4.0 * f64::from(f32::EPSILON) * self.magnitude.max(other.magnitude);
        self.vertices
            .iter()
            .zip(&other.vertices)
            .all(|(&p, &q)| motion.apply(p).distance(q) <= tolerance)
            .then_some(motion)
    }
}

/// Each vertex of the mesh's local index in one part at a time, by array
/// rather than hash map: a hash map made finding copies take longer than
/// searching (90 ms of crowd-rocker's 950 000 triangles, against a 32 ms
/// match stage). A stamp per vertex says whether its index is the
/// current part's, so nothing is cleared between parts.
struct LocalIndex {
    stamp: Vec<u32>,
    local: Vec<u32>,
    current: u32,
}

impl LocalIndex {
    fn new(vertices: usize) -> LocalIndex {
        LocalIndex {
            stamp: vec![0; vertices],
            local: vec![0; vertices],
            current: 0,
        }
    }

    /// Starts a part: every vertex unnumbered.
    fn begin(&mut self) {
        self.current = self.current.wrapping_add(1);
        if self.current == 0 {
            self.stamp.fill(0);
            self.current = 1;
        }
    }

    /// `v`'s index in the current part, `next` if it has none yet.
    fn local(&mut self, v: u32, next: u32) -> u32 {
        let v = v as usize;
        if self.stamp[v] != self.current {
            self.stamp[v] = self.current;
            self.local[v] = next;
        }
        self.local[v]
    }
}

/// A hash of a part's triangles in local indices: equal lists hash
/// equal, and lists that meet are compared in full, so a fast mix serves
/// where SipHash's resistance to chosen keys buys nothing.
fn pattern_hash(pattern: &[u32]) -> u64 {
    pattern.iter().fold(pattern.len() as u64, |h, &i| {
        (h.rotate_left(5) ^ u64::from(i)).wrapping_mul(0x9E37_79B9_7F4A_7C15)
    })
}

/// A searched part that later ones may copy, in brief: its vertices are
/// read again only for a part that may be its copy, so that a scene of
/// distinct parts does not hold a second copy of its mesh.
struct Original {
    part: usize,
    spread: f64,
    magnitude: f64,
    /// The two vertices that make its frame.
    pair: (usize, usize),
}

/// For each of `parts` (triangle lists of `mesh`), `None` where it is
/// searched, or the earlier part it copies and the motion from that part
/// to it. Only parts that are searched are copied from.
pub(super) fn congruent_parts(mesh: &TriMesh, parts: &[&[u32]]) -> Vec<Option<(usize, Rigid)>> {
    let mut index = LocalIndex::new(mesh.positions().len());
    // Searched parts by their triangles in local indices (a hash of them:
    // equal lists are checked when the hashes meet).
    let mut originals: HashMap<(usize, usize, u64), Vec<Original>> = HashMap::new();
    parts
        .iter()
        .enumerate()
        .map(|(i, triangles)| {
            let (local, pattern) = Local::new(mesh, triangles, &mut index);
            let key = (pattern.len(), local.vertices.len(), pattern_hash(&pattern));
            let same_pattern = originals.entry(key).or_default();
            let copied = same_pattern.iter().find_map(|original| {
                let close = (original.spread - local.spread).abs()
                    <= TOLERANCE * original.spread.max(local.spread)
                        + 4.0 * f64::from(f32::EPSILON) * original.magnitude.max(local.magnitude);
                if !close {
                    return None;
                }
                let (there, their_pattern) = Local::new(mesh, parts[original.part], &mut index);
                (their_pattern == pattern)
                    .then(|| there.motion_to(&local, original.pair))
                    .flatten()
                    .map(|m| (original.part, m))
            });
            if copied.is_none()
                && let Some(pair) = local.frame_vertices()
            {
                same_pattern.push(Original {
                    part: i,
                    spread: local.spread,
                    magnitude: local.magnitude,
                    pair,
                });
            }
            copied
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::{cuboid, torus};
    use glam::DQuat;

    fn placed(mesh: &TriMesh, turn: DQuat, shift: Vec3) -> TriMesh {
        mesh.map_positions(|p| turn * p + shift).unwrap()
    }

    #[test]
    fn moved_copies_are_found_and_other_shapes_are_not() {
        let ring = torus(Vec3::ZERO, 1.0, 0.3, 24, 12);
        let turn = DQuat::from_axis_angle(Vec3::new(1.0, 2.0, -0.5).normalize(), 2.1);
        let mut scene = ring.clone();
        scene.append(&placed(&ring, turn, Vec3::new(5.0, -3.0, 2.0)));
        // The same triangles, stretched: not a rigid copy.
        scene.append(
            &ring
                .map_positions(|p| p * Vec3::new(1.0, 1.0, 1.2))
                .unwrap(),
        );
        // A mirror image: not a proper motion.
        scene.append(
            &ring
                .map_positions(|p| p * Vec3::new(-1.0, 1.0, 1.0) + Vec3::X * 9.0)
                .unwrap(),
        );
        scene.append(&cuboid(Vec3::splat(10.0), Vec3::splat(11.0)));
        scene.append(&placed(&ring, DQuat::IDENTITY, Vec3::new(0.0, 20.0, 0.0)));
        let n = ring.triangles().len() as u32;
        let parts: Vec<Vec<u32>> = (0..4)
            .map(|k| (k * n..(k + 1) * n).collect())
            .chain([
                (4 * n..4 * n + 12).collect(),
                (4 * n + 12..5 * n + 12).collect(),
            ])
            .collect();
        let lists: Vec<&[u32]> = parts.iter().map(|p| p.as_slice()).collect();
        let copies = congruent_parts(&scene, &lists);
        let originals: Vec<Option<usize>> = copies.iter().map(|c| c.map(|(j, _)| j)).collect();
        assert_eq!(originals, [None, Some(0), None, None, None, Some(0)]);
        // The motion takes the first ring onto the second.
        let (_, motion) = copies[1].unwrap();
        for p in ring.positions() {
            let p = Vec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            let q = turn * p + Vec3::new(5.0, -3.0, 2.0);
            assert!(motion.apply(p).distance(q) < 1e-5, "{p:?}");
        }
    }
}
