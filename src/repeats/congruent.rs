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

use std::collections::{BTreeMap, HashMap};
use std::hash::Hasher;

use crate::align::Rigid;
use crate::exec::Threads;
use crate::math::Vec3;
use crate::mesh::{FxHasher, TriMesh, VertexNumbering};
use glam::DMat3;

/// Vertices may differ by this share of the part's radius, plus the
/// rounding of their f32 coordinates: far below a voxel.
const TOLERANCE: f64 = 1e-4;

/// How far a vertex may land from its copy's, for parts of `spread` whose
/// coordinates reach `magnitude`: a share of the part's size plus the
/// rounding of f32 coordinates, far below a voxel.
fn tolerance(spread: f64, magnitude: f64) -> f64 {
    TOLERANCE * spread + 4.0 * f64::from(f32::EPSILON) * magnitude
}

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
    fn new(mesh: &TriMesh, triangles: &[u32]) -> (Local, Vec<u32>) {
        Local::numbered(mesh, triangles, false)
    }

    /// The part numbered with each triangle's corners read in order, or
    /// in reverse (`reversed`: a mirror image whose triangles were turned
    /// over to face outwards again is numbered as its original was).
    fn numbered(mesh: &TriMesh, triangles: &[u32], reversed: bool) -> (Local, Vec<u32>) {
        let mut numbering = VertexNumbering::for_part(mesh, triangles);
        let mut vertices = Vec::new();
        let mut pattern = Vec::with_capacity(3 * triangles.len());
        for &t in triangles {
            let [a, b, c] = mesh.triangles()[t as usize];
            let corners = if reversed { [a, c, b] } else { [a, b, c] };
            for v in corners {
                let (local, first_use) = numbering.number(v);
                if first_use {
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

    /// Bytes its vertices take.
    fn bytes(&self) -> usize {
        std::mem::size_of::<Vec3>() * self.vertices.len()
    }

    /// How far a vertex may land from its copy's.
    fn tolerance(&self, other: &Local) -> f64 {
        tolerance(
            self.spread.max(other.spread),
            self.magnitude.max(other.magnitude),
        )
    }

    /// The rigid motion taking `self` onto `other` vertex by vertex (a
    /// reflection where `mirrored`), and the farthest a vertex lands from
    /// its copy's, if every vertex lands within the tolerance.
    fn motion_to(
        &self,
        other: &Local,
        pair: (usize, usize),
        mirrored: bool,
    ) -> Option<(Rigid, f64)> {
        // A reflection M turns the frame's third axis, a cross product,
        // against M's image of it: M = (x', y', -z') F^T.
        let mut theirs = other.frame(pair);
        if mirrored {
            theirs.z_axis = -theirs.z_axis;
        }
        let rotation = theirs * self.frame(pair).transpose();
        let motion = Rigid {
            rotation,
            translation: other.centroid - rotation * self.centroid,
        };
        let tolerance = self.tolerance(other);
        let mut residual: f64 = 0.0;
        for (&p, &q) in self.vertices.iter().zip(&other.vertices) {
            let off = motion.apply(p).distance(q);
            if off > tolerance {
                return None;
            }
            residual = residual.max(off);
        }
        Some((motion, residual))
    }
}

/// A hash of a part's triangles in local indices: equal lists hash
/// equal, and lists that meet are compared in full, so a fast mix serves
/// where SipHash's resistance to chosen keys buys nothing.
fn pattern_hash(pattern: &[u32]) -> u64 {
    let mut hasher = FxHasher::default();
    hasher.write_usize(pattern.len());
    for &i in pattern {
        hasher.write_u32(i);
    }
    hasher.finish()
}

/// A searched part that later ones may copy. Its numbering is kept while
/// a later part has as many triangles (reading it again for each copy took
/// a third of the step on crowd-rocker), up to [`KEPT_BYTES_PER_TRIANGLE`]; past that,
/// it is read again when a part may be its copy.
struct Original {
    part: usize,
    spread: f64,
    magnitude: f64,
    /// The two vertices that make its frame.
    pair: (usize, usize),
    kept: Option<(Local, Vec<u32>)>,
}

impl Original {
    /// Bytes its kept numbering holds.
    fn kept_bytes(&self) -> usize {
        self.kept
            .as_ref()
            .map_or(0, |(local, pattern)| local.bytes() + 4 * pattern.len())
    }

    /// Whether `local` could be a rigid copy, from its spread alone.
    fn spread_close(&self, local: &Local) -> bool {
        (self.spread - local.spread).abs()
            <= tolerance(
                self.spread.max(local.spread),
                self.magnitude.max(local.magnitude),
            )
    }
}

/// The searched parts that share a triangle list, by spread: a part is
/// compared only with those whose spread could match its own, a range in
/// this order (comparing with every one was quadratic: 100 000 small parts
/// of one topology and as many sizes took minutes).
#[derive(Default)]
struct SamePattern {
    /// Keyed by the spread's bits (spreads are finite and not negative, so
    /// their bits sort as they do) and the part.
    by_spread: BTreeMap<(u64, usize), Original>,
    /// The largest coordinate's magnitude among them.
    magnitude: f64,
}

impl SamePattern {
    /// Those whose spread is close to `local`'s, earliest part first.
    fn close_to(&self, local: &Local) -> Vec<&Original> {
        // The tolerance grows with the larger spread and magnitude: with the
        // largest magnitude here, it bounds the range every close spread
        // lies in.
        let rounding = tolerance(0.0, self.magnitude.max(local.magnitude));
        let low = local.spread * (1.0 - TOLERANCE) - rounding;
        let high = (local.spread + rounding) / (1.0 - TOLERANCE);
        let key = |spread: f64| if spread > 0.0 { spread.to_bits() } else { 0 };
        let mut close: Vec<&Original> = self
            .by_spread
            .range((key(low), 0)..=(key(high), usize::MAX))
            .map(|(_, original)| original)
            .filter(|original| original.spread_close(local))
            .collect();
        close.sort_by_key(|original| original.part);
        close
    }

    fn push(&mut self, original: Original) {
        self.magnitude = self.magnitude.max(original.magnitude);
        self.by_spread
            .insert((original.spread.to_bits(), original.part), original);
    }

    /// Bytes their kept numberings hold.
    fn kept_bytes(&self) -> usize {
        self.by_spread.values().map(Original::kept_bytes).sum()
    }
}

/// The originals' numberings kept at once, at most, per triangle of the
/// mesh: as much again as the mesh's triangle list, so that a scene of
/// many distinct parts does not hold a second copy of itself.
const KEPT_BYTES_PER_TRIANGLE: usize = 12;

/// Parts numbered at once, at most: a bound on the memory the step holds
/// beside the kept originals, and enough to keep the threads busy.
const BATCH_TRIANGLES: usize = 1 << 18;

/// Whether a mirror image of a part is its copy: not for the search (a
/// chiral template's mirror image is not the template), yes for repeated
/// parts (an instanced model places left and right hands by one mesh).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MirrorImages {
    Refused,
    Accepted,
}

/// A part that is a rigid copy of an earlier one, vertex for vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CopyOf {
    /// The earlier part, itself a copy of none.
    pub original: usize,
    /// The motion from the original to this part.
    pub motion: Rigid,
    /// The farthest a vertex of the original, moved, lands from this
    /// part's: float rounding for an exact copy.
    pub residual: f64,
}

impl CopyOf {
    /// Whether the motion is a reflection: a mirror image of the original.
    pub fn mirrored(&self) -> bool {
        self.motion.rotation.determinant() < 0.0
    }
}

/// For each of `parts` (triangle lists of `mesh`), `None` where it copies
/// no earlier part (the search's originals), or what it copies. Parts are
/// numbered with `backend`, and the same copies are found with either.
/// With `mirrors` accepted, a mirror image is a copy too, whichever way
/// its triangles turn.
pub fn congruent_parts(
    mesh: &TriMesh,
    parts: &[&[u32]],
    backend: Threads,
    mirrors: MirrorImages,
) -> Vec<Option<CopyOf>> {
    let kept_limit = KEPT_BYTES_PER_TRIANGLE * mesh.triangles().len();
    congruent_parts_keeping(mesh, parts, backend, mirrors, kept_limit)
}

/// [`congruent_parts`], keeping originals' numberings of at most
/// `kept_limit` bytes at once.
fn congruent_parts_keeping(
    mesh: &TriMesh,
    parts: &[&[u32]],
    backend: Threads,
    mirrors: MirrorImages,
    kept_limit: usize,
) -> Vec<Option<CopyOf>> {
    let handedness: &[bool] = match mirrors {
        MirrorImages::Refused => &[false],
        MirrorImages::Accepted => &[false, true],
    };
    let mut copies = vec![None; parts.len()];
    // A copy has as many triangles as its original: a part alone in its
    // count is neither, and is not numbered at all.
    let mut last_of_count: HashMap<usize, (usize, usize)> = HashMap::new();
    for (i, triangles) in parts.iter().enumerate() {
        let entry = last_of_count.entry(triangles.len()).or_insert((0, i));
        *entry = (entry.0 + 1, i);
    }
    let shared: Vec<usize> = (0..parts.len())
        .filter(|&i| last_of_count[&parts[i].len()].0 > 1)
        .collect();
    // Searched parts by their triangles in local indices (a hash of them:
    // equal lists are checked when the hashes meet).
    let mut originals: HashMap<(usize, usize, u64), SamePattern> = HashMap::new();
    let mut kept_bytes = 0;
    let mut rest = shared.as_slice();
    while !rest.is_empty() {
        let mut taken = 0;
        let mut triangles = 0;
        while taken < rest.len() && (taken == 0 || triangles < BATCH_TRIANGLES) {
            triangles += parts[rest[taken]].len();
            taken += 1;
        }
        let (batch, later) = rest.split_at(taken);
        rest = later;
        let numbered = backend.map_each(batch.len(), |k| Local::new(mesh, parts[batch[k]]));
        for (&i, (local, pattern)) in batch.iter().zip(numbered) {
            let length = pattern.len();
            let key = (length, local.vertices.len(), pattern_hash(&pattern));
            copies[i] = originals
                .get(&key)
                .and_then(|same| original_of(same, &local, &pattern, mesh, parts, handedness));
            if copies[i].is_none() && mirrors == MirrorImages::Accepted {
                // A mirror image turned over matches read backwards, and
                // only as a reflection (a turned copy read so is inside out).
                let (turned_over, reversed) = Local::numbered(mesh, parts[i], true);
                let key = (
                    reversed.len(),
                    turned_over.vertices.len(),
                    pattern_hash(&reversed),
                );
                copies[i] = originals.get(&key).and_then(|same| {
                    original_of(same, &turned_over, &reversed, mesh, parts, &[true])
                });
            }
            let (_, last) = last_of_count[&parts[i].len()];
            if copies[i].is_none()
                && last > i
                && let Some(pair) = local.frame_vertices()
            {
                let bytes = local.bytes() + 4 * pattern.len();
                let keep = kept_bytes + bytes <= kept_limit;
                if keep {
                    kept_bytes += bytes;
                }
                originals.entry(key).or_default().push(Original {
                    part: i,
                    spread: local.spread,
                    magnitude: local.magnitude,
                    pair,
                    kept: keep.then_some((local, pattern)),
                });
            }
            if last == i {
                // No later part can copy one of this many triangles.
                originals.retain(|&(other, ..), kept| {
                    if other == length {
                        kept_bytes -= kept.kept_bytes();
                    }
                    other != length
                });
            }
        }
    }
    copies
}

/// The first of `same_pattern`'s originals near `local` whose numbered
/// triangles equal `pattern`, and the motion onto `local`, a reflection
/// where `handedness` allows it (`true`): an original whose numbering was
/// not kept is numbered again.
fn original_of(
    same_pattern: &SamePattern,
    local: &Local,
    pattern: &[u32],
    mesh: &TriMesh,
    parts: &[&[u32]],
    handedness: &[bool],
) -> Option<CopyOf> {
    same_pattern
        .close_to(local)
        .into_iter()
        .find_map(|original| {
            let read_again;
            let (there, their_pattern) = match &original.kept {
                Some((there, their_pattern)) => (there, their_pattern),
                None => {
                    read_again = Local::new(mesh, parts[original.part]);
                    (&read_again.0, &read_again.1)
                }
            };
            (their_pattern.as_slice() == pattern)
                .then(|| {
                    handedness
                        .iter()
                        .find_map(|&mirrored| there.motion_to(local, original.pair, mirrored))
                })
                .flatten()
                .map(|(motion, residual)| CopyOf {
                    original: original.part,
                    motion,
                    residual,
                })
        })
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
        let copies = congruent_parts(&scene, &lists, Threads::Serial, MirrorImages::Refused);
        let originals: Vec<Option<usize>> = copies.iter().map(|c| c.map(|c| c.original)).collect();
        assert_eq!(originals, [None, Some(0), None, None, None, Some(0)]);
        // The motion takes the first ring onto the second.
        let motion = copies[1].unwrap().motion;
        for p in ring.positions() {
            let p = Vec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            let q = turn * p + Vec3::new(5.0, -3.0, 2.0);
            assert!(motion.apply(p).distance(q) < 1e-5, "{p:?}");
        }
    }

    /// The same scene with its vertices strewn through the list (a part's
    /// vertices far apart, so numbered through a hash map) finds the same
    /// copies, on one thread or several, and with no original kept.
    #[test]
    fn strewn_vertices_and_threads_find_the_same_copies() {
        let ring = torus(Vec3::ZERO, 1.0, 0.3, 16, 8);
        let turn = DQuat::from_axis_angle(Vec3::new(0.3, -1.0, 0.2).normalize(), 0.7);
        let mut scene = ring.clone();
        for k in 1..6 {
            scene.append(&placed(&ring, turn, Vec3::splat(4.0 * k as f64)));
        }
        // A different shape of as many triangles between the copies.
        scene.append(&ring.map_positions(|p| p * 1.5).unwrap());
        // A large part alone in its count, whose vertices the rings' spread
        // among.
        let filler = torus(Vec3::splat(-9.0), 3.0, 1.0, 160, 80);
        scene.append(&filler);
        let n = ring.triangles().len() as u32;
        let parts: Vec<Vec<u32>> = (0..7)
            .map(|k| (k * n..(k + 1) * n).collect())
            .chain([(7 * n..7 * n + filler.triangles().len() as u32).collect()])
            .collect();
        let lists: Vec<&[u32]> = parts.iter().map(|p| p.as_slice()).collect();
        // Vertex v moves to v * step mod count: neighbours land far apart.
        let count = scene.positions().len();
        let step = (count / 2 + 1..).find(|s| gcd(*s, count) == 1).unwrap();
        let moved = |v: u32| ((v as usize * step) % count) as u32;
        let mut positions = vec![[0.0; 3]; count];
        for (v, p) in scene.positions().iter().enumerate() {
            positions[moved(v as u32) as usize] = *p;
        }
        let triangles = scene.triangles().iter().map(|t| t.map(moved)).collect();
        let strewn = TriMesh::new(positions, triangles).unwrap();
        assert!(VertexNumbering::for_part(&strewn, lists[0]).is_strewn());
        let originals = |mesh: &TriMesh, backend| -> Vec<Option<usize>> {
            congruent_parts(mesh, &lists, backend, MirrorImages::Refused)
                .iter()
                .map(|c| c.map(|c| c.original))
                .collect()
        };
        let expected = [
            None,
            Some(0),
            Some(0),
            Some(0),
            Some(0),
            Some(0),
            None,
            None,
        ];
        assert_eq!(originals(&scene, Threads::Serial), expected);
        assert_eq!(originals(&scene, Threads::Parallel), expected);
        assert_eq!(originals(&strewn, Threads::Serial), expected);
        assert_eq!(originals(&strewn, Threads::Parallel), expected);
        // Nothing kept: every original read again, the same copies.
        let read_again: Vec<Option<usize>> =
            congruent_parts_keeping(&scene, &lists, Threads::Parallel, MirrorImages::Refused, 0)
                .iter()
                .map(|c| c.map(|c| c.original))
                .collect();
        assert_eq!(read_again, expected);
    }

    fn gcd(a: usize, b: usize) -> usize {
        if b == 0 { a } else { gcd(b, a % b) }
    }

    #[test]
    fn many_parts_of_one_topology_are_compared_by_spread_alone() {
        // 20 000 boxes of as many sizes, and two moved copies of one of
        // them: every box has the same triangle list, so only the spread
        // tells them apart (comparing with every earlier box was
        // quadratic).
        let n = 20_000;
        // Lengths 0.05% apart, all at the origin: past the tolerance (0.01%
        // of the spread, and the rounding of small coordinates).
        let length = |k: usize| 1.0005f64.powi(k as i32);
        let mut scene = cuboid(Vec3::ZERO, Vec3::new(1.0, 1.0, 1.0));
        for k in 1..n {
            scene.append(&cuboid(Vec3::ZERO, Vec3::new(length(k), 1.0, 0.5)));
        }
        let turn = DQuat::from_axis_angle(Vec3::Z, 0.7);
        let original = cuboid(Vec3::ZERO, Vec3::new(length(500), 1.0, 0.5));
        scene.append(&placed(&original, turn, Vec3::new(-50.0, 0.0, 0.0)));
        scene.append(&placed(
            &original,
            DQuat::IDENTITY,
            Vec3::new(-90.0, 0.0, 0.0),
        ));
        let parts: Vec<Vec<u32>> = (0..n as u32 + 2)
            .map(|k| (12 * k..12 * (k + 1)).collect())
            .collect();
        let lists: Vec<&[u32]> = parts.iter().map(|p| p.as_slice()).collect();
        let start = std::time::Instant::now();
        let copies = congruent_parts(&scene, &lists, Threads::Serial, MirrorImages::Refused);
        let took = start.elapsed();
        let found: Vec<(usize, usize)> = copies
            .iter()
            .enumerate()
            .filter_map(|(i, c)| c.map(|c| (i, c.original)))
            .collect();
        // Box 500 is the two copies' original.
        assert_eq!(found, [(n, 500), (n + 1, 500)]);
        // Generous for a debug build on a slow machine; quadratic took
        // minutes at this size.
        assert!(took.as_secs() < 20, "{took:?}");
    }
}
