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
use std::hash::BuildHasherDefault;

use super::CopyOf;
use crate::align::Rigid;
use crate::math::{Aabb, Vec3};
use crate::mesh::{FxHasher, TriMesh};
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

    /// How far, at most, the rotation of a copy that [`Self::copy_at`]
    /// finds for a pose lies from the pose's (the spectral norm of their
    /// difference), where the piece has no symmetry but the identity:
    /// `None` where it may have one.
    ///
    /// Whatever `copy_at` lets through is a motion S (the pose undone,
    /// then the copy's) that moves the centroid within the tolerance t
    /// and each vertex within t of a vertex: a symmetry, or the identity
    /// off by rounding. Three vertices pin S down where every vertex it
    /// could be taken near lies close to the vertex itself: the farthest
    /// from the centroid (it lands as far, within 2t), the farthest from
    /// that axis (as far, and as far along it), and the farthest from
    /// their plane (as far from the centroid, and as far along the two).
    /// Each then moves at most t past that cluster's width, and the
    /// rotation of S lies from the identity by at most what those three
    /// moves allow, doubled for rounding.
    fn turn_bound(&self) -> Option<f64> {
        let t = self.tolerance;
        let c = self.centroid;
        let vertices = &self.vertices;
        let farthest = |score: &dyn Fn(Vec3) -> f64| {
            vertices
                .iter()
                .copied()
                .max_by(|a, b| score(*a).total_cmp(&score(*b)))
        };
        // The widest cluster of vertices near `v`: those that pass `near`.
        let spread = |v: Vec3, near: &dyn Fn(Vec3) -> bool| {
            vertices
                .iter()
                .filter(|&&w| near(w))
                .map(|w| w.distance(v))
                .fold(0.0, f64::max)
        };
        let a = farthest(&|v| v.distance(c))?;
        let da = a.distance(c);
        if da <= 0.0 {
            return None;
        }
        let ea = 2.0 * t + spread(a, &|w| w.distance(c) >= da - 2.0 * t);
        let axis = (a - c) / da;
        // How far S may turn the axis: |R^T x - x| for x along it.
        let ka = ea / da;
        let off_axis = |v: Vec3| {
            let u = v - c;
            (u - u.dot(axis) * axis).length()
        };
        let b = farthest(&off_axis)?;
        let (db, rb) = (b.distance(c), off_axis(b));
        if rb <= 1e-6 * da {
            return None;
        }
        let along_a = |v: Vec3| (v - c).dot(axis);
        let reach_b = db * ka + 2.0 * t;
        let eb = 2.0 * t
            + spread(b, &|w| {
                (w.distance(c) - db).abs() <= 2.0 * t && (along_a(w) - along_a(b)).abs() <= reach_b
            });
        let ub = b - c;
        let side = (ub - ub.dot(axis) * axis) / rb;
        let kb = (eb + db * ka) / rb;
        let normal = axis.cross(side);
        let cv = farthest(&|v| (v - c).dot(normal).abs())?;
        let dc = cv.distance(c);
        if (cv - c).dot(normal).abs() <= 1e-6 * da {
            return None;
        }
        let along_b = |v: Vec3| (v - c).dot(side);
        let ec = 2.0 * t
            + spread(cv, &|w| {
                (w.distance(c) - dc).abs() <= 2.0 * t
                    && (along_a(w) - along_a(cv)).abs() <= dc * ka + 2.0 * t
                    && (along_b(w) - along_b(cv)).abs() <= dc * kb + 2.0 * t
            });
        // |R - I| <= |(R - I) U| |U^-1|, U the three vertices about the
        // centroid, each column of (R - I) U at most its vertex's move.
        let u = DMat3::from_cols(a - c, ub, cv - c);
        let inverse = u.inverse();
        let frobenius = (inverse.x_axis.length_squared()
            + inverse.y_axis.length_squared()
            + inverse.z_axis.length_squared())
        .sqrt();
        let bound = 2.0 * (ea * ea + eb * eb + ec * ec).sqrt() * frobenius;
        bound.is_finite().then_some(bound)
    }

    /// How far, at most, a copy's pose moves a point `reach` from the
    /// centroid from where the anchor's motion that finds it does (see
    /// [`PoseIndex`]), given [`Self::turn_bound`] `turn`: twice the
    /// tolerance, and twice the turn over that reach, doubled for
    /// rounding.
    fn translation_bound(&self, turn: f64, reach: f64) -> f64 {
        2.0 * (2.0 * self.tolerance + 2.0 * turn * reach)
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
    bodies_counted(mesh, pieces, copies).0
}

/// [`bodies`], and how many pairs of families it tried to move together.
///
/// Each family joins the first earlier family left unjoined (an anchor)
/// that it moves with, as before; but only the families that
/// [`PoseIndex`] finds for an anchor are tried: trying each with every
/// other of as many copies was quadratic, 20 000 parts each with one
/// mirror image took most of a minute.
fn bodies_counted(
    mesh: &TriMesh,
    pieces: &[Vec<u32>],
    copies: &[Option<CopyOf>],
) -> (Vec<Body>, usize) {
    let families = piece_families(mesh, pieces, copies);
    // Families by copy count: only those of one count can move together.
    let mut by_count: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for (f, family) in families.iter().enumerate() {
        by_count.entry(family.copies.len()).or_default().push(f);
    }
    let mut joined = vec![false; families.len()];
    let mut bodies = Vec::new();
    let mut tried = 0;
    for same_count in by_count.values() {
        let index = PoseIndex::new(&families, same_count);
        for (k, &anchor) in same_count.iter().enumerate() {
            if joined[anchor] {
                continue;
            }
            let a = &families[anchor];
            let mut body = a.one_piece_bodies();
            let mut members = 1;
            for other in index.candidates(a, k) {
                let other = same_count[other];
                if joined[other] {
                    continue;
                }
                tried += 1;
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
    (bodies, tried)
}

/// The families of one copy count that may move with an anchor.
///
/// A family moves with an anchor when, for some copy `f` of it, the
/// anchor's poses composed with `f`'s find a copy each, one of them its
/// original. Say its original is found at the anchor's copy `l`: then at
/// each other copy `l'` of the anchor it has a copy `j` whose pose is the
/// anchor's motion from `l` to `l'`, P(l') P(l)^-1, within what
/// [`PieceFamily::copy_at`] lets through twice: its centroid within
/// twice the tolerance, and, where the piece has no symmetry but the
/// identity ([`PieceFamily::turn_bound`]), its rotation within twice
/// that bound. Each copy's pose but the original's is kept by its
/// rotation and where it moves the origin of the family's region (within
/// twice the tolerance and the turn's bound over the origin's distance
/// from the centroid), in cells at least four times as wide as those
/// bounds; an anchor looks up the cells about its motions P(1) and
/// P(l)^-1 (l the copy that finds the original: the anchor's first copy
/// or another). A family whose piece may be symmetric is tried with
/// every anchor.
struct PoseIndex {
    /// The copies' poses by region, levels and cells: the families'
    /// places in the count's list.
    cells: HashMap<CellKey, Vec<usize>, BuildHasherDefault<FxHasher>>,
    /// Each region's origin and the levels in use there.
    regions: Vec<(Vec3, Vec<Levels>)>,
    /// Those tried with every anchor, ascending.
    everywhere: Vec<usize>,
}

/// The rotation's and the translation's levels of a family's bounds:
/// cells of 2^(level + 2), four times the bound or more.
type Levels = (i32, i32);

/// A cell of poses: the region, the levels, and the values' cells.
type CellKey = (usize, Levels, [i64; 6]);

/// The regions along each axis of the box about the families' centroids:
/// a pose is kept by where it moves its region's origin, which a turn
/// that the bounds allow moves less the nearer the origin is.
const REGIONS: usize = 4;

impl PoseIndex {
    fn new(families: &[PieceFamily], same_count: &[usize]) -> PoseIndex {
        let mut index = PoseIndex {
            cells: HashMap::default(),
            regions: Vec::new(),
            everywhere: Vec::new(),
        };
        let Some(bounds) = Aabb::around(same_count.iter().map(|&f| families[f].centroid)) else {
            return index;
        };
        let step = (bounds.max - bounds.min).max_element().max(1e-9) / REGIONS as f64;
        let origin = |r: [usize; 3]| {
            bounds.min + step * (Vec3::new(r[0] as f64, r[1] as f64, r[2] as f64) + 0.5)
        };
        let mut region_of: HashMap<[usize; 3], usize> = HashMap::new();
        for (k, &f) in same_count.iter().enumerate() {
            let family = &families[f];
            let at = ((family.centroid - bounds.min) / step)
                .to_array()
                .map(|x| (x.max(0.0) as usize).min(REGIONS - 1));
            let o = origin(at);
            let Some(levels) = family.turn_bound().and_then(|turn| {
                // Twice the bound, over again for rounding.
                let reach = family.centroid.distance(o);
                Some((
                    level_of(4.0 * turn)?,
                    level_of(family.translation_bound(turn, reach))?,
                ))
            }) else {
                index.everywhere.push(k);
                continue;
            };
            let region = *region_of.entry(at).or_insert_with(|| {
                index.regions.push((o, Vec::new()));
                index.regions.len() - 1
            });
            if !index.regions[region].1.contains(&levels) {
                index.regions[region].1.push(levels);
            }
            for (_, pose, _) in &family.copies[1..] {
                let key = pose_values(pose, o)
                    .map(|(x, scale)| (x / scale_of(scale, levels)).floor() as i64);
                let list = index.cells.entry((region, levels, key)).or_default();
                if list.last() != Some(&k) {
                    list.push(k);
                }
            }
        }
        index
    }

    /// The places after `k` of the families that may move with `anchor`
    /// (the family at `k`), ascending.
    fn candidates(&self, anchor: &PieceFamily, k: usize) -> Vec<usize> {
        let from = self.everywhere.partition_point(|&other| other <= k);
        let mut found: Vec<usize> = self.everywhere[from..].to_vec();
        let first = anchor.copies[1].1;
        let motions = std::iter::once(first)
            .chain(anchor.copies[1..].iter().map(|(_, pose, _)| pose.inverse()));
        for motion in motions {
            for (region, (o, levels)) in self.regions.iter().enumerate() {
                let values = pose_values(&motion, *o);
                for &level in levels {
                    // Each value's cells: those its bound reaches, one or two.
                    let ranges: [(i64, i64); 6] = values.map(|(x, scale)| {
                        let width = scale_of(scale, level);
                        let bound = width / 4.0;
                        (
                            ((x - bound) / width).floor() as i64,
                            ((x + bound) / width).floor() as i64,
                        )
                    });
                    let mut key = ranges.map(|(low, _)| low);
                    'cells: loop {
                        if let Some(list) = self.cells.get(&(region, level, key)) {
                            found.extend(list.iter().copied().filter(|&other| other > k));
                        }
                        // The next key, as an odometer.
                        for d in 0..6 {
                            if key[d] < ranges[d].1 {
                                key[d] += 1;
                                continue 'cells;
                            }
                            key[d] = ranges[d].0;
                        }
                        break;
                    }
                }
            }
        }
        found.sort_unstable();
        found.dedup();
        found
    }
}

/// Which kind of value each of [`pose_values`] is.
#[derive(Clone, Copy)]
enum Scale {
    Turn,
    Shift,
}

/// A pose's values as the index keeps them: three entries of its
/// rotation (which fix it up to a few), and where it moves `origin`.
fn pose_values(pose: &Rigid, origin: Vec3) -> [(f64, Scale); 6] {
    let r = pose.rotation;
    let t = pose.apply(origin);
    [
        (r.x_axis.x, Scale::Turn),
        (r.x_axis.y, Scale::Turn),
        (r.y_axis.z, Scale::Turn),
        (t.x, Scale::Shift),
        (t.y, Scale::Shift),
        (t.z, Scale::Shift),
    ]
}

/// The width of a cell of values of `scale` at `levels`: a rotation's
/// entries lie within [-1, 1], so one cell of 8 holds them all.
fn scale_of(scale: Scale, (turn, shift): Levels) -> f64 {
    match scale {
        Scale::Turn => 2f64.powi(turn.min(1) + 2),
        Scale::Shift => 2f64.powi(shift + 2),
    }
}

/// The level whose cells, 2^(level + 2) wide, are at least four times
/// `bound` (a value's bound reaches two cells about half the time), an
/// even one so that there are few: none for a bound that is no finite
/// positive number.
fn level_of(bound: f64) -> Option<i32> {
    (bound > 0.0 && bound.is_finite()).then(|| {
        let level = (bound.log2().ceil() as i32).clamp(-1000, 1000);
        level + level.rem_euclid(2)
    })
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exec::Threads;
    use crate::mesh::shapes::cuboid;
    use crate::repeats::{MirrorImages, congruent_parts};
    use glam::DQuat;

    /// A box of `size` with its far corner pulled out: no turn or
    /// reflection maps it onto itself.
    fn lopsided(size: Vec3) -> TriMesh {
        cuboid(Vec3::ZERO, size)
            .map_positions(|p| {
                if p.distance(size) < 1e-5 {
                    p + size * Vec3::new(0.4, 0.2, 0.5)
                } else {
                    p
                }
            })
            .unwrap()
    }

    /// A turn that looks random, the same for the same `i`.
    fn turn(i: usize) -> DQuat {
        let mut state = (i as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let mut next = || {
            state ^= state >> 29;
            state = state.wrapping_mul(0xBF58_476D_1CE4_E5B9);
            state ^= state >> 32;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        DQuat::from_xyzw(next(), next(), next(), next()).normalize()
    }

    /// `n` parts of as many sizes, each with one copy turned or mirrored
    /// (reflected in x, its triangles turned over), placed at random
    /// about a grid: every copy of a part is 12 triangles, and the
    /// pieces' copies, mirror images accepted.
    fn pairs(n: usize, mirrored: bool) -> (TriMesh, Vec<Vec<u32>>, Vec<Option<CopyOf>>) {
        let mut scene: Option<TriMesh> = None;
        for k in 0..n {
            let part = lopsided(Vec3::new(1.0 + 0.01 * k as f64, 2.0, 3.0));
            for copy in 0..2 {
                let slot = 2 * k + copy;
                let at = Vec3::new(20.0 * (slot % 64) as f64, 20.0 * (slot / 64) as f64, 0.0);
                let r = turn(slot);
                let mut placed = part.map_positions(|p| r * p + at).unwrap();
                if mirrored && copy == 1 {
                    let positions = placed
                        .positions()
                        .iter()
                        .map(|p| [2.0 * at.x as f32 - p[0], p[1], p[2]])
                        .collect();
                    let triangles = placed
                        .triangles()
                        .iter()
                        .map(|&[a, b, c]| [a, c, b])
                        .collect();
                    placed = TriMesh::new(positions, triangles).unwrap();
                }
                match &mut scene {
                    Some(scene) => scene.append(&placed),
                    None => scene = Some(placed),
                }
            }
        }
        let scene = scene.unwrap();
        let pieces: Vec<Vec<u32>> = (0..2 * n as u32)
            .map(|k| (12 * k..12 * k + 12).collect())
            .collect();
        let lists: Vec<&[u32]> = pieces.iter().map(|p| p.as_slice()).collect();
        let copies = congruent_parts(&scene, &lists, Threads::Serial, MirrorImages::Accepted);
        (scene, pieces, copies)
    }

    #[test]
    fn distinct_parts_each_with_one_copy_are_tried_together_a_linear_number_of_times() {
        for mirrored in [true, false] {
            for n in [250, 500, 1000] {
                let (scene, pieces, copies) = pairs(n, mirrored);
                assert_eq!(copies.iter().flatten().count(), n);
                let (bodies, tried) = bodies_counted(&scene, &pieces, &copies);
                // No two parts move together: each is a body of its own.
                assert_eq!(bodies.len(), n);
                assert!(bodies.iter().all(|b| b.pieces == 1 && b.copies.len() == 2));
                // Trying every pair was n (n - 1) / 2.
                assert!(tried <= n / 4, "{n} parts: {tried} tries");
            }
        }
    }

    #[test]
    fn parts_that_move_together_are_still_found_through_the_index() {
        // Each of 40 bodies is two parts side by side, placed twice: the
        // index finds each part's partner among the others.
        let mut scene: Option<TriMesh> = None;
        for k in 0..40 {
            let first = lopsided(Vec3::new(1.0 + 0.01 * k as f64, 2.0, 3.0));
            let second = lopsided(Vec3::new(1.5, 1.0 + 0.01 * k as f64, 0.5))
                .map_positions(|p| p + Vec3::new(4.0, 0.0, 0.0))
                .unwrap();
            for copy in 0..2 {
                let r = turn(2 * k + copy);
                let at = Vec3::new(30.0 * k as f64, 30.0 * copy as f64, 0.0);
                for part in [&first, &second] {
                    let placed = part.map_positions(|p| r * p + at).unwrap();
                    match &mut scene {
                        Some(scene) => scene.append(&placed),
                        None => scene = Some(placed),
                    }
                }
            }
        }
        let scene = scene.unwrap();
        let pieces: Vec<Vec<u32>> = (0..160u32)
            .map(|k| (12 * k..12 * k + 12).collect())
            .collect();
        let lists: Vec<&[u32]> = pieces.iter().map(|p| p.as_slice()).collect();
        let copies = congruent_parts(&scene, &lists, Threads::Serial, MirrorImages::Refused);
        let (bodies, tried) = bodies_counted(&scene, &pieces, &copies);
        assert_eq!(bodies.len(), 40);
        assert!(bodies.iter().all(|b| b.pieces == 2 && b.copies.len() == 2));
        assert!(tried <= 80, "{tried}");
    }
}
