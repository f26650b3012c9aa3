//! A count pyramid over the solid: level l holds the number of solid voxels in
//! each block of s x s x s voxels, s = 2^l.
//!
//! The descriptors read large balls and spheres from a level whose blocks
//! are small next to the radius (see [`level_for_radius`]), so every layer
//! costs about the same whatever its radius: a ball of radius R needs ~pi
//! (R/s)^2 runs instead of ~pi R^2, and a sphere's samples fall in a grid
//! 8^l times smaller that stays in cache. The block average is also the
//! right low-pass before sampling a sphere whose samples are several voxels
//! apart.
//!
//! Each row of blocks is stored as running sums along x, so the count of any
//! run of blocks is one subtraction.

use std::cell::RefCell;
use std::sync::OnceLock;

use super::grid::{Grid, Rows};
use crate::exec::{Threads, made_once};

/// Levels 1..=MAX_LEVEL can be built (level 0 is the bit grid itself).
pub const MAX_LEVEL: u32 = 5;

/// The coarsest level whose blocks still fit `blocks` times into `radius`
/// voxels.
pub fn level_for_radius(radius: f64, blocks: f64) -> u32 {
    let mut level = 0;
    while level < MAX_LEVEL && radius / f64::from(1u32 << (level + 1)) >= blocks {
        level += 1;
    }
    level
}

thread_local! {
    /// Running-sum buffers of dropped levels, all zero again, for the next
    /// level built on this thread.
    static SPARE_SUMS: RefCell<Vec<Vec<u32>>> = const { RefCell::new(Vec::new()) };
}

/// Buffers a thread keeps, and the most entries one may hold (16 MiB): a
/// few parts' worth, outside the memory budget.
const SPARE_BUFFERS: usize = 2;
const SPARE_MAX_ENTRIES: usize = 4 << 20;

/// A zeroed buffer of at least `len` entries (at most twice that): a
/// spare one where this thread has one. A part's level is mostly the empty
/// rows of its padding, so zeroing fresh memory for it was 5% of the
/// search of a building of distinct parts, while giving one back zeroes
/// only the rows it wrote.
fn zeroed_sums(len: usize) -> Vec<u32> {
    let spare = SPARE_SUMS.try_with(|spare| {
        let mut spare = spare.borrow_mut();
        let fits = spare
            .iter()
            .enumerate()
            .filter(|(_, b)| b.len() >= len && b.len() / 2 <= len)
            .min_by_key(|(_, b)| b.len())
            .map(|(i, _)| i)?;
        Some(spare.swap_remove(fits))
    });
    spare.ok().flatten().unwrap_or_else(|| vec![0; len])
}

/// One level: block counts as running sums along x (for balls), and block
/// occupancy as bytes (for interpolating spheres).
pub struct CountLevel {
    level: u32,
    dims: [usize; 3],
    stride: usize,
    /// The running sums, row after row; may run past them (a spare buffer,
    /// zero there).
    prefix: Vec<u32>,
    /// The rows of blocks that may hold solid; the others are zero.
    rows: Rows,
    /// Solid fraction of each block times 255, rounded; one trailing zero so
    /// that two neighbours can always be read together. Only spheres read
    /// it, so it is made on first use: most levels serve balls alone.
    occupancy: OnceLock<Vec<u8>>,
}

impl CountLevel {
    /// The level number l.
    pub fn level(&self) -> u32 {
        self.level
    }

    /// The block edge s = 2^l in voxels.
    pub fn scale(&self) -> usize {
        1 << self.level
    }

    /// Blocks along x, y, z.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// Index of the running sums of block row (y, z); the row holds
    /// `dims[0] + 1` sums, the first one 0.
    #[inline]
    pub fn row_start(&self, y: usize, z: usize) -> usize {
        (z * self.dims[1] + y) * self.stride
    }

    /// Entries between consecutive rows.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// The running sums, row after row.
    pub fn prefix(&self) -> &[u32] {
        &self.prefix[..self.sums_len()]
    }

    /// Entries of the running sums.
    fn sums_len(&self) -> usize {
        self.stride * self.dims[1] * self.dims[2]
    }

    /// Solid voxels in blocks `x0..=x1` of the row starting at `row`.
    #[inline]
    pub fn run(&self, row: usize, x0: usize, x1: usize) -> u32 {
        self.prefix[row + x1 + 1] - self.prefix[row + x0]
    }

    /// Block occupancy (solid fraction x 255), x fastest, then y, then z;
    /// made now if needed, on this thread.
    pub fn occupancy(&self) -> &[u8] {
        self.occupancy_with(Threads::Serial)
    }

    /// [`CountLevel::occupancy`], made with `backend` if needed (see
    /// [`made_once`]).
    pub fn occupancy_with(&self, backend: Threads) -> &[u8] {
        made_once(&self.occupancy, || self.make_occupancy(backend)).as_slice()
    }

    fn make_occupancy(&self, backend: Threads) -> Vec<u8> {
        let (dims, stride) = (self.dims, self.stride);
        let (shift, half) = (3 * self.level, 1u32 << (3 * self.level - 1));
        let mut occupancy = vec![0u8; dims[0] * dims[1] * dims[2] + 1];
        backend.for_each_row(
            &mut occupancy[..dims[0] * dims[1] * dims[2]],
            dims[0],
            |r, out| {
                if !self.rows.holds(r % dims[1], r / dims[1]) {
                    return;
                }
                let sums = &self.prefix[r * stride..(r + 1) * stride];
                if sums[stride - 1] == 0 {
                    // Left zero: see [`CountLevel::build`].
                    return;
                }
                for x in 0..out.len() {
                    out[x] = (((sums[x + 1] - sums[x]) * 255 + half) >> shift) as u8;
                }
            },
        );
        occupancy
    }

    /// Solid voxels in blocks `x0..=x1` of the row starting at `row`, and
    /// their first moment along x about block `about`, in blocks. Read from
    /// the running sums alone (summation by parts: the moment about the
    /// run's start is the sum over its blocks of the count to the run's
    /// end), so it needs no table beside them; the extra sums read lie in
    /// the cache lines of the run's two ends.
    #[inline]
    pub fn run_moment(&self, row: usize, x0: usize, x1: usize, about: i64) -> (u32, i64) {
        let sums = &self.prefix[row + x0..=row + x1 + 1];
        let end = sums[sums.len() - 1];
        let n = end - sums[0];
        let from_start: u64 = sums[1..sums.len() - 1]
            .iter()
            .map(|&s| u64::from(end - s))
            .sum();
        (n, from_start as i64 + i64::from(n) * (x0 as i64 - about))
    }

    /// Solid voxels in block (x, y, z).
    pub fn block(&self, x: usize, y: usize, z: usize) -> u32 {
        let r = self.row_start(y, z);
        self.run(r, x, x)
    }

    /// A level whose block counts `count(row, out)` writes row by row;
    /// a row `empty(row)` says has no solid is left as allocated (zero).
    /// A part's grid is padded by the template's radius on every side, so
    /// most of its rows are empty: writing them, zeros and running sums,
    /// was most of the work.
    fn build(
        level: u32,
        dims: [usize; 3],
        rows: Rows,
        backend: Threads,
        empty: impl Fn(usize, usize) -> bool + Sync + Send,
        count: impl Fn(usize, usize, &mut [u32]) + Sync + Send,
    ) -> CountLevel {
        let stride = dims[0] + 1;
        let len = stride * dims[1] * dims[2];
        let mut prefix = zeroed_sums(len);
        // Plane by plane, the rows of blocks that may hold solid only.
        let plane = stride * dims[1];
        let (first, end) = (rows.z[0].min(rows.z[1]), rows.z[1]);
        backend.for_each_row(&mut prefix[first * plane..end * plane], plane, |i, sums| {
            let z = first + i;
            for y in rows.y[0]..rows.y[1] {
                if empty(y, z) {
                    continue;
                }
                let row = &mut sums[y * stride..(y + 1) * stride];
                // Fresh zeroed memory is first touched by a write: a read
                // first maps the shared zero page and the write then faults
                // again.
                row.fill(0);
                count(y, z, &mut row[1..]);
                // The running sum stays in a register: reading back the
                // entry just written chains every step through memory.
                let mut sum = 0;
                for x in &mut row[1..] {
                    sum += *x;
                    *x = sum;
                }
            }
        });
        CountLevel {
            level,
            dims,
            stride,
            prefix,
            rows,
            occupancy: OnceLock::new(),
        }
    }

    /// Level 1 from the bit grid: the four fine rows of a block row are
    /// summed as bit-pair counts in 4-bit fields, 16 blocks per operation.
    fn first(grid: &Grid, backend: Threads) -> CountLevel {
        let [nx, ny, nz] = grid.dims();
        let dims = [nx.div_ceil(2), ny.div_ceil(2), nz.div_ceil(2)];
        let wpr = grid.words_per_row();
        let words = grid.words();
        let rows_of = |y: usize, z: usize| {
            [(0, 0), (1, 0), (0, 1), (1, 1)]
                .into_iter()
                .filter(move |&(dy, dz)| 2 * y + dy < ny && 2 * z + dz < nz)
                .map(move |(dy, dz)| grid.row_start(2 * y + dy, 2 * z + dz))
        };
        let empty = |y: usize, z: usize| {
            rows_of(y, z).all(|start| words[start..start + wpr].iter().all(|&w| w == 0))
        };
        let rows = grid.rows().halved();
        CountLevel::build(1, dims, rows, backend, empty, |y, z, out| {
            let rows: Vec<usize> = rows_of(y, z).collect();
            for k in 0..wpr {
                let (mut even, mut odd) = (0u64, 0u64);
                for &start in &rows {
                    let w = words[start + k];
                    let pairs = (w & 0x5555_5555_5555_5555) + ((w >> 1) & 0x5555_5555_5555_5555);
                    even += pairs & 0x3333_3333_3333_3333;
                    odd += (pairs >> 2) & 0x3333_3333_3333_3333;
                }
                if even | odd == 0 {
                    continue;
                }
                for j in 0..16 {
                    let x = k * 32 + 2 * j;
                    if x < out.len() {
                        out[x] = ((even >> (4 * j)) & 15) as u32;
                    }
                    if x + 1 < out.len() {
                        out[x + 1] = ((odd >> (4 * j)) & 15) as u32;
                    }
                }
            }
        })
    }

    /// Level l + 1 from level l.
    fn next(&self, backend: Threads) -> CountLevel {
        let d = self.dims;
        let dims = [d[0].div_ceil(2), d[1].div_ceil(2), d[2].div_ceil(2)];
        // The starts of the source rows (four, fewer at the far sides).
        let sources = |y: usize, z: usize| {
            [(0, 0), (1, 0), (0, 1), (1, 1)]
                .into_iter()
                .map(move |(dy, dz)| (2 * y + dy, 2 * z + dz))
                .filter(|&(yy, zz)| yy < d[1] && zz < d[2])
                .map(|(yy, zz)| self.row_start(yy, zz))
        };
        // A source row is empty when its running sum ends at 0.
        let empty = |y: usize, z: usize| sources(y, z).all(|row| self.prefix[row + d[0]] == 0);
        let rows = self.rows.halved();
        CountLevel::build(self.level + 1, dims, rows, backend, empty, |y, z, out| {
            for row in sources(y, z) {
                for (x, o) in out.iter_mut().enumerate() {
                    *o += self.run(row, 2 * x, (2 * x + 1).min(d[0] - 1));
                }
            }
        })
    }
}

impl Drop for CountLevel {
    /// Gives the running sums back to this thread's spares, zeroed: only
    /// rows that hold solid were written, and their sums end above zero.
    fn drop(&mut self) {
        let mut sums = std::mem::take(&mut self.prefix);
        if sums.len() > SPARE_MAX_ENTRIES {
            return;
        }
        let (len, stride) = (self.sums_len(), self.stride);
        let rows = self.rows;
        let plane = stride * self.dims[1];
        let held = match rows.is_empty() {
            true => 0..0,
            false => rows.z[0] * plane..rows.z[1] * plane,
        };
        for row in sums[..len][held].chunks_exact_mut(stride) {
            if row[stride - 1] != 0 {
                row.fill(0);
            }
        }
        let _ = SPARE_SUMS.try_with(|spare| {
            let mut spare = spare.borrow_mut();
            if spare.len() < SPARE_BUFFERS {
                spare.push(sums);
            } else if let Some(smaller) = spare.iter_mut().min_by_key(|b| b.len())
                && smaller.len() < sums.len()
            {
                *smaller = sums;
            }
        });
    }
}

/// A solid bit grid with its pyramid levels, each built on first use.
pub struct Solid {
    bits: Grid,
    levels: [OnceLock<CountLevel>; MAX_LEVEL as usize],
}

impl Solid {
    /// Wraps a solid grid.
    pub fn new(bits: Grid) -> Solid {
        Solid {
            bits,
            levels: Default::default(),
        }
    }

    /// The bit grid (level 0).
    pub fn bits(&self) -> &Grid {
        &self.bits
    }

    /// Level `level` (1..=MAX_LEVEL), built now if needed (with `backend`).
    pub fn level(&self, level: u32, backend: Threads) -> &CountLevel {
        assert!(
            (1..=MAX_LEVEL).contains(&level),
            "pyramid level {level} out of range"
        );
        made_once(&self.levels[level as usize - 1], || {
            if level == 1 {
                CountLevel::first(&self.bits, backend)
            } else {
                self.level(level - 1, backend).next(backend)
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::voxel::GridSpec;

    #[test]
    fn block_counts_match_brute_force_at_every_level() {
        let spec = GridSpec {
            origin: Vec3::ZERO,
            voxel_size: 1.0,
            dims: [77, 21, 13],
        };
        let mut g = Grid::new(spec);
        let mut s: u64 = 99;
        for z in 0..13 {
            for y in 0..21 {
                for x in 0..77 {
                    s ^= s << 13;
                    s ^= s >> 7;
                    s ^= s << 17;
                    if s.is_multiple_of(3) {
                        g.set(x, y, z);
                    }
                }
            }
        }
        let solid = Solid::new(g.clone());
        for level in 1..=4 {
            let l = solid.level(level, Threads::Parallel);
            let sc = l.scale() as i64;
            for z in 0..l.dims()[2] {
                for y in 0..l.dims()[1] {
                    for x in 0..l.dims()[0] {
                        let mut n = 0;
                        for dz in 0..sc {
                            for dy in 0..sc {
                                for dx in 0..sc {
                                    n += g.get(
                                        x as i64 * sc + dx,
                                        y as i64 * sc + dy,
                                        z as i64 * sc + dz,
                                    ) as u32;
                                }
                            }
                        }
                        assert_eq!(l.block(x, y, z), n, "level {level} block {x} {y} {z}");
                    }
                }
            }
        }
    }

    #[test]
    fn a_level_built_on_a_spare_buffer_counts_as_on_a_fresh_one() {
        // A full grid writes every row; the sparse one after it on this
        // thread takes its buffer back and leaves most rows unwritten, which
        // must read zero.
        let spec = GridSpec {
            origin: Vec3::ZERO,
            voxel_size: 1.0,
            dims: [70, 30, 26],
        };
        let mut full = Grid::new(spec);
        for z in 0..26 {
            for y in 0..30 {
                for x in 0..70 {
                    full.set(x, y, z);
                }
            }
        }
        let mut sparse = Grid::new(spec);
        sparse.set(5, 7, 9);
        sparse.set(60, 20, 3);
        for grid in [full, sparse.clone(), sparse] {
            let solid = Solid::new(grid.clone());
            for level in 1..=2 {
                let l = solid.level(level, Threads::Serial);
                let sc = l.scale() as i64;
                for z in 0..l.dims()[2] {
                    for y in 0..l.dims()[1] {
                        for x in 0..l.dims()[0] {
                            let mut n = 0;
                            for (dx, dy, dz) in (0..sc).flat_map(|a| {
                                (0..sc).flat_map(move |b| (0..sc).map(move |c| (a, b, c)))
                            }) {
                                n += grid.get(
                                    x as i64 * sc + dx,
                                    y as i64 * sc + dy,
                                    z as i64 * sc + dz,
                                ) as u32;
                            }
                            assert_eq!(l.block(x, y, z), n, "level {level} block {x} {y} {z}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn levels_keep_balls_several_blocks_wide() {
        assert_eq!(level_for_radius(5.0, 6.0), 0);
        assert_eq!(level_for_radius(12.0, 6.0), 1);
        assert_eq!(level_for_radius(24.4, 6.0), 2);
        assert_eq!(level_for_radius(73.3, 6.0), 3);
        assert_eq!(level_for_radius(73.3, 10.0), 2);
        assert_eq!(level_for_radius(1e6, 6.0), MAX_LEVEL);
    }
}
