//! The connected surface behind a triangle soup: welded vertices, edges with
//! the triangles that share them, and each edge's signed dihedral angle,
//! which the curvature descriptor needs.

use crate::exec::Threads;
use crate::math::Vec3;
use crate::mesh::{TriMesh, weld_vertices_on};
use std::ops::ControlFlow;

/// A welded triangle mesh with edge adjacency, laid out for the curvature
/// descriptor's neighbourhood walks: every array a walk reads is flat and
/// indexed by triangle.
#[derive(PartialEq)]
pub struct Surface {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    /// Corner positions per triangle, copied so that a walk reads one place.
    corners: Vec<[Vec3; 3]>,
    areas: Vec<f64>,
    /// Edge ids of each triangle: edge i joins corners i and i + 1.
    triangle_edges: Vec<[u32; 3]>,
    /// Per edge: its end vertices, angle and normal.
    edges: Vec<Edge>,
    /// Triangles across each triangle's edges (CSR).
    neighbour_start: Vec<u32>,
    neighbour_list: Vec<u32>,
    /// The curved edges (nonzero angle) each triangle owns (CSR): an edge
    /// belongs to the first triangle that uses it, so that a walk over
    /// triangles counts it once.
    curved_start: Vec<u32>,
    curved: Vec<CurvedEdge>,
    /// Triangles around each vertex (CSR).
    vertex_start: Vec<u32>,
    vertex_triangles: Vec<u32>,
    /// Small connected groups of triangles, stored contiguously, that a walk
    /// takes whole when they lie inside its ball.
    patches: Patches,
}

/// Connected patches of at most [`Patches::SIZE`] triangles: triangles of
/// patch p are `start[p]..start[p + 1]`, and so are their curved edges in
/// the owner order.
#[derive(Default, PartialEq)]
struct Patches {
    of_triangle: Vec<u32>,
    start: Vec<u32>,
    area: Vec<f64>,
    /// Area-weighted sum of triangle centroids.
    moment: Vec<Vec3>,
    /// Bounding sphere of the corners.
    centre: Vec<Vec3>,
    radius: Vec<f64>,
    /// Triangles next to the patch, outside it (CSR).
    border_start: Vec<u32>,
    border: Vec<u32>,
}

impl Patches {
    const SIZE: usize = 16;
}

/// Where each triangle goes when patches are stored contiguously: built
/// before the per-triangle arrays, so that those are laid out once.
struct PatchLayout {
    /// Old triangle id of each new one, patch after patch.
    order: Vec<u32>,
    new_of_old: Vec<u32>,
    /// Patch p holds new ids `start[p]..start[p + 1]`.
    start: Vec<u32>,
}

impl PatchLayout {
    /// Grows patches breadth-first from each free triangle in the current
    /// (Morton) order, over `neighbours`.
    fn new<'n>(n: usize, neighbours: impl Fn(u32) -> &'n [u32]) -> PatchLayout {
        let mut claimed = vec![false; n];
        let mut order: Vec<u32> = Vec::with_capacity(n);
        let mut start = vec![0u32];
        let mut queue = std::collections::VecDeque::new();
        for seed in 0..n as u32 {
            if claimed[seed as usize] {
                continue;
            }
            let first = order.len();
            claimed[seed as usize] = true;
            queue.clear();
            queue.push_back(seed);
            while let Some(t) = queue.pop_front() {
                order.push(t);
                if order.len() - first == Patches::SIZE {
                    break;
                }
                for &u in neighbours(t) {
                    if !claimed[u as usize] && order.len() - first + queue.len() < Patches::SIZE {
                        claimed[u as usize] = true;
                        queue.push_back(u);
                    }
                }
            }
            // Claimed but not reached (the patch filled up): free again.
            for t in queue.drain(..) {
                claimed[t as usize] = false;
            }
            start.push(order.len() as u32);
        }
        let mut new_of_old = vec![0u32; n];
        for (new, &old) in order.iter().enumerate() {
            new_of_old[old as usize] = new as u32;
        }
        PatchLayout {
            order,
            new_of_old,
            start,
        }
    }

    /// Each patch's bounds, area and border, from `surface`, whose
    /// triangles are already in this layout's order.
    fn summarize(self, surface: &Surface, backend: Threads) -> Patches {
        let count = self.start.len() - 1;
        let mut of_triangle = vec![0u32; surface.triangles.len()];
        for (p, w) in self.start.windows(2).enumerate() {
            of_triangle[w[0] as usize..w[1] as usize].fill(p as u32);
        }
        let start = &self.start;
        let summaries = backend.map(count, |p| {
            let range = start[p] as usize..start[p + 1] as usize;
            let corners = &surface.corners[range.clone()];
            let centre = corners.iter().flatten().fold(Vec3::ZERO, |a, &q| a + q)
                * (1.0 / (3 * corners.len()) as f64);
            let radius = corners
                .iter()
                .flatten()
                .map(|q| q.distance(centre))
                .fold(0.0, f64::max);
            let mut area = 0.0;
            let mut moment = Vec3::ZERO;
            for t in range.clone() {
                let c = surface.corners[t];
                area += surface.areas[t];
                moment += (c[0] + c[1] + c[2]) * (surface.areas[t] / 3.0);
            }
            let mut border: Vec<u32> = range
                .flat_map(|t| surface.neighbours(t as u32).iter().copied())
                .filter(|&u| of_triangle[u as usize] != p as u32)
                .collect();
            border.sort_unstable();
            border.dedup();
            (centre, radius, area, moment, border)
        });
        let mut patches = Patches {
            area: Vec::with_capacity(count),
            moment: Vec::with_capacity(count),
            centre: Vec::with_capacity(count),
            radius: Vec::with_capacity(count),
            border_start: Vec::with_capacity(count + 1),
            border: Vec::new(),
            start: Vec::new(),
            of_triangle: Vec::new(),
        };
        patches.border_start.push(0);
        for (centre, radius, area, moment, border) in summaries {
            patches.centre.push(centre);
            patches.radius.push(radius);
            patches.area.push(area);
            patches.moment.push(moment);
            patches.border.extend_from_slice(&border);
            patches.border_start.push(patches.border.len() as u32);
        }
        patches.start = self.start;
        patches.of_triangle = of_triangle;
        patches
    }
}

/// An edge of the welded mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Edge {
    /// End vertices (lower id first).
    pub ends: [u32; 2],
    /// Signed dihedral angle: the turn between the normals of its two
    /// triangles, positive where the surface is convex. Zero on boundary
    /// edges (one triangle) and non-manifold ones (more than two), where no
    /// single angle exists: they add nothing to the curvature.
    pub angle: f64,
    /// Unit normal of the surface along the edge (the mean of its two
    /// triangles' normals; zero where the angle is).
    pub normal: Vec3,
}

/// What the curvature tensor needs of an edge with a nonzero angle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurvedEdge {
    /// Unit direction (from the lower vertex id to the higher).
    pub direction: Vec3,
    /// Unit normal of the surface along the edge.
    pub normal: Vec3,
    /// Signed dihedral angle.
    pub angle: f64,
    /// Length.
    pub length: f64,
    /// Which edge of its owner triangle it is: edge i joins corners i and
    /// i + 1, so a clip of the triangle tells how much of it is inside.
    pub side: u8,
}

/// Spreads the low 10 bits of `x` to every third bit (Morton interleaving).
fn spread_bits(x: u32) -> u32 {
    let mut x = x & 0x3ff;
    x = (x | x << 16) & 0x0300_00ff;
    x = (x | x << 8) & 0x0300_f00f;
    x = (x | x << 4) & 0x030c_30c3;
    (x | x << 2) & 0x0924_9249
}

/// Turns prefix counts (`start[i + 1]` = count of item i) into CSR offsets
/// and fills the list from `(key, value)` pairs.
fn compressed(count: usize, pairs: &[(u32, u32)]) -> (Vec<u32>, Vec<u32>) {
    let mut start = vec![0u32; count + 1];
    for &(k, _) in pairs {
        start[k as usize + 1] += 1;
    }
    for i in 0..count {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut list = vec![0u32; pairs.len()];
    for &(k, v) in pairs {
        list[fill[k as usize] as usize] = v;
        fill[k as usize] += 1;
    }
    (start, list)
}

/// The edge that a run of half-edges with one key makes: its angle and
/// normal where exactly two triangles share it, none elsewhere.
fn edge_of_run(
    run: &[(u64, u32, bool)],
    triangles: &[[u32; 3]],
    positions: &[Vec3],
    face_normal: impl Fn(usize) -> Vec3,
) -> Edge {
    let ends = [(run[0].0 >> 32) as u32, run[0].0 as u32];
    let (angle, normal) = match run {
        &[(_, h1, forward1), (_, h2, forward2)] if h1 / 3 != h2 / 3 => {
            let (t1, t2) = ((h1 / 3) as usize, (h2 / 3) as usize);
            let (n1, mut n2) = (face_normal(t1), face_normal(t2));
            // Consistently oriented neighbours walk the edge in opposite
            // directions; if not, one is flipped.
            if forward1 == forward2 {
                n2 = -n2;
            }
            let turn = n1.cross(n2).length().atan2(n1.dot(n2));
            // Convex when the far corner of the second triangle lies below
            // the first one's plane.
            let far = triangles[t2]
                .iter()
                .find(|&&v| v != ends[0] && v != ends[1])
                .expect("a triangle has a corner off each edge");
            let below = (positions[*far as usize] - positions[ends[0] as usize]).dot(n1);
            let angle = if below <= 0.0 { turn } else { -turn };
            let mean = n1 * (1.0 / n1.length()) + n2 * (1.0 / n2.length());
            let len = mean.length();
            if len > 0.0 {
                (angle, mean * (1.0 / len))
            } else {
                (0.0, Vec3::ZERO)
            }
        }
        _ => (0.0, Vec3::ZERO),
    };
    Edge {
        ends,
        angle,
        normal,
    }
}

impl Surface {
    /// Welds `mesh` (seams in glTF and OBJ split vertices that are one point
    /// of the surface) and builds its adjacency, with `backend`'s threads
    /// (every backend builds the same surface: sorts have unique keys, and
    /// parallel steps keep their input order).
    pub fn new(mesh: &TriMesh, backend: Threads) -> Surface {
        match Surface::build(mesh, backend, &mut |_| ControlFlow::Continue(())) {
            Some(surface) => surface,
            None => unreachable!("a build that is never stopped ends"),
        }
    }

    /// The steps [`Surface::build`] reports: the weld, the vertex order,
    /// the triangles, the edges, the patches and the per-triangle arrays.
    pub const BUILD_STEPS: usize = 6;

    /// As [`Surface::new`], telling `step` how many of [`Self::BUILD_STEPS`]
    /// are done after each (on a mesh of millions of triangles the build
    /// takes seconds); `None` once `step` returns `Break`.
    pub fn build(
        mesh: &TriMesh,
        backend: Threads,
        step: &mut dyn FnMut(usize) -> ControlFlow<()>,
    ) -> Option<Surface> {
        let mut done = 0;
        let mut next_step = || {
            done += 1;
            step(done).is_continue()
        };
        let (welded, count) = weld_vertices_on(mesh.positions(), backend);
        if !next_step() {
            return None;
        }
        let mut positions = vec![Vec3::ZERO; count];
        for (i, &id) in welded.iter().enumerate() {
            positions[id as usize] = mesh.vertex(i as u32);
        }
        // Vertices and triangles in Morton order: a neighbourhood walk then
        // reads nearby memory, and consecutive candidates share their walks'
        // cache lines (3-5x faster than file order on simplified meshes).
        let bounds = mesh.bounds();
        let size = bounds.extent();
        let (lo, extent) = (bounds.min, size.x.max(size.y).max(size.z).max(1e-30));
        let morton = |p: Vec3| {
            let cell = |x: f64| ((x * 1023.0).clamp(0.0, 1023.0)) as u32;
            let q = (p - lo) * (1.0 / extent);
            spread_bits(cell(q.x)) | spread_bits(cell(q.y)) << 1 | spread_bits(cell(q.z)) << 2
        };
        // Keys computed once (not per comparison); ties keep file order.
        let mut keyed: Vec<(u32, u32)> = backend.map(count, |v| (morton(positions[v]), v as u32));
        backend.sort_unstable(&mut keyed);
        let order: Vec<u32> = keyed.into_iter().map(|(_, v)| v).collect();
        let mut rank = vec![0u32; count];
        for (new, &old) in order.iter().enumerate() {
            rank[old as usize] = new as u32;
        }
        let positions: Vec<Vec3> = backend.map(count, |i| positions[order[i] as usize]);
        let ids: Vec<u32> = backend.map(welded.len(), |i| rank[welded[i] as usize]);
        drop((welded, rank, order));
        if !next_step() {
            return None;
        }
        let file_triangles = mesh.triangles();
        let triangles: Vec<[u32; 3]> = backend.filter_map(file_triangles.len(), |i| {
            let t = file_triangles[i].map(|v| ids[v as usize]);
            (t[0] != t[1] && t[1] != t[2] && t[2] != t[0]).then_some(t)
        });
        drop(ids);
        // By lowest vertex, ties in file order: a counting sort.
        let by_lowest: Vec<(u32, u32)> = backend.map(triangles.len(), |i| {
            let t = triangles[i];
            (t[0].min(t[1]).min(t[2]), i as u32)
        });
        let (_, sorted) = compressed(count, &by_lowest);
        drop(by_lowest);
        let triangles: Vec<[u32; 3]> = backend.map(sorted.len(), |i| triangles[sorted[i] as usize]);
        drop(sorted);
        if !next_step() {
            return None;
        }
        // Half-edges sorted by their undirected key, then by id: equal keys
        // are one edge. Bucketed by the lower end (a counting sort), then
        // each small bucket sorted.
        let ends = |h: usize| (triangles[h / 3][h % 3], triangles[h / 3][(h + 1) % 3]);
        let lower_ends: Vec<(u32, u32)> = backend.map(triangles.len() * 3, |h| {
            let (a, b) = ends(h);
            (a.min(b), h as u32)
        });
        let (_, by_lower) = compressed(count, &lower_ends);
        drop(lower_ends);
        let mut half: Vec<(u64, u32, bool)> = backend.map(by_lower.len(), |i| {
            let h = by_lower[i];
            let (a, b) = ends(h as usize);
            (((a.min(b) as u64) << 32) | a.max(b) as u64, h, a < b)
        });
        drop(by_lower);
        backend.sort_runs_unstable(&mut half, |x, y| x.0 >> 32 == y.0 >> 32);
        let mut run_start: Vec<u32> = backend.filter_map(half.len(), |i| {
            (i == 0 || half[i].0 != half[i - 1].0).then_some(i as u32)
        });
        run_start.push(half.len() as u32);
        let run = |e: usize| &half[run_start[e] as usize..run_start[e + 1] as usize];
        let edge_count = run_start.len() - 1;
        let mut triangle_edges = vec![[0u32; 3]; triangles.len()];
        let mut neighbours: Vec<(u32, u32)> = Vec::with_capacity(half.len());
        for e in 0..edge_count {
            let run = run(e);
            for (i, x) in run.iter().enumerate() {
                triangle_edges[(x.1 / 3) as usize][(x.1 % 3) as usize] = e as u32;
                for y in &run[i + 1..] {
                    let (t, u) = (x.1 / 3, y.1 / 3);
                    if t != u {
                        neighbours.push((t, u));
                        neighbours.push((u, t));
                    }
                }
            }
        }
        let (neighbour_start, neighbour_list) = compressed(triangles.len(), &neighbours);
        drop(neighbours);
        if !next_step() {
            return None;
        }
        let face_normal = |t: usize| {
            let p = triangles[t].map(|v| positions[v as usize]);
            (p[1] - p[0]).cross(p[2] - p[0])
        };
        // The patches (a serial walk) beside the edges' angles: every
        // per-triangle array is then built once, already in patch order.
        let (layout, edges) = backend.join(
            || {
                PatchLayout::new(triangles.len(), |t| {
                    &neighbour_list[neighbour_start[t as usize] as usize
                        ..neighbour_start[t as usize + 1] as usize]
                })
            },
            || {
                backend.map(edge_count, |e| {
                    edge_of_run(run(e), &triangles, &positions, face_normal)
                })
            },
        );
        if !next_step() {
            return None;
        }
        let (order, new_of_old) = (&layout.order, &layout.new_of_old);
        let mut new_start = Vec::with_capacity(triangles.len() + 1);
        new_start.push(0u32);
        let mut new_list = Vec::with_capacity(neighbour_list.len());
        for &old in order {
            let (a, b) = (
                neighbour_start[old as usize] as usize,
                neighbour_start[old as usize + 1] as usize,
            );
            new_list.extend(neighbour_list[a..b].iter().map(|&u| new_of_old[u as usize]));
            new_start.push(new_list.len() as u32);
        }
        drop((neighbour_start, neighbour_list));
        // A curved edge's owner is the triangle of its first half-edge.
        let owned: Vec<(u32, u32)> = backend.filter_map(edge_count, |e| {
            let first = half[run_start[e] as usize].1;
            (edges[e].angle != 0.0).then_some((new_of_old[(first / 3) as usize], first))
        });
        drop((half, run_start));
        let (curved_start, owned_halves) = compressed(triangles.len(), &owned);
        drop(owned);
        let curved = backend.map(owned_halves.len(), |i| {
            let half = owned_halves[i];
            let side = half % 3;
            let edge: Edge = edges[triangle_edges[(half / 3) as usize][side as usize] as usize];
            let (a, b) = (
                positions[edge.ends[0] as usize],
                positions[edge.ends[1] as usize],
            );
            let length = (b - a).length();
            CurvedEdge {
                direction: (b - a) * (1.0 / length),
                normal: edge.normal,
                angle: edge.angle,
                length,
                side: side as u8,
            }
        });
        // Each vertex's triangles in the sorted order, as ids in patch order.
        let at_vertex: Vec<[(u32, u32); 3]> = backend.map(triangles.len(), |ti| {
            triangles[ti].map(|v| (v, new_of_old[ti]))
        });
        let (vertex_start, vertex_triangles) = compressed(count, at_vertex.as_flattened());
        drop(at_vertex);
        let triangles: Vec<[u32; 3]> = backend.map(order.len(), |i| triangles[order[i] as usize]);
        let triangle_edges = backend.map(order.len(), |i| triangle_edges[order[i] as usize]);
        let corners: Vec<[Vec3; 3]> = backend.map(triangles.len(), |i| {
            triangles[i].map(|v| positions[v as usize])
        });
        let areas = backend.map(corners.len(), |i| {
            let p = corners[i];
            0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length()
        });
        let mut surface = Surface {
            positions,
            triangles,
            corners,
            areas,
            triangle_edges,
            edges,
            neighbour_start: new_start,
            neighbour_list: new_list,
            curved_start,
            curved,
            vertex_start,
            vertex_triangles,
            patches: Patches::default(),
        };
        surface.patches = layout.summarize(&surface, backend);
        next_step().then_some(surface)
    }

    /// The patch triangle `t` belongs to.
    pub fn patch_of(&self, t: u32) -> u32 {
        self.patches.of_triangle[t as usize]
    }

    /// The triangles of patch `p` (a contiguous range of ids).
    pub fn patch_triangles(&self, p: u32) -> std::ops::Range<u32> {
        self.patches.start[p as usize]..self.patches.start[p as usize + 1]
    }

    /// Number of patches.
    pub fn patch_count(&self) -> usize {
        self.patches.area.len()
    }

    /// Centre and radius of a sphere around patch `p`.
    pub fn patch_bounds(&self, p: u32) -> (Vec3, f64) {
        (
            self.patches.centre[p as usize],
            self.patches.radius[p as usize],
        )
    }

    /// Area of patch `p` and the area-weighted sum of its triangles'
    /// centroids.
    pub fn patch_area(&self, p: u32) -> (f64, Vec3) {
        (
            self.patches.area[p as usize],
            self.patches.moment[p as usize],
        )
    }

    /// The curved edges the triangles of patch `p` own.
    pub fn patch_curved_edges(&self, p: u32) -> &[CurvedEdge] {
        let r = self.patch_triangles(p);
        let (a, b) = (
            self.curved_start[r.start as usize],
            self.curved_start[r.end as usize],
        );
        &self.curved[a as usize..b as usize]
    }

    /// Triangles outside patch `p` that share an edge with it.
    pub fn patch_border(&self, p: u32) -> &[u32] {
        let (a, b) = (
            self.patches.border_start[p as usize],
            self.patches.border_start[p as usize + 1],
        );
        &self.patches.border[a as usize..b as usize]
    }

    /// Number of welded vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Position of welded vertex `v`.
    pub fn position(&self, v: u32) -> Vec3 {
        self.positions[v as usize]
    }

    /// The triangles, as welded vertex ids.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Corner positions of triangle `t`.
    pub fn corners(&self, t: u32) -> [Vec3; 3] {
        self.corners[t as usize]
    }

    /// Area of triangle `t`.
    pub fn area(&self, t: u32) -> f64 {
        self.areas[t as usize]
    }

    /// Edge ids of triangle `t` (edge i joins corners i and i + 1).
    pub fn triangle_edges(&self, t: u32) -> [u32; 3] {
        self.triangle_edges[t as usize]
    }

    /// Edge `e`.
    pub fn edge(&self, e: u32) -> Edge {
        self.edges[e as usize]
    }

    /// The curved edges triangle `t` owns; every curved edge has exactly one
    /// owner.
    pub fn curved_edges(&self, t: u32) -> &[CurvedEdge] {
        let (a, b) = (
            self.curved_start[t as usize],
            self.curved_start[t as usize + 1],
        );
        &self.curved[a as usize..b as usize]
    }

    /// Unit normal at vertex `v`: the area-weighted mean of its triangles'
    /// normals (zero if they cancel).
    pub fn vertex_normal(&self, v: u32) -> Vec3 {
        let sum = self.triangles_at(v).iter().fold(Vec3::ZERO, |acc, &t| {
            let p = self.corners(t);
            acc + (p[1] - p[0]).cross(p[2] - p[0])
        });
        let len = sum.length();
        if len > 0.0 {
            sum * (1.0 / len)
        } else {
            Vec3::ZERO
        }
    }

    /// The vertices that some triangle uses (files may carry others).
    pub fn used_vertices(&self) -> impl Iterator<Item = u32> + '_ {
        (0..self.vertex_count() as u32).filter(|&v| !self.triangles_at(v).is_empty())
    }

    /// The used vertex nearest to `p` (None without triangles).
    pub fn nearest_vertex(&self, p: Vec3) -> Option<u32> {
        self.used_vertices().min_by(|&a, &b| {
            (self.position(a) - p)
                .length_squared()
                .total_cmp(&(self.position(b) - p).length_squared())
        })
    }

    /// Triangles using vertex `v`.
    pub fn triangles_at(&self, v: u32) -> &[u32] {
        let (a, b) = (
            self.vertex_start[v as usize],
            self.vertex_start[v as usize + 1],
        );
        &self.vertex_triangles[a as usize..b as usize]
    }

    /// Triangles across the edges of triangle `t` (each neighbour once per
    /// shared edge).
    pub fn neighbours(&self, t: u32) -> &[u32] {
        let (a, b) = (
            self.neighbour_start[t as usize],
            self.neighbour_start[t as usize + 1],
        );
        &self.neighbour_list[a as usize..b as usize]
    }
}
/// Bytes per triangle of the welded surface the curvature descriptor walks
/// (corners, areas, edges, adjacency, patches), rounded up from its arrays.
const SURFACE_BYTES_PER_TRIANGLE: u64 = 320;

/// Bytes of the welded surface of a mesh with `triangles`.
pub(crate) fn surface_bytes(triangles: usize) -> u64 {
    SURFACE_BYTES_PER_TRIANGLE.saturating_mul(triangles as u64)
}

#[cfg(test)]
mod tests;
