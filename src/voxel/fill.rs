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
            fill_shell(mesh, &shells[s], spec, &out, backend, Path::Cheaper);
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

/// How a shell is filled: the dense block or the sorted crossings give the
/// same voxels; the tests compare them.
#[derive(Clone, Copy, PartialEq, Debug)]
#[cfg_attr(not(test), allow(dead_code))]
enum Path {
    /// Whichever costs less (and nothing at all for a lone triangle).
    Cheaper,
    Dense,
    Sparse,
}

fn fill_shell(
    mesh: &TriMesh,
    shell: &Shell,
    spec: &GridSpec,
    out: &AtomicGrid,
    backend: Backend,
    path: Path,
) {
    if path == Path::Cheaper && !shell.closed && shell.triangles.len() == 1 {
        // A lone triangle: a column crosses it once or not at all, so every
        // column that crosses it abstains (odd) and every other one says
        // "outside". Nothing is filled, and a soup of large separate
        // triangles skips a block per triangle.
        return;
    }
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
    // Twice the area the shell projects onto each axis plane: about twice
    // the number of columns along that axis that cross it.
    let mut area = [0.0f64; 3];
    for [a, b, c] in &corners {
        let n = (*b - *a).cross(*c - *a);
        area = [0, 1, 2].map(|k| area[k] + n[k].abs());
    }
    // The block is filled word-parallel (a few operations per word and
    // axis), but its size is the shell's bounding box, which a thin shell
    // lying diagonally (or a few large triangles) crosses in a vanishing
    // share of its columns: then the crossings are sorted by column instead,
    // and only the words that some column calls inside are visited.
    let crossings = |axes: &[usize]| {
        axes.iter().map(|&a| area[a] / 2.0).sum::<f64>() + (axes.len() * corners.len()) as f64
    };
    if shell.closed {
        // Along the axis that crosses the least projected area.
        let axis = (0..3)
            .min_by(|&i, &j| area[i].total_cmp(&area[j]))
            .unwrap_or(2);
        let sparse = match path {
            Path::Cheaper => block.len() as f64 > DENSE_WORDS_PER_CROSSING * crossings(&[axis]),
            _ => path == Path::Sparse,
        };
        if sparse {
            let columns = Columns::new(axis, &corners, &block, false);
            columns.emit_parity(&block, out);
            return;
        }
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
    let sparse = match path {
        Path::Cheaper => {
            3.0 * block.len() as f64 > DENSE_WORDS_PER_CROSSING * crossings(&[0, 1, 2])
        }
        _ => path == Path::Sparse,
    };
    if sparse {
        let columns = [0, 1, 2].map(|axis| Columns::new(axis, &corners, &block, true));
        let inside_words: usize = columns.iter().map(|c| c.inside_words).sum();
        // Voting reads the other two axes at every word one of them calls
        // inside: a few binary searches instead of three word operations.
        if path == Path::Sparse || 3 * block.len() > DENSE_WORDS_PER_VOTE * inside_words {
            vote_sparse(&columns, &block, out);
            return;
        }
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

/// A shell's block is filled densely when it has at most this many words
/// per axis and (estimated) crossing: sorting a crossing costs about as
/// much as a dozen word operations.
const DENSE_WORDS_PER_CROSSING: f64 = 12.0;

/// An open shell whose crossings are sorted is still voted densely when its
/// block has at most this many words per axis and word that some axis
/// calls inside (the sparse vote looks the other two axes up there).
const DENSE_WORDS_PER_VOTE: usize = 16;

/// The crossings of a shell along one axis, sorted into groups of columns:
/// the rows (y, z) along x, and along y and z the 64 columns of one x word
/// (at one z, or one y), so that a group's state at a position is one word
/// as in the dense block. Gives the same parity as [`parity_along`].
struct Columns {
    axis: usize,
    /// The groups that any crossing reaches, ascending: along x the row
    /// `z * ny + y`, along y `z * words + k`, along z `y * words + k`
    /// (block-relative, k the word within the block's row).
    groups: Vec<u64>,
    /// Group i's changes are `changes[starts[i]..starts[i + 1]]`.
    starts: Vec<usize>,
    /// Along x: (word k, its inside bits), ascending in k. Along y and z:
    /// (position, the group's inside bits from there on until the next
    /// change or the block's end), ascending.
    changes: Vec<(u32, u64)>,
    /// Per group: the columns crossed an odd number of times (all bits of
    /// a row along x).
    odd: Vec<u64>,
    /// How many block words hold inside bits.
    inside_words: usize,
}

impl Columns {
    /// `valid_only`: leave the inside of odd columns out (as the vote does).
    fn new(axis: usize, corners: &[[Vec3; 3]], block: &Block, valid_only: bool) -> Columns {
        let mut keys: Vec<u64> = Vec::new();
        let rel = |v: [usize; 3]| {
            let (x, y, z) = (v[0] - block.lo[0], v[1] - block.lo[1], v[2] - block.lo[2]);
            let k = ((v[0] >> 6) - block.first_word) as u64;
            let bit = (v[0] & 63) as u64;
            (x as u64, y as u64, z as u64, k, bit)
        };
        let words = block.words as u64;
        let ny = block.ny as u64;
        for tri in corners {
            match axis {
                0 => for_each_crossing::<0>(tri, block, |v| {
                    let (x, y, z, _, _) = rel(v);
                    keys.push(((z * ny + y) << 16) | x);
                }),
                1 => for_each_crossing::<1>(tri, block, |v| {
                    let (_, y, z, k, bit) = rel(v);
                    keys.push(((z * words + k) << 22) | (y << 6) | bit);
                }),
                _ => for_each_crossing::<2>(tri, block, |v| {
                    let (_, y, z, k, bit) = rel(v);
                    keys.push(((y * words + k) << 22) | (z << 6) | bit);
                }),
            }
        }
        keys.sort_unstable();
        let mut columns = Columns {
            axis,
            groups: Vec::new(),
            starts: vec![0],
            changes: Vec::new(),
            odd: Vec::new(),
            inside_words: 0,
        };
        let len = block.hi[axis] - block.lo[axis] + 1;
        let shift = if axis == 0 { 16 } else { 22 };
        let mut i = 0;
        while i < keys.len() {
            let group = keys[i] >> shift;
            let end = i + keys[i..].partition_point(|&key| key >> shift == group);
            let first = columns.changes.len();
            let odd = if axis == 0 {
                columns.row_changes(&keys[i..end], block, len, valid_only)
            } else {
                columns.column_changes(&keys[i..end], len, valid_only)
            };
            if columns.changes.len() > first || odd != 0 {
                columns.groups.push(group);
                columns.starts.push(columns.changes.len());
                columns.odd.push(odd);
            }
            i = end;
        }
        columns
    }

    /// One row along x from its sorted crossings: the inside is every
    /// other interval between them (the last one runs to the block's end
    /// when the count is odd, unless `valid_only`).
    fn row_changes(&mut self, keys: &[u64], block: &Block, len: usize, valid_only: bool) -> u64 {
        let odd = keys.len() % 2 == 1;
        if odd && valid_only {
            return !0;
        }
        let first = self.changes.len();
        for pair in keys.chunks(2) {
            let a = block.lo[0] + (pair[0] & 0xffff) as usize;
            let b = block.lo[0] + pair.get(1).map_or(len, |&key| (key & 0xffff) as usize);
            // Bits a..b, a word at a time.
            let mut x = a;
            while x < b {
                let word_end = ((x >> 6) + 1) << 6;
                let stop = b.min(word_end);
                let bits = (!0u64 >> (64 - (stop - x))) << (x & 63);
                let k = ((x >> 6) - block.first_word) as u32;
                match self.changes[first..].last_mut() {
                    Some(last) if last.0 == k => last.1 |= bits,
                    _ => self.changes.push((k, bits)),
                }
                x = stop;
            }
        }
        self.inside_words += self.changes.len() - first;
        if odd { !0 } else { 0 }
    }

    /// One group of 64 columns along y or z from its sorted crossings.
    fn column_changes(&mut self, keys: &[u64], len: usize, valid_only: bool) -> u64 {
        let odd = keys.iter().fold(0u64, |odd, &key| odd ^ (1 << (key & 63)));
        let mask = if valid_only { !odd } else { !0 };
        let first = self.changes.len();
        let (mut word, mut i) = (0u64, 0);
        while i < keys.len() {
            let at = (keys[i] >> 6) & 0xffff;
            while i < keys.len() && (keys[i] >> 6) & 0xffff == at {
                word ^= 1 << (keys[i] & 63);
                i += 1;
            }
            let inside = word & mask;
            let last = self.changes[first..].last().map_or(0, |c| c.1);
            if inside != last {
                self.changes.push((at as u32, inside));
            }
        }
        let changes = &self.changes[first..];
        for (j, &(at, inside)) in changes.iter().enumerate() {
            if inside != 0 {
                let next = changes.get(j + 1).map_or(len, |c| c.0 as usize);
                self.inside_words += next - at as usize;
            }
        }
        odd
    }

    /// The inside bits and the odd columns of `group` at `position` (the
    /// word along x, the place along y or z).
    fn at(&self, group: u64, position: u32) -> (u64, u64) {
        let Ok(g) = self.groups.binary_search(&group) else {
            return (0, 0);
        };
        let changes = &self.changes[self.starts[g]..self.starts[g + 1]];
        let inside = if self.axis == 0 {
            changes
                .binary_search_by_key(&position, |c| c.0)
                .map_or(0, |i| changes[i].1)
        } else {
            match changes.partition_point(|c| c.0 <= position) {
                0 => 0,
                i => changes[i - 1].1,
            }
        };
        (inside, self.odd[g])
    }

    /// Calls `visit(k, y, z, inside)` (block-relative) for every block word
    /// with inside bits.
    fn for_each_inside(&self, block: &Block, mut visit: impl FnMut(usize, usize, usize, u64)) {
        let len = block.hi[self.axis] - block.lo[self.axis] + 1;
        for (g, &group) in self.groups.iter().enumerate() {
            let group = group as usize;
            let changes = &self.changes[self.starts[g]..self.starts[g + 1]];
            for (j, &(at, inside)) in changes.iter().enumerate() {
                if inside == 0 {
                    continue;
                }
                let at = at as usize;
                match self.axis {
                    0 => visit(at, group % block.ny, group / block.ny, inside),
                    axis => {
                        let next = changes.get(j + 1).map_or(len, |c| c.0 as usize);
                        let (k, other) = (group % block.words, group / block.words);
                        for t in at..next {
                            if axis == 1 {
                                visit(k, t, other, inside);
                            } else {
                                visit(k, other, t, inside);
                            }
                        }
                    }
                }
            }
        }
    }

    /// ORs the parity into `out` (a closed shell's interior).
    fn emit_parity(&self, block: &Block, out: &AtomicGrid) {
        self.for_each_inside(block, |k, y, z, inside| {
            out.or_word(
                block.first_word + k,
                block.lo[1] + y,
                block.lo[2] + z,
                inside,
            );
        });
    }
}

/// The vote of [`vote`] from sorted crossings: a voxel is solid when more
/// valid columns call it inside than outside, so it is inside along some
/// axis a, and then solid where another axis calls it inside too or both
/// other axes abstain. Visits only the words some axis calls inside.
fn vote_sparse(columns: &[Columns; 3], block: &Block, out: &AtomicGrid) {
    let (ny, words) = (block.ny as u64, block.words as u64);
    // (inside, odd) of each axis at block word (k, y, z).
    let state = |axis: usize, k: usize, y: usize, z: usize| {
        let (k, y, z) = (k as u64, y as u64, z as u64);
        match axis {
            0 => columns[0].at(z * ny + y, k as u32),
            1 => columns[1].at(z * words + k, y as u32),
            _ => columns[2].at(y * words + k, z as u32),
        }
    };
    for (axis, c) in columns.iter().enumerate() {
        let (b, c2) = ((axis + 1) % 3, (axis + 2) % 3);
        c.for_each_inside(block, |k, y, z, inside| {
            let (inside_b, odd_b) = state(b, k, y, z);
            let (inside_c, odd_c) = state(c2, k, y, z);
            let solid = inside & (inside_b | inside_c | (odd_b & odd_c));
            out.or_word(
                block.first_word + k,
                block.lo[1] + y,
                block.lo[2] + z,
                solid,
            );
        });
    }
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
        let cy = cv as f64 + 0.5;
        // Each edge's test is monotone along the row (its value is affine in
        // the column, and rounding is monotone): the columns that pass all
        // three form one run. Its ends are found from where the edges cross
        // the row and settled by the tests themselves, so that a row costs
        // the columns it crosses, not the bounding box's width (a long thin
        // triangle lying diagonally would cost the box's area). A narrow
        // box (a fine mesh's triangles) is cheaper to test column by column.
        let (mut first, mut last) = (u0 as i64, u1 as i64);
        if last - first >= NARROW_ROW {
            for i in 0..3 {
                let (a, b) = (p[(i + 1) % 3], p[(i + 2) % 3]);
                let passes = |cu: i64| owned_edge(a, b, [cu as f64 + 0.5, cy]).is_some();
                if a[1] == b[1] {
                    // Parallel to the row: the same for every column.
                    if !passes(first) {
                        first = last + 1;
                    }
                } else {
                    // The column whose centre the edge's line crosses.
                    let x = a[0] + (b[0] - a[0]) * (cy - a[1]) / (b[1] - a[1]) - 0.5;
                    if a[1] > b[1] {
                        // Passes from some column on: the first that does.
                        let mut s = (ceil(x) as i64).clamp(first, last + 1);
                        while s > first && passes(s - 1) {
                            s -= 1;
                        }
                        while s <= last && !passes(s) {
                            s += 1;
                        }
                        first = s;
                    } else {
                        // Passes up to some column: the last that does.
                        let mut s = (floor(x) as i64).clamp(first - 1, last);
                        while s < last && passes(s + 1) {
                            s += 1;
                        }
                        while s >= first && !passes(s) {
                            s -= 1;
                        }
                        last = s;
                    }
                }
                if first > last {
                    break;
                }
            }
        }
        for cu in first..=last {
            let cu = cu as usize;
            let c = [cu as f64 + 0.5, cy];
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

/// Rows of a triangle's box at most this many columns wide are tested
/// column by column rather than searched for their run.
const NARROW_ROW: i64 = 8;

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
            fill_shell(mesh, &open, spec, &out, Backend::Serial, Path::Dense);
        }
        out.into_grid()
    }

    /// Every shell of `mesh` filled along `path` (as open shells when
    /// `open`), into one grid.
    fn filled(mesh: &TriMesh, spec: &GridSpec, path: Path, open: bool) -> Grid {
        let out = AtomicGrid::new(*spec);
        for shell in shells(mesh, Backend::Serial) {
            let shell = Shell {
                closed: shell.closed && !open,
                ..shell
            };
            fill_shell(mesh, &shell, spec, &out, Backend::Serial, path);
        }
        out.into_grid()
    }

    fn rng(mut s: u64) -> impl FnMut() -> f64 {
        move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// Separate shells that stress the sparse path: tents (two large
    /// triangles sharing an edge), thin slivers lying diagonally, tetrahedra,
    /// triangles with axis-parallel edges and corners on column centres.
    fn awkward_shells(seed: u64) -> TriMesh {
        let mut rnd = rng(seed);
        let mut positions: Vec<[f32; 3]> = Vec::new();
        let mut triangles: Vec<[u32; 3]> = Vec::new();
        let point = |rnd: &mut dyn FnMut() -> f64| [0; 3].map(|_| (rnd() * 40.0) as f32 - 20.0);
        for i in 0..40u32 {
            let n = positions.len() as u32;
            let [a, b, c, d] = [0; 4].map(|_| point(&mut rnd));
            match i % 5 {
                0 => {
                    positions.extend([a, b, c, d]);
                    triangles.extend([[n, n + 1, n + 2], [n + 1, n, n + 3]]);
                }
                1 => {
                    let near = |p: [f32; 3], rnd: &mut dyn FnMut() -> f64| {
                        p.map(|x| x + (rnd() as f32 - 0.5) * 0.4)
                    };
                    let (c, d) = (near(a, &mut rnd), near(a, &mut rnd));
                    positions.extend([a, b, c, d]);
                    triangles.extend([[n, n + 1, n + 2], [n + 1, n, n + 3]]);
                }
                2 => {
                    positions.extend([a, b, c, d]);
                    triangles.extend([
                        [n, n + 1, n + 2],
                        [n, n + 3, n + 1],
                        [n, n + 2, n + 3],
                        [n + 1, n + 3, n + 2],
                    ]);
                }
                3 => {
                    // Corners on whole and half units (in a grid of voxel
                    // 0.5 with its origin on a whole unit: on voxel corners
                    // and column centres), edges parallel to the axes.
                    let snap = |p: [f32; 3]| p.map(|x| (x * 4.0).round() / 4.0);
                    let (a, b) = (snap(a), snap(b));
                    let c = [a[0], b[1], a[2]];
                    let d = [b[0], a[1], b[2]];
                    positions.extend([a, b, c, d]);
                    triangles.extend([[n, n + 1, n + 2], [n + 1, n, n + 3]]);
                }
                _ => {
                    positions.extend([a, b, c]);
                    triangles.push([n, n + 1, n + 2]);
                }
            }
        }
        TriMesh::new(positions, triangles).unwrap()
    }

    #[test]
    fn sorted_crossings_fill_as_the_dense_block() {
        let mut meshes = vec![
            awkward_shells(7),
            awkward_shells(8),
            torus(Vec3::new(0.3, 0.1, 0.0), 0.8, 0.3, 48, 24),
        ];
        let sphere = uv_sphere(Vec3::ZERO, 1.0, 48, 96);
        meshes.push(
            sphere
                .filter_triangles(|t| sphere.corners(t).iter().all(|p| p.z > -0.9 && p.x < 0.95))
                .unwrap(),
        );
        for (i, m) in meshes.iter().enumerate() {
            for res in [37, 96] {
                let spec = GridSpec::for_scene(m.bounds(), res).unwrap();
                for open in [false, true] {
                    let dense = filled(m, &spec, Path::Dense, open);
                    let sparse = filled(m, &spec, Path::Sparse, open);
                    let cheaper = filled(m, &spec, Path::Cheaper, open);
                    assert!(dense == sparse, "mesh {i} at {res}, open {open}");
                    assert!(dense == cheaper, "mesh {i} at {res}, open {open}");
                }
            }
        }
        // A grid whose origin is a whole unit and whose voxel is 0.5, so that
        // snapped corners fall on voxel corners and column centres.
        let m = awkward_shells(9);
        let spec = GridSpec {
            origin: Vec3::new(-24.0, -24.0, -24.0),
            voxel_size: 0.5,
            dims: [97, 97, 97],
        };
        let b = m.bounds();
        assert!(
            b.min.x.min(b.min.y).min(b.min.z) > -24.0 && b.max.x.max(b.max.y).max(b.max.z) < 24.0
        );
        for open in [false, true] {
            let dense = filled(&m, &spec, Path::Dense, open);
            assert!(dense.count_ones() > 0);
            assert!(dense == filled(&m, &spec, Path::Sparse, open));
            assert!(dense == filled(&m, &spec, Path::Cheaper, open));
        }
    }

    #[test]
    fn a_lone_triangle_fills_nothing() {
        let mut rnd = rng(3);
        for _ in 0..200 {
            let p = [0; 3].map(|_| [0; 3].map(|_| rnd() as f32 * 10.0));
            let m = TriMesh::new(p.to_vec(), vec![[0, 1, 2]]).unwrap();
            let spec = GridSpec::for_scene(m.bounds(), 24).unwrap();
            assert_eq!(filled(&m, &spec, Path::Dense, true).count_ones(), 0);
        }
    }

    /// The crossings of every column of the triangle's bounding box, tested
    /// one by one (what `for_each_crossing` finds run by run).
    fn scanned_crossings<const AXIS: usize>(tri: &[Vec3; 3], block: &Block) -> Vec<[usize; 3]> {
        let (u, v) = ((AXIS + 1) % 3, (AXIS + 2) % 3);
        let range = |a: usize| {
            let lo = tri[0][a].min(tri[1][a]).min(tri[2][a]);
            let hi = tri[0][a].max(tri[1][a]).max(tri[2][a]);
            let first = ceil(lo - 0.5).max(block.lo[a] as f64);
            let last = floor(hi - 0.5).min(block.hi[a] as f64);
            first as usize..=last as usize
        };
        let (us, vs) = (range(u), range(v));
        if us.is_empty() || vs.is_empty() {
            return Vec::new();
        }
        let mut p = tri.map(|q| [q[u], q[v]]);
        let mut depth = tri.map(|q| q[AXIS]);
        let area2 = edge(p[0], p[1], p[2]);
        if area2 == 0.0 {
            return Vec::new();
        }
        if area2 < 0.0 {
            p.swap(1, 2);
            depth.swap(1, 2);
        }
        let area2 = area2.abs();
        let mut out = Vec::new();
        for cv in vs {
            for cu in us.clone() {
                let c = [cu as f64 + 0.5, cv as f64 + 0.5];
                let w = [
                    owned_edge(p[1], p[2], c),
                    owned_edge(p[2], p[0], c),
                    owned_edge(p[0], p[1], c),
                ];
                let [Some(w0), Some(w1), Some(w2)] = w else {
                    continue;
                };
                let d = (w0 * depth[0] + w1 * depth[1] + w2 * depth[2]) / area2;
                let t = floor(d + 0.5).clamp(block.lo[AXIS] as f64, block.hi[AXIS] as f64);
                let mut at = [0; 3];
                at[AXIS] = t as usize;
                at[u] = cu;
                at[v] = cv;
                out.push(at);
            }
        }
        out
    }

    #[test]
    fn rows_of_crossings_are_those_of_the_whole_box() {
        let mut rnd = rng(11);
        let block = Block {
            lo: [0; 3],
            hi: [39; 3],
            first_word: 0,
            words: 1,
            ny: 40,
            nz: 40,
        };
        for i in 0..3000 {
            let mut tri = [0; 3].map(|_| Vec3::new(rnd() * 40.0, rnd() * 40.0, rnd() * 40.0));
            match i % 4 {
                // A sliver: the third corner near the first.
                0 => tri[2] = tri[0] + Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * 0.3,
                // Corners on half units: on column centres and voxel corners.
                1 => {
                    tri = tri.map(|q| {
                        Vec3::new(
                            (q.x * 2.0).round() / 2.0,
                            (q.y * 2.0).round() / 2.0,
                            (q.z * 2.0).round() / 2.0,
                        )
                    })
                }
                // Nearly degenerate: the third corner almost on the first edge.
                2 => tri[2] = tri[0] + (tri[1] - tri[0]) * rnd() + Vec3::new(1e-9, -1e-9, 1e-9),
                _ => {}
            }
            fn found<const AXIS: usize>(tri: &[Vec3; 3], block: &Block) -> Vec<[usize; 3]> {
                let mut out = Vec::new();
                for_each_crossing::<AXIS>(tri, block, |v| out.push(v));
                out
            }
            assert_eq!(
                found::<0>(&tri, &block),
                scanned_crossings::<0>(&tri, &block),
                "{tri:?}"
            );
            assert_eq!(
                found::<1>(&tri, &block),
                scanned_crossings::<1>(&tri, &block),
                "{tri:?}"
            );
            assert_eq!(
                found::<2>(&tri, &block),
                scanned_crossings::<2>(&tri, &block),
                "{tri:?}"
            );
        }
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
