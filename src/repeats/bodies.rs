//! Pieces that repeat together are one part.
//!
//! A CAD body arrives as tens of unwelded face pieces, and a mesh of two
//! wheels as two pieces that do not touch: each piece repeats, and the
//! pieces of one copy move together. Families of pieces whose copies pair
//! one to one, every pair at the same relative pose, are one family of
//! bodies: as a rigid group of an instanced model, the pieces of a copy
//! move as one.

use std::cell::OnceCell;
use std::collections::{BTreeMap, HashMap};

use super::CopyOf;
use crate::align::Rigid;
use crate::math::{Aabb, Vec3};
use crate::mesh::TriMesh;
use glam::DMat3;

/// One copy of a body: its pieces, and the motion from the body's first
/// copy.
pub(super) struct BodyCopy {
    pub pieces: Vec<usize>,
    pub pose: Rigid,
    pub residual: f64,
}

impl BodyCopy {
    /// Its triangles, ascending, given the triangles of each of `pieces`.
    pub fn triangles(&self, pieces: &[Vec<u32>]) -> Vec<u32> {
        let mut triangles: Vec<u32> = self
            .pieces
            .iter()
            .flat_map(|&p| pieces[p].iter().copied())
            .collect();
        triangles.sort_unstable();
        triangles
    }
}

/// A part found twice or more: how many pieces a copy has, and its copies.
pub(super) struct Body {
    pub pieces: usize,
    pub copies: Vec<BodyCopy>,
}

const IDENTITY: Rigid = Rigid {
    rotation: DMat3::IDENTITY,
    translation: Vec3::ZERO,
};

/// Poses agree when they move a piece's box corners this share of its
/// size apart at most, plus rounding: copies are exact, so the share is
/// that of the vertex test.
const POSE_TOLERANCE: f64 = 1e-4;

/// A family of pieces: its copies, the original first.
struct PieceFamily {
    copies: Vec<(usize, Rigid, f64)>,
    /// The original's box corners, to compare poses on.
    corners: [Vec3; 8],
    tolerance: f64,
    /// Where each copy puts the first corner, by x: the copies a pose may
    /// be are found by bisection.
    by_first_corner: Vec<(f64, usize)>,
    /// The original's vertices and their mean, for a copy whose motion is
    /// another's composed with a symmetry of the piece.
    vertices: Vec<Vec3>,
    centroid: Vec3,
    /// Where each copy puts the centroid, by x.
    by_centroid: Vec<(f64, usize)>,
    /// The original's vertices by cell of the tolerance's size, built
    /// when a pose is first looked up through a symmetry.
    cells: OnceCell<HashMap<[i64; 3], Vec<usize>>>,
}

impl PieceFamily {
    /// Each copy as a body of that one piece, to join others into.
    fn one_piece_bodies(&self) -> Vec<BodyCopy> {
        self.copies
            .iter()
            .map(|&(piece, pose, residual)| BodyCopy {
                pieces: vec![piece],
                pose,
                residual,
            })
            .collect()
    }

    /// The copy that `pose` moves the original onto, if any: where the
    /// copy's pose moves the corners as `pose` does, or, a symmetric piece
    /// being stored turned, where the two poses differ by a symmetry of
    /// the piece.
    fn copy_at(&self, pose: &Rigid) -> Option<usize> {
        self.copy_at_same_pose(pose)
            .or_else(|| self.copy_at_through_symmetry(pose))
    }

    /// The copy whose pose moves the corners within the tolerance of
    /// where `pose` moves them, if any.
    fn copy_at_same_pose(&self, pose: &Rigid) -> Option<usize> {
        let want = self.corners.map(|c| pose.apply(c));
        let from = self
            .by_first_corner
            .partition_point(|&(x, _)| x < want[0].x - self.tolerance);
        self.by_first_corner[from..]
            .iter()
            .take_while(|&&(x, _)| x <= want[0].x + self.tolerance)
            .map(|&(_, j)| j)
            .find(|&j| {
                let p = &self.copies[j].1;
                self.corners
                    .iter()
                    .zip(&want)
                    .all(|(&c, &w)| p.apply(c).distance(w) <= self.tolerance)
            })
    }

    /// The copy that `pose` moves the original onto where the copy's own
    /// pose differs from `pose` by a symmetry of the piece: it moves the
    /// centroid to the same place, and the motion between the two takes
    /// every vertex of the original onto one of its vertices.
    fn copy_at_through_symmetry(&self, pose: &Rigid) -> Option<usize> {
        let want = pose.apply(self.centroid);
        let from = self
            .by_centroid
            .partition_point(|&(x, _)| x < want.x - self.tolerance);
        let back = pose.inverse();
        self.by_centroid[from..]
            .iter()
            .take_while(|&&(x, _)| x <= want.x + self.tolerance)
            .map(|&(_, j)| j)
            .find(|&j| {
                let p = &self.copies[j].1;
                p.apply(self.centroid).distance(want) <= self.tolerance
                    && self.is_symmetry(&compose(&back, p))
            })
    }

    /// Whether `motion` takes every vertex of the original onto one of
    /// its vertices.
    fn is_symmetry(&self, motion: &Rigid) -> bool {
        let cell = |p: Vec3| (p / self.tolerance).floor().as_i64vec3().to_array();
        let cells = self.cells.get_or_init(|| {
            let mut cells: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
            for (i, &v) in self.vertices.iter().enumerate() {
                cells.entry(cell(v)).or_default().push(i);
            }
            cells
        });
        self.vertices.iter().all(|&v| {
            let moved = motion.apply(v);
            let [x, y, z] = cell(moved);
            (-1..=1).any(|dx| {
                (-1..=1).any(|dy| {
                    (-1..=1).any(|dz| {
                        cells.get(&[x + dx, y + dy, z + dz]).is_some_and(|near| {
                            near.iter()
                                .any(|&i| self.vertices[i].distance(moved) <= self.tolerance)
                        })
                    })
                })
            })
        })
    }

    /// For each of `anchor`'s copies, the copies of this family that move
    /// with it, as many with each and each copy once, if every copy does.
    fn moves_with(&self, anchor: &PieceFamily) -> Option<Vec<Vec<usize>>> {
        let (n, m) = (anchor.copies.len(), self.copies.len());
        if m % n != 0 {
            return None;
        }
        let mut taken = vec![false; m];
        let mut with: Vec<Vec<usize>> = vec![Vec::with_capacity(m / n); n];
        let mut found = 0;
        // Which copies stand beside the anchor's original: each is tried.
        for first in 0..m {
            if taken[first] {
                continue;
            }
            let beside = self.copies[first].1;
            let mut pairing = Vec::with_capacity(n);
            for (_, pose, _) in &anchor.copies {
                match self.copy_at(&compose(pose, &beside)) {
                    Some(j) if !taken[j] && !pairing.contains(&j) => pairing.push(j),
                    _ => break,
                }
            }
            if pairing.len() < n {
                continue;
            }
            for (copy, j) in with.iter_mut().zip(pairing) {
                taken[j] = true;
                copy.push(j);
            }
            found += 1;
            if found * n == m {
                return Some(with);
            }
        }
        None
    }
}

/// `a` after `b`.
pub(super) fn compose(a: &Rigid, b: &Rigid) -> Rigid {
    Rigid {
        rotation: a.rotation * b.rotation,
        translation: a.apply(b.translation),
    }
}

fn corners(bounds: Aabb) -> [Vec3; 8] {
    std::array::from_fn(|i| {
        Vec3::new(
            if i & 1 == 0 {
                bounds.min.x
            } else {
                bounds.max.x
            },
            if i & 2 == 0 {
                bounds.min.y
            } else {
                bounds.max.y
            },
            if i & 4 == 0 {
                bounds.min.z
            } else {
                bounds.max.z
            },
        )
    })
}

/// The families of pieces that repeat: a piece's copies, its original
/// first.
fn piece_families(
    mesh: &TriMesh,
    pieces: &[Vec<u32>],
    copies: &[Option<CopyOf>],
) -> Vec<PieceFamily> {
    let mut families: BTreeMap<usize, Vec<(usize, Rigid, f64)>> = BTreeMap::new();
    for (p, copy) in copies.iter().enumerate() {
        if let Some(copy) = copy {
            families
                .entry(copy.original)
                .or_insert_with(|| vec![(copy.original, IDENTITY, 0.0)])
                .push((p, copy.motion, copy.residual));
        }
    }
    families
        .into_values()
        .map(|copies| {
            let original = &pieces[copies[0].0];
            let vertices: Vec<Vec3> = mesh
                .vertices_of(original)
                .into_iter()
                .map(|v| mesh.vertex(v))
                .collect();
            let centroid = vertices.iter().copied().sum::<Vec3>() / vertices.len() as f64;
            let bounds = Aabb::around(vertices.iter().copied()).expect("a piece has triangles");
            let size = bounds.max.distance(bounds.min);
            let magnitude = bounds.min.abs().max(bounds.max.abs()).max_element();
            let corners = corners(bounds);
            let mut by_first_corner: Vec<(f64, usize)> = copies
                .iter()
                .enumerate()
                .map(|(j, (_, pose, _))| (pose.apply(corners[0]).x, j))
                .collect();
            by_first_corner.sort_by(|a, b| a.0.total_cmp(&b.0));
            let mut by_centroid: Vec<(f64, usize)> = copies
                .iter()
                .enumerate()
                .map(|(j, (_, pose, _))| (pose.apply(centroid).x, j))
                .collect();
            by_centroid.sort_by(|a, b| a.0.total_cmp(&b.0));
            PieceFamily {
                copies,
                corners,
                tolerance: POSE_TOLERANCE * size + 8.0 * f64::from(f32::EPSILON) * magnitude,
                by_first_corner,
                vertices,
                centroid,
                by_centroid,
                cells: OnceCell::new(),
            }
        })
        .collect()
}

/// The bodies of `pieces`, given which piece copies which: families of
/// pieces that move together, joined.
pub(super) fn bodies(mesh: &TriMesh, pieces: &[Vec<u32>], copies: &[Option<CopyOf>]) -> Vec<Body> {
    let families = piece_families(mesh, pieces, copies);
    // Families by copy count: only those of one count can move together.
    let mut by_count: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for (f, family) in families.iter().enumerate() {
        by_count.entry(family.copies.len()).or_default().push(f);
    }
    let mut joined = vec![false; families.len()];
    let mut bodies = Vec::new();
    for same_count in by_count.values() {
        for (k, &anchor) in same_count.iter().enumerate() {
            if joined[anchor] {
                continue;
            }
            let a = &families[anchor];
            let mut body = a.one_piece_bodies();
            let mut members = 1;
            for &other in &same_count[k + 1..] {
                if joined[other] {
                    continue;
                }
                let Some(pairing) = families[other].moves_with(a) else {
                    continue;
                };
                joined[other] = true;
                members += 1;
                join_into(&mut body, &families[other], pairing);
            }
            bodies.push(Body {
                pieces: members,
                copies: body,
            });
        }
    }
    bodies
}

/// Adds `family`'s pieces to the body copies they move with.
fn join_into(body: &mut [BodyCopy], family: &PieceFamily, pairing: Vec<Vec<usize>>) {
    for (copy, with) in body.iter_mut().zip(pairing) {
        for j in with {
            let (piece, _, residual) = family.copies[j];
            copy.pieces.push(piece);
            copy.residual = copy.residual.max(residual);
        }
    }
}

/// Where `pieces` are, all of them, copies of one body (each piece in a
/// family, each family as many times in every copy), those copies.
pub(super) fn one_body(
    mesh: &TriMesh,
    pieces: &[Vec<u32>],
    copies: &[Option<CopyOf>],
) -> Option<Vec<BodyCopy>> {
    let families = piece_families(mesh, pieces, copies);
    let covered: usize = families.iter().map(|f| f.copies.len()).sum();
    if covered != pieces.len() {
        return None;
    }
    let anchor = families.iter().min_by_key(|f| f.copies.len())?;
    let mut body = anchor.one_piece_bodies();
    for family in &families {
        if std::ptr::eq(family, anchor) {
            continue;
        }
        join_into(&mut body, family, family.moves_with(anchor)?);
    }
    Some(body)
}
