//! A copy brings its own vertices.
//!
//! A rigid copy of the template has a vertex wherever the template has one,
//! moved with it: so the scene point where a copy's anchor lies has a
//! vertex of its part as close as the template's anchor has one of the
//! template. A remeshed or simplified copy moves its vertices by about an
//! edge, which the reach allows for. Where a part has no vertex for a long
//! way (the inside of a slab's face, a wall, a duct: most of a building
//! model's surface, and the long faces of machined parts), no copy can be
//! anchored, and its skin voxels there are not candidates. Without this, a
//! 100 m floor slab under 0.3 m fixtures held 42 million candidates and the
//! search was refused for memory.

use std::collections::HashSet;
use std::hash::BuildHasherDefault;

use crate::exec::Threads;
use crate::math::{Aabb, Vec3};
use crate::mesh::{FxHasher, TriMesh};
use crate::voxel::{AtomicGrid, Grid, GridSpec, dilate};

/// Cells of the vertex grid at most, whatever the part's size: a larger
/// part gets larger cells, which keep more candidates, never fewer.
const MAX_CELLS: f64 = (1u64 << 27) as f64;

/// Cells this many times the reach get the exact test by vertex cells too.
const FINE_WHEN_COARSER: f64 = 1.5;

/// Triangles a thread marks at a time.
const MARK_GRAIN: usize = 4096;

/// Which points of a part lie within reach of one of its vertices.
pub(super) struct NearVertices {
    cells: Grid,
    /// Where the cells are coarser than the reach (a part thousands of
    /// times the template's size), the cells of side `reach` that hold a
    /// vertex: a point is near only if one of the 27 around its own does.
    /// A coarse cell kept everything within about a cell of a vertex: a
    /// 100-unit cube's 8 corners kept 470 000 candidates for a 0.05-unit
    /// template, ten times those within reach.
    fine: Option<FineCells>,
    /// Where the cells are about the reach (most parts), the vertices they
    /// hold: a point is near only if one lies within reach. The cells alone
    /// keep points up to 3.5 reaches away: on a building's box-like parts,
    /// two candidates in five were no nearer.
    listed: Option<ListedVertices>,
}

/// Cells listed by vertex at most: the lists take 4 bytes a cell, and the
/// half cells a byte.
const MAX_LISTED_CELLS: usize = 1 << 22;

/// A part's vertices sorted by the cell of side at least `reach` that holds
/// them (each once, however many triangles share it).
struct ListedVertices {
    spec: GridSpec,
    /// Cells of half the side that hold a vertex: any point of such a cell
    /// is within reach of it (its diagonal is 0.87 reach), so on a dense
    /// mesh most points are accepted by one bit.
    halves: Grid,
    /// Where the vertices of each cell start in `points`, x fastest; one
    /// more entry than cells.
    start: Vec<u32>,
    points: Vec<Vec3>,
    reach: f64,
}

impl ListedVertices {
    fn new(mesh: &TriMesh, triangles: &[u32], spec: GridSpec, reach: f64) -> Option<Self> {
        let [nx, ny, nz] = spec.dims;
        let cells = nx.checked_mul(ny)?.checked_mul(nz)?;
        if cells > MAX_LISTED_CELLS {
            return None;
        }
        let corners = mesh.vertices_of(triangles);
        let cell_of = |p: Vec3| {
            let c = spec.voxel_of(p);
            let inside = (0..3).all(|a| c[a] >= 0 && (c[a] as usize) < spec.dims[a]);
            inside.then(|| (c[0] as usize) + nx * (c[1] as usize + ny * c[2] as usize))
        };
        let half_spec = GridSpec {
            origin: spec.origin,
            voxel_size: spec.voxel_size / 2.0,
            dims: spec.dims.map(|d| 2 * d),
        };
        let mut halves = Grid::new(half_spec);
        let mut start = vec![0u32; cells + 1];
        for &v in &corners {
            let p = mesh.vertex(v);
            if let Some(c) = cell_of(p) {
                start[c + 1] += 1;
                let h = half_spec.voxel_of(p).map(|x| x.max(0) as usize);
                if (0..3).all(|a| h[a] < half_spec.dims[a]) {
                    halves.set(h[0], h[1], h[2]);
                }
            }
        }
        for c in 0..cells {
            start[c + 1] += start[c];
        }
        let mut next = start.clone();
        let mut points = vec![Vec3::ZERO; start[cells] as usize];
        for &v in &corners {
            let p = mesh.vertex(v);
            if let Some(c) = cell_of(p) {
                points[next[c] as usize] = p;
                next[c] += 1;
            }
        }
        Some(ListedVertices {
            spec,
            halves,
            start,
            points,
            reach,
        })
    }

    /// Whether a vertex lies within reach of `p`: in the 27 cells around
    /// its own, read as 9 runs of 3 along x.
    fn near(&self, p: Vec3) -> bool {
        let [hx, hy, hz] = self.halves.spec().voxel_of(p);
        if self.halves.get(hx, hy, hz) {
            return true;
        }
        let [nx, ny, nz] = self.spec.dims.map(|d| d as i64);
        let [x, y, z] = self.spec.voxel_of(p);
        let reach2 = self.reach * self.reach;
        let (x0, x1) = ((x - 1).max(0), (x + 1).min(nx - 1));
        if x0 > x1 {
            return false;
        }
        for cz in (z - 1).max(0)..=(z + 1).min(nz - 1) {
            for cy in (y - 1).max(0)..=(y + 1).min(ny - 1) {
                let row = ((cz * ny + cy) * nx) as usize;
                let (a, b) = (
                    self.start[row + x0 as usize] as usize,
                    self.start[row + x1 as usize + 1] as usize,
                );
                if self.points[a..b]
                    .iter()
                    .any(|q| q.distance_squared(p) <= reach2)
                {
                    return true;
                }
            }
        }
        false
    }

    fn bytes(&self) -> u64 {
        (4 * self.start.len() + std::mem::size_of::<Vec3>() * self.points.len()) as u64
            + 8 * self.halves.words().len() as u64
    }
}

/// Cells of side `reach` that hold a vertex, hashed: as many as the part's
/// vertices at most, whatever its size.
struct FineCells {
    origin: Vec3,
    side: f64,
    held: HashSet<[i64; 3], BuildHasherDefault<FxHasher>>,
}

impl FineCells {
    fn new(mesh: &TriMesh, triangles: &[u32], origin: Vec3, side: f64) -> FineCells {
        let mut held = HashSet::default();
        for &t in triangles {
            for p in mesh.corners(t as usize) {
                held.insert(Self::cell(origin, side, p));
            }
        }
        FineCells { origin, side, held }
    }

    fn cell(origin: Vec3, side: f64, p: Vec3) -> [i64; 3] {
        ((p - origin) / side).floor().to_array().map(|c| c as i64)
    }

    /// Whether a vertex may lie within `side` of `p`: in its cell or a
    /// neighbour (a distance of at most `side` moves a cell index by one).
    fn near(&self, p: Vec3) -> bool {
        let [x, y, z] = Self::cell(self.origin, self.side, p);
        (z - 1..=z + 1).any(|z| {
            (y - 1..=y + 1).any(|y| (x - 1..=x + 1).any(|x| self.held.contains(&[x, y, z])))
        })
    }

    fn bytes(&self) -> u64 {
        // A key and the table's control byte and slack, about.
        (self.held.capacity() * (std::mem::size_of::<[i64; 3]>() + 8)) as u64
    }
}

impl NearVertices {
    /// Cells of side `reach` over `bounds` (a part's box), each set where a
    /// corner of `triangles` of `mesh` lies in it or in a neighbour: every
    /// point within `reach` of a vertex is in a set cell.
    pub(super) fn new(
        mesh: &TriMesh,
        triangles: &[u32],
        bounds: Aabb,
        reach: f64,
        backend: Threads,
    ) -> Option<NearVertices> {
        let e = bounds.extent();
        // Padding aside, the cells over the box: a side of `reach`, or
        // larger where the box would need more than MAX_CELLS of them, or
        // more than a grid's side holds.
        let volume = (e.x + reach) * (e.y + reach) * (e.z + reach);
        let longest = e.x.max(e.y).max(e.z);
        let cell = reach
            .max((volume / MAX_CELLS).cbrt())
            .max(longest / 60_000.0);
        if !(cell.is_finite() && cell > 0.0) {
            return None;
        }
        let spec = GridSpec::around(bounds, cell).ok()?;
        // Marked from all threads: a part may have a million corners.
        let marked = AtomicGrid::new(spec);
        backend.for_each_range(triangles.len(), MARK_GRAIN, |range| {
            for &t in &triangles[range] {
                for p in mesh.corners(t as usize) {
                    let [x, y, z] = spec.voxel_of(p);
                    if x >= 0 && y >= 0 && z >= 0 {
                        let [x, y, z] = [x, y, z].map(|c| c as usize);
                        if x < spec.dims[0] && y < spec.dims[1] && z < spec.dims[2] {
                            marked.set(x, y, z);
                        }
                    }
                }
            }
        });
        let marked = marked.into_grid();
        let coarse = cell > FINE_WHEN_COARSER * reach;
        let fine = coarse.then(|| FineCells::new(mesh, triangles, spec.origin, reach));
        let listed = if coarse {
            None
        } else {
            ListedVertices::new(mesh, triangles, spec, reach)
        };
        Some(NearVertices {
            cells: dilate(&marked, backend),
            fine,
            listed,
        })
    }

    /// Whether some point of `bounds` may lie within reach of a vertex.
    pub(super) fn any_in(&self, bounds: &Aabb) -> bool {
        let spec = self.cells.spec();
        let (lo, hi) = (spec.voxel_of(bounds.min), spec.voxel_of(bounds.max));
        let clamp = |c: i64, a: usize| c.clamp(0, spec.dims[a] as i64 - 1);
        if (0..3).any(|a| hi[a] < 0 || lo[a] >= spec.dims[a] as i64) {
            return false;
        }
        let (lo, hi) = (
            [0, 1, 2].map(|a| clamp(lo[a], a)),
            [0, 1, 2].map(|a| clamp(hi[a], a)),
        );
        (lo[2]..=hi[2])
            .any(|z| (lo[1]..=hi[1]).any(|y| (lo[0]..=hi[0]).any(|x| self.cells.get(x, y, z))))
    }

    /// How far from every vertex a point that [`NearVertices::near`]
    /// accepts may lie: across its cell and a neighbour's.
    pub(super) fn farthest(&self) -> f64 {
        2.0 * 3f64.sqrt() * self.cells.spec().voxel_size
    }

    /// Bytes its cells take.
    pub(super) fn bytes(&self) -> u64 {
        8 * self.cells.words().len() as u64
            + self.fine.as_ref().map_or(0, FineCells::bytes)
            + self.listed.as_ref().map_or(0, ListedVertices::bytes)
    }

    /// The set cells' boxes: where the points [`NearVertices::any_in`]
    /// accepts lie.
    pub(super) fn cells(&self) -> impl Iterator<Item = Aabb> + '_ {
        let spec = *self.cells.spec();
        self.cells.iter_ones().map(move |[x, y, z]| {
            let min =
                spec.origin + Vec3::new(f64::from(x), f64::from(y), f64::from(z)) * spec.voxel_size;
            Aabb {
                min,
                max: min + Vec3::splat(spec.voxel_size),
            }
        })
    }

    /// Whether `p` may lie within reach of a vertex (a set cell); points
    /// outside the part's box are never near.
    pub(super) fn near(&self, p: Vec3) -> bool {
        let [x, y, z] = self.cells.spec().voxel_of(p);
        self.cells.get(x, y, z)
            && self.fine.as_ref().is_none_or(|fine| fine.near(p))
            && self.listed.as_ref().is_none_or(|listed| listed.near(p))
    }
}

/// How far from a vertex a copy's anchor can lie: twice the template's own
/// distance (`template_gap`, the largest over its anchors), plus the way
/// from a copy's anchor to the candidate standing for it (a cube of
/// `spacing` voxels of `voxel`, and a voxel of rounding), plus half the
/// first radius `r1` for vertices that remeshing moved.
pub(super) fn reach(template_gap: f64, spacing: u32, voxel: f64, r1: f64) -> f64 {
    2.0 * template_gap + (3f64.sqrt() * f64::from(spacing) + 2.0) * voxel + 0.5 * r1
}

/// The largest, over `anchors`, of the distance to the nearest of `points`.
pub(super) fn template_gap(anchors: &[Vec3], points: impl Iterator<Item = Vec3>) -> f64 {
    let mut nearest = vec![f64::INFINITY; anchors.len()];
    for p in points {
        for (n, a) in nearest.iter_mut().zip(anchors) {
            *n = n.min(p.distance(*a));
        }
    }
    nearest.into_iter().fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::cuboid;

    #[test]
    fn the_inside_of_a_large_face_is_far_from_every_vertex() {
        // A slab of two triangles a face: vertices only at its corners.
        let slab = cuboid(Vec3::new(-10.0, -10.0, -0.2), Vec3::ZERO);
        let triangles: Vec<u32> = (0..slab.triangles().len() as u32).collect();
        let near = NearVertices::new(&slab, &triangles, slab.bounds(), 0.5, Threads::Serial)
            .expect("cells");
        // Within reach of a corner: near. The middle of the top face, and
        // anywhere beyond a few cells of every corner: not.
        assert!(near.near(Vec3::new(-9.7, -9.8, 0.0)));
        assert!(near.near(Vec3::new(-0.3, -0.1, -0.1)));
        assert!(!near.near(Vec3::new(-5.0, -5.0, 0.0)));
        assert!(!near.near(Vec3::new(-2.0, -8.0, 0.0)));
        // Every point within reach of a vertex is near, whatever the cell
        // it falls in.
        for corner in slab.positions() {
            let c = Vec3::new(corner[0] as f64, corner[1] as f64, corner[2] as f64);
            for d in [
                Vec3::new(0.49, 0.0, 0.0),
                Vec3::new(0.0, -0.49, 0.0),
                Vec3::new(0.28, 0.28, 0.28),
                Vec3::new(-0.2, 0.3, -0.3),
            ] {
                let p = c + d;
                assert!(near.near(p), "{p:?} near {c:?}");
            }
        }
    }

    #[test]
    fn a_point_is_near_exactly_when_a_vertex_lies_within_reach() {
        // Box-like parts of a few cells: the cells around a corner reach
        // 3.5 times as far as the reach, the listed vertices no further.
        let part = cuboid(Vec3::new(-1.0, -0.4, -0.7), Vec3::new(1.3, 0.5, 0.2));
        let triangles: Vec<u32> = (0..part.triangles().len() as u32).collect();
        let reach = 0.31;
        let near = NearVertices::new(&part, &triangles, part.bounds(), reach, Threads::Serial)
            .expect("cells");
        assert!(near.listed.is_some());
        let corners: Vec<Vec3> = part
            .positions()
            .iter()
            .map(|c| Vec3::new(c[0] as f64, c[1] as f64, c[2] as f64))
            .collect();
        let mut rnd = crate::math::unit_rng(5);
        let (mut inside, mut outside) = (0, 0);
        for _ in 0..20_000 {
            let p = Vec3::new(-1.1 + 2.5 * rnd(), -0.5 + 1.1 * rnd(), -0.8 + 1.1 * rnd());
            let nearest = corners
                .iter()
                .map(|c| c.distance(p))
                .fold(f64::INFINITY, f64::min);
            // Rounding aside.
            if (nearest - reach).abs() > 1e-9 {
                assert_eq!(near.near(p), nearest < reach, "{p:?} at {nearest}");
                if nearest < reach {
                    inside += 1;
                } else {
                    outside += 1;
                }
            }
        }
        assert!(inside > 100 && outside > 100, "{inside} {outside}");
    }

    #[test]
    fn in_a_part_far_larger_than_the_reach_only_points_within_reach_are_near() {
        // A 100-unit cube and a reach of 0.05: the bit cells are about 0.2
        // wide, and the vertex cells take over.
        let cube = cuboid(Vec3::splat(-50.0), Vec3::splat(50.0));
        let triangles: Vec<u32> = (0..cube.triangles().len() as u32).collect();
        let reach = 0.05;
        let near = NearVertices::new(&cube, &triangles, cube.bounds(), reach, Threads::Serial)
            .expect("cells");
        assert!(near.fine.is_some());
        let corner = Vec3::splat(50.0);
        for d in [
            Vec3::new(-0.049, 0.0, 0.0),
            Vec3::new(0.0, -0.03, -0.03),
            Vec3::splat(-0.028),
        ] {
            assert!(near.near(corner + d), "{d:?} from a corner");
        }
        // Within a coarse cell of the corner, but past twice the reach.
        for d in [Vec3::new(-0.11, 0.0, 0.0), Vec3::new(0.0, -0.15, -0.05)] {
            assert!(!near.near(corner + d), "{d:?} from a corner");
        }
        // Windows are listed by the coarse cells: a superset.
        assert!(near.any_in(&Aabb {
            min: corner - Vec3::splat(0.01),
            max: corner,
        }));
    }

    #[test]
    fn the_gap_is_the_worst_anchors_nearest_vertex() {
        let anchors = [Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0)];
        let points = [Vec3::new(0.0, 1.0, 0.0), Vec3::new(10.0, 0.0, 3.0)];
        assert_eq!(template_gap(&anchors, points.into_iter()), 3.0);
    }
}
