//! Solid fill that survives open meshes and overlapping shells.
//!
//! Real scenes are unions of many meshes, often not watertight: the bunny's
//! base has holes, the teapot is four interpenetrating shells, figures are sunk
//! into a ground slab. A single parity count over the whole scene breaks on
//! every one of these. So:
//!
//! 1. The mesh is split into shells (connected components of welded vertices),
//!    and each shell is filled on its own; the scene's solid is their union, so
//!    overlapping shells and objects never cancel each other out.
//! 2. Within a shell, a voxel's centre is tested by parity along three rays,
//!    one per axis (the columns of voxel centres). A column that crosses the
//!    shell an odd number of times passed through a hole: it abstains.
//! 3. The voxel is solid when more valid columns call it inside than outside
//!    (a majority of three, or a unanimous one or two when others abstain).
//!
//! A closed shell (every edge shared by an even number of its triangles) has
//! no holes for a column to pass through: the three rays agree at every
//! voxel centre not on the surface itself (and those voxels are surface
//! voxels anyway), so one axis is enough, the one that meets the fewest
//! triangles.
//!
//! A hole in the bunny's base spoils only the vertical columns through it; the
//! two horizontal ones still agree. Crossings are counted with a watertight
//! rasterization rule (shared edges are owned by exactly one triangle, with
//! edge functions evaluated in a canonical orientation) so a closed shell
//! never produces a spurious odd column.
//!
//! Each axis is done with bit-parallel word operations: a crossing toggles one
//! bit where "inside" starts, and a prefix XOR along the axis turns toggles
//! into parity (64 columns at a time along y and z).

use super::grid::{AtomicGrid, Grid, GridSpec};
use crate::exec::Backend;
use crate::math::{Vec3, ceil, floor};
use crate::mesh::{TriMesh, weld_vertices};

/// The voxels whose centre lies inside the mesh's solid (the surface itself
/// is not included; see [`super::voxelize`]).
pub fn fill_solid(mesh: &TriMesh, spec: &GridSpec, backend: Backend) -> Grid {
    let shells = shells(mesh, backend);
    let out = AtomicGrid::new(*spec);
    backend.for_each_range(shells.len(), 1, |range| {
        for s in range {
            fill_shell(mesh, &shells[s], spec, &out, backend);
        }
    });
    out.into_grid()
}

/// The triangles of one edge-connected component, and whether it is closed.
pub(crate) struct Shell {
    /// Triangle indices into the mesh.
    pub triangles: Vec<u32>,
    /// Every edge is shared by an even number of the shell's triangles.
    pub closed: bool,
}

/// Triangle indices of each shell.
///
/// Triangles belong to one shell when they share an edge (after welding, so
/// that texture seams do not cut a surface apart). Sharing a single vertex is
/// not enough: two objects that merely touch, or interpenetrate with a few
/// coincident vertices, must be filled separately and united, never merged
/// into one parity count. Shells never cross parts (separately placed
/// meshes are separate objects), and instances of one mesh share its
/// connectivity, computed once. Distinct parts are split into shells in
/// parallel: that was the serial half of filling a scene.
pub(crate) fn shells(mesh: &TriMesh, backend: Backend) -> Vec<Shell> {
    let parts = mesh.parts();
    let local_tris: Vec<Vec<[u32; 3]>> = parts
        .iter()
        .map(|part| {
            let first = part.first_triangle as usize;
            mesh.triangles()[first..first + part.triangle_count as usize]
                .iter()
                .map(|t| t.map(|i| i - part.first_vertex))
                .collect()
        })
        .collect();
    // Each part's computing twin: the first part with the same source and
    // the same triangles (a degenerate triangle dropped in one instance only
    // would differ), itself when there is none.
    let mut twin: Vec<usize> = Vec::with_capacity(parts.len());
    for i in 0..parts.len() {
        let found = (0..i).find(|&j| {
            twin[j] == j && parts[j].source == parts[i].source && local_tris[j] == local_tris[i]
        });
        twin.push(found.unwrap_or(i));
    }
    let distinct: Vec<usize> = (0..parts.len()).filter(|&i| twin[i] == i).collect();
    let distinct_shells = backend.map_each(distinct.len(), |k| {
        let part = &parts[distinct[k]];
        let vertices = part.first_vertex as usize..(part.first_vertex + part.vertex_count) as usize;
        part_shells(&mesh.positions()[vertices], &local_tris[distinct[k]])
    });
    let mut shells = Vec::new();
    for (i, part) in parts.iter().enumerate() {
        let k = distinct.binary_search(&twin[i]).expect("a twin computes");
        let first = part.first_triangle;
        shells.extend(distinct_shells[k].iter().map(|s| Shell {
            triangles: s.triangles.iter().map(|&t| t + first).collect(),
            closed: s.closed,
        }));
    }
    shells
}

/// Shells of one part, as triangle indices within it.
fn part_shells(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Vec<Shell> {
    let (ids, n) = weld_vertices(positions);
    let tris: Vec<[u32; 3]> = triangles
        .iter()
        .map(|t| t.map(|i| ids[i as usize]))
        .collect();
    // Triangles around each welded vertex (counting sort, no hashing).
    let mut start = vec![0u32; n + 1];
    for t in &tris {
        for &v in t {
            start[v as usize + 1] += 1;
        }
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    // Each incident triangle with its two other corners, so that finding the
    // triangle across an edge reads one vertex's list and nothing else.
    let mut fill = start.clone();
    let mut around = vec![(0u32, 0u32, 0u32); tris.len() * 3];
    for (ti, t) in tris.iter().enumerate() {
        for k in 0..3 {
            let v = t[k] as usize;
            around[fill[v] as usize] = (ti as u32, t[(k + 1) % 3], t[(k + 2) % 3]);
            fill[v] += 1;
        }
    }
    let mut parent: Vec<u32> = (0..tris.len() as u32).collect();
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            let p = parent[x as usize];
            parent[x as usize] = parent[p as usize];
            x = p;
        }
        x
    }
    // Triangles with an edge that an odd number of triangles use: they open
    // their shell. The edge v-w is used by every triangle around v that has
    // w as one of its other corners: one, plus those that share w with it.
    let mut open_edge_triangles = Vec::new();
    let mut sharing: Vec<[u32; 2]> = Vec::new();
    for v in 0..n {
        let list = &around[start[v] as usize..start[v + 1] as usize];
        sharing.clear();
        sharing.resize(list.len(), [0, 0]);
        // Two triangles around v share an edge when they share another corner.
        for (i, &(t1, a1, b1)) in list.iter().enumerate() {
            for (j, &(t2, a2, b2)) in list.iter().enumerate().skip(i + 1) {
                let (a1_shared, b1_shared) = (a1 == a2 || a1 == b2, b1 == a2 || b1 == b2);
                if a1_shared || b1_shared {
                    sharing[i][0] += a1_shared as u32;
                    sharing[i][1] += b1_shared as u32;
                    sharing[j][0] += (a2 == a1 || a2 == b1) as u32;
                    sharing[j][1] += (b2 == a1 || b2 == b1) as u32;
                    let (r1, r2) = (find(&mut parent, t1), find(&mut parent, t2));
                    if r1 != r2 {
                        parent[r1.max(r2) as usize] = r1.min(r2);
                    }
                }
            }
        }
        // Each edge once, from its lower end.
        for (&(t, a, b), shared) in list.iter().zip(&sharing) {
            if (a as usize > v && shared[0] % 2 == 0) || (b as usize > v && shared[1] % 2 == 0) {
                open_edge_triangles.push(t);
            }
        }
    }
    let mut shell_of_root = vec![u32::MAX; tris.len()];
    let mut shells: Vec<Shell> = Vec::new();
    for ti in 0..tris.len() as u32 {
        let root = find(&mut parent, ti) as usize;
        if shell_of_root[root] == u32::MAX {
            shell_of_root[root] = shells.len() as u32;
            shells.push(Shell {
                triangles: Vec::new(),
                closed: true,
            });
        }
        shells[shell_of_root[root] as usize].triangles.push(ti);
    }
    for t in open_edge_triangles {
        let root = find(&mut parent, t) as usize;
        shells[shell_of_root[root] as usize].closed = false;
    }
    shells
}

/// A shell's bounding box in voxels, padded by one so that every column
/// starts before the first crossing and ends after the last.
struct Block {
    lo: [usize; 3],
    hi: [usize; 3],
    first_word: usize,
    words: usize,
    ny: usize,
    nz: usize,
}

impl Block {
    fn index(&self, x: usize, y: usize, z: usize) -> (usize, u64) {
        let row = (z - self.lo[2]) * self.ny + (y - self.lo[1]);
        (row * self.words + (x >> 6) - self.first_word, 1 << (x & 63))
    }

    fn toggle(&self, bits: &mut [u64], v: [usize; 3]) {
        let (i, bit) = self.index(v[0], v[1], v[2]);
        bits[i] ^= bit;
    }

    fn len(&self) -> usize {
        self.words * self.ny * self.nz
    }
}

fn fill_shell(mesh: &TriMesh, shell: &Shell, spec: &GridSpec, out: &AtomicGrid, backend: Backend) {
    let corners: Vec<[Vec3; 3]> = shell
        .triangles
        .iter()
        .map(|&t| mesh.corners(t as usize).map(|p| spec.to_grid(p)))
        .collect();
    let (mut lo_p, mut hi_p) = (corners[0][0], corners[0][0]);
    for c in corners.iter().flatten() {
        lo_p = lo_p.min(*c);
        hi_p = hi_p.max(*c);
    }
    let dims = spec.dims;
    let lo = [0, 1, 2].map(|a| ((floor(lo_p[a]) - 1.0).max(0.0) as usize).min(dims[a] - 1));
    let hi = [0, 1, 2].map(|a| ((floor(hi_p[a]) + 1.0).max(0.0) as usize).min(dims[a] - 1));
    let block = Block {
        lo,
        hi,
        first_word: lo[0] >> 6,
        words: (hi[0] >> 6) - (lo[0] >> 6) + 1,
        ny: hi[1] - lo[1] + 1,
        nz: hi[2] - lo[2] + 1,
    };
    if shell.closed {
        // Along the axis that crosses the least projected area.
        let mut area = [0.0f64; 3];
        for [a, b, c] in &corners {
            let n = (*b - *a).cross(*c - *a);
            area = [0, 1, 2].map(|k| area[k] + n[k].abs());
        }
        let axis = (0..3)
            .min_by(|&i, &j| area[i].total_cmp(&area[j]))
            .unwrap_or(2);
        let inside = parity_along(axis, &corners, &block);
        for z in 0..block.nz {
            for y in 0..block.ny {
                let row = (z * block.ny + y) * block.words;
                for (k, &word) in inside[row..row + block.words].iter().enumerate() {
                    out.or_word(block.first_word + k, block.lo[1] + y, block.lo[2] + z, word);
                }
            }
        }
        return;
    }
    // parity[a]: parity along axis a. The three axes are independent: a
    // large shell runs them side by side.
    let mut parity = vec![Vec::new(); 3];
    let axes = if corners.len() >= 4096 {
        backend
    } else {
        Backend::Serial
    };
    axes.for_each_row(&mut parity, 1, |axis, slot| {
        slot[0] = parity_along(axis, &corners, &block);
    });
    vote(&parity, &block, out);
}

/// The parity of the crossings along `axis` of every column of `block`:
/// a crossing toggles the voxel where "inside" starts, and a prefix XOR
/// along the axis turns the toggles into parity.
fn parity_along(axis: usize, corners: &[[Vec3; 3]], block: &Block) -> Vec<u64> {
    let mut bits = vec![0u64; block.len()];
    for tri in corners {
        match axis {
            0 => for_each_crossing::<0>(tri, block, |v| block.toggle(&mut bits, v)),
            1 => for_each_crossing::<1>(tri, block, |v| block.toggle(&mut bits, v)),
            _ => for_each_crossing::<2>(tri, block, |v| block.toggle(&mut bits, v)),
        }
    }
    match axis {
        0 => prefix_xor_x(&mut bits, block),
        1 => prefix_xor_rows(&mut bits, block.words, block.ny, block.nz, 1),
        _ => prefix_xor_rows(&mut bits, block.words, block.ny, block.nz, block.ny),
    }
    bits
}

/// Calls `toggle` with the voxel where each crossing of the triangle by a
/// column along `AXIS` flips the column's state: the first voxel whose centre
/// lies past the crossing.
fn for_each_crossing<const AXIS: usize>(
    tri: &[Vec3; 3],
    block: &Block,
    mut toggle: impl FnMut([usize; 3]),
) {
    let (u, v) = ((AXIS + 1) % 3, (AXIS + 2) % 3);
    // Column (cu, cv) runs through (cu + 0.5, cv + 0.5); most triangles of a
    // fine mesh contain no column centre at all, so find that out first.
    let min_u = tri[0][u].min(tri[1][u]).min(tri[2][u]);
    let max_u = tri[0][u].max(tri[1][u]).max(tri[2][u]);
    let (u0, u1) = (
        ceil(min_u - 0.5).max(block.lo[u] as f64),
        floor(max_u - 0.5).min(block.hi[u] as f64),
    );
    if u1 < u0 {
        return;
    }
    let min_v = tri[0][v].min(tri[1][v]).min(tri[2][v]);
    let max_v = tri[0][v].max(tri[1][v]).max(tri[2][v]);
    let (v0, v1) = (
        ceil(min_v - 0.5).max(block.lo[v] as f64),
        floor(max_v - 0.5).min(block.hi[v] as f64),
    );
    if v1 < v0 {
        return;
    }
    let mut p = tri.map(|q| [q[u], q[v]]);
    let mut depth = tri.map(|q| q[AXIS]);
    let area2 = edge(p[0], p[1], p[2]);
    if area2 == 0.0 {
        return; // parallel to the axis: no column crosses it
    }
    if area2 < 0.0 {
        p.swap(1, 2);
        depth.swap(1, 2);
    }
    let area2 = area2.abs();
    let mut at = [0usize; 3];
    for cv in v0 as usize..=v1 as usize {
        for cu in u0 as usize..=u1 as usize {
            let c = [cu as f64 + 0.5, cv as f64 + 0.5];
            let w0 = owned_edge(p[1], p[2], c);
            let w1 = owned_edge(p[2], p[0], c);
            let w2 = owned_edge(p[0], p[1], c);
            let (Some(w0), Some(w1), Some(w2)) = (w0, w1, w2) else {
                continue;
            };
            let d = (w0 * depth[0] + w1 * depth[1] + w2 * depth[2]) / area2;
            let t = floor(d + 0.5).clamp(block.lo[AXIS] as f64, block.hi[AXIS] as f64);
            at[AXIS] = t as usize;
            at[u] = cu;
            at[v] = cv;
            toggle(at);
        }
    }
}

/// Twice the signed area of (a, b, c).
fn edge(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// The edge function of the directed edge a->b at `c`, when `c` is on its
/// inner side or on the edge and the edge owns its points; `None` otherwise.
///
/// The value is computed from the lexicographically smaller endpoint, so the
/// two triangles sharing an edge see exactly opposite values, and exactly one
/// of the two directions owns points on the edge: together, a point is inside
/// exactly one triangle of a closed fan.
fn owned_edge(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> Option<f64> {
    let e = if (a[0], a[1]) < (b[0], b[1]) {
        edge(a, b, c)
    } else {
        -edge(b, a, c)
    };
    let owns = (b[1] < a[1]) || (b[1] == a[1] && b[0] > a[0]);
    (e > 0.0 || (e == 0.0 && owns)).then_some(e)
}

/// Prefix XOR along x within each row: bit x becomes the XOR of bits 0..=x.
fn prefix_xor_x(bits: &mut [u64], block: &Block) {
    for row in bits.chunks_exact_mut(block.words) {
        let mut carry = 0u64;
        for w in row {
            let mut x = *w;
            x ^= x << 1;
            x ^= x << 2;
            x ^= x << 4;
            x ^= x << 8;
            x ^= x << 16;
            x ^= x << 32;
            x ^= carry;
            *w = x;
            carry = if x >> 63 == 1 { !0 } else { 0 };
        }
    }
}

/// Prefix XOR along y (`step` = 1 row) or z (`step` = ny rows), 64 columns per
/// word operation.
fn prefix_xor_rows(bits: &mut [u64], words: usize, ny: usize, nz: usize, step: usize) {
    let rows = ny * nz;
    for r in 0..rows {
        let along = if step == 1 { r % ny } else { r / ny };
        if along == 0 {
            continue;
        }
        let (prev, cur) = bits.split_at_mut(r * words);
        let prev = &prev[(r - step) * words..(r - step + 1) * words];
        for (c, p) in cur[..words].iter_mut().zip(prev) {
            *c ^= p;
        }
    }
}

/// Combines the three parities with their columns' validity and ORs the
/// solid voxels into `out`.
fn vote(parity: &[Vec<u64>], b: &Block, out: &AtomicGrid) {
    let w = b.words;
    let last_x_word = (b.hi[0] >> 6) - b.first_word;
    let last_x_bit = b.hi[0] & 63;
    for z in 0..b.nz {
        for y in 0..b.ny {
            let row = (z * b.ny + y) * w;
            // A column whose state is still "inside" at its far padding voxel
            // crossed the shell an odd number of times.
            let x_valid = if (parity[0][row + last_x_word] >> last_x_bit) & 1 == 0 {
                !0
            } else {
                0
            };
            let y_end = (z * b.ny + b.ny - 1) * w;
            let z_end = ((b.nz - 1) * b.ny + y) * w;
            for k in 0..w {
                let (px, py, pz) = (parity[0][row + k], parity[1][row + k], parity[2][row + k]);
                let y_valid = !parity[1][y_end + k];
                let z_valid = !parity[2][z_end + k];
                let (ix, iy, iz) = (px & x_valid, py & y_valid, pz & z_valid);
                let (ox, oy, oz) = (!px & x_valid, !py & y_valid, !pz & z_valid);
                let majority = (ix & iy) | (ix & iz) | (iy & iz);
                let uncontested = (ix | iy | iz) & !(ox | oy | oz);
                out.or_word(
                    b.first_word + k,
                    b.lo[1] + y,
                    b.lo[2] + z,
                    majority | uncontested,
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::{cuboid, torus, uv_sphere};

    /// The three-axis vote, which needs no closed shell: the oracle for the
    /// one-axis fill of closed ones.
    fn voted(mesh: &TriMesh, spec: &GridSpec) -> Grid {
        let out = AtomicGrid::new(*spec);
        for shell in shells(mesh, Backend::Serial) {
            let open = Shell {
                closed: false,
                ..shell
            };
            fill_shell(mesh, &open, spec, &out, Backend::Serial);
        }
        out.into_grid()
    }

    #[test]
    fn closed_shells_are_told_from_open_ones_and_fill_alike() {
        let mut m = uv_sphere(Vec3::ZERO, 1.0, 48, 96);
        m.append(&torus(Vec3::new(2.5, 0.0, 0.3), 0.8, 0.3, 48, 24));
        m.append(&cuboid(
            Vec3::new(-1.0, -1.0, -1.6),
            Vec3::new(3.0, 1.0, -1.2),
        ));
        let found = shells(&m, Backend::Serial);
        assert_eq!(found.len(), 3);
        assert!(found.iter().all(|s| s.closed));
        // A sphere with its south cap cut away is open.
        let open = m
            .filter_triangles(|t| m.corners(t).iter().all(|p| p.z > -0.96 || p.z < -1.1))
            .unwrap();
        let found = shells(&open, Backend::Serial);
        assert_eq!(found.iter().filter(|s| !s.closed).count(), 1);
        let spec = GridSpec::for_scene(m.bounds(), 160).unwrap();
        let one_axis = fill_solid(&m, &spec, Backend::Serial);
        assert!(one_axis.count_ones() > 0);
        assert_eq!(one_axis, voted(&m, &spec));
    }
}
