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
//! two horizontal ones still agree. But an open shell whose triangles all
//! face into one half-space (a terrain, a sheet, a shallow bowl) is not
//! filled at all: it has no inside for the columns to find, and the vote
//! would call inside what lies between its slopes and what its columns
//! enter over its rim, above a terrain as much as below it.
//!
//! Crossings are counted with a watertight rasterization rule (shared edges
//! are owned by exactly one triangle, with edge functions evaluated in a
//! canonical orientation) so a closed shell never produces a spurious odd
//! column.
//!
//! Each axis is done with bit-parallel word operations: a crossing toggles one
//! bit where "inside" starts, and a prefix XOR along the axis turns toggles
//! into parity (64 columns at a time along y and z).

mod columns;
mod parity;
mod shells;
#[cfg(test)]
mod tests;

use std::sync::Mutex;

use super::grid::{AtomicGrid, Grid, GridSpec, Rows};
use crate::exec::Threads;
use crate::math::{Vec3, floor, max_each, min_each};
use crate::mesh::TriMesh;
use columns::{Columns, DENSE_WORDS_PER_CROSSING, DENSE_WORDS_PER_VOTE, vote_sparse};
use parity::{parity_along, vote};
pub(crate) use shells::{Shell, shells};

/// The voxels whose centre lies inside the mesh's solid (the surface itself
/// is not included; see [`super::voxelize`]).
pub fn fill_solid(mesh: &TriMesh, spec: &GridSpec, backend: Threads) -> Grid {
    fill_shells(mesh, &shells(mesh, backend), spec, backend)
}

/// The voxels whose centre lies inside one of `shells` of `mesh`. A shell
/// may be given in part (a window's: see [`super::window`]), with the
/// closedness of the whole: every column of the grid must cross the same
/// triangles of it as the whole shell does.
pub(crate) fn fill_shells(
    mesh: &TriMesh,
    shells: &[Shell],
    spec: &GridSpec,
    backend: Threads,
) -> Grid {
    let out = AtomicGrid::new(*spec);
    let written = Mutex::new(Rows::NONE);
    backend.for_each_range(shells.len(), 1, |range| {
        let mut rows = Rows::NONE;
        for s in range {
            // A shell that faces one way bounds no solid (see `Shell`):
            // its columns could only count in what they pass over its rim.
            if !shells[s].triangles.is_empty() && !shells[s].one_sided {
                rows = rows.union(fill_shell(
                    mesh,
                    &shells[s],
                    spec,
                    &out,
                    backend,
                    Path::Cheaper,
                ));
            }
        }
        let mut written = written.lock().unwrap_or_else(|e| e.into_inner());
        *written = written.union(rows);
    });
    let rows = written.into_inner().unwrap_or_else(|e| e.into_inner());
    out.into_grid().within(rows)
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
    /// Whichever costs less.
    Cheaper,
    Dense,
    Sparse,
}

fn fill_shell(
    mesh: &TriMesh,
    shell: &Shell,
    spec: &GridSpec,
    out: &AtomicGrid,
    backend: Threads,
    path: Path,
) -> Rows {
    let corners: Vec<[Vec3; 3]> = shell
        .triangles
        .iter()
        .map(|&t| mesh.corners(t as usize).map(|p| spec.to_grid(p)))
        .collect();
    let (mut lo_p, mut hi_p) = (corners[0][0], corners[0][0]);
    for c in corners.iter().flatten() {
        lo_p = min_each(lo_p, *c);
        hi_p = max_each(hi_p, *c);
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
    // What is filled lies in the block.
    let rows = Rows {
        y: [lo[1], hi[1] + 1],
        z: [lo[2], hi[2] + 1],
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
            return rows;
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
        return rows;
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
            return rows;
        }
    }
    // parity[a]: parity along axis a. The three axes are independent: a
    // large shell runs them side by side.
    let mut parity = vec![Vec::new(); 3];
    let axes = if corners.len() >= 4096 {
        backend
    } else {
        Threads::Serial
    };
    axes.for_each_row(&mut parity, 1, |axis, slot| {
        slot[0] = parity_along(axis, &corners, &block);
    });
    vote(&parity, &block, out);
    rows
}
