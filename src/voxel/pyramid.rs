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

use std::sync::OnceLock;

use super::grid::Grid;
use crate::exec::Backend;

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

/// One level: block counts as running sums along x (for balls), and block
/// occupancy as bytes (for interpolating spheres).
pub struct CountLevel {
    level: u32,
    dims: [usize; 3],
    stride: usize,
    prefix: Vec<u32>,
    /// Solid fraction of each block times 255, rounded; one trailing zero so
    /// that two neighbours can always be read together.
    occupancy: Vec<u8>,
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
        &self.prefix
    }

    /// Solid voxels in blocks `x0..=x1` of the row starting at `row`.
    #[inline]
    pub fn run(&self, row: usize, x0: usize, x1: usize) -> u32 {
        self.prefix[row + x1 + 1] - self.prefix[row + x0]
    }

    /// Block occupancy (solid fraction x 255), x fastest, then y, then z.
    pub fn occupancy(&self) -> &[u8] {
        &self.occupancy
    }

    /// Solid voxels in block (x, y, z).
    pub fn block(&self, x: usize, y: usize, z: usize) -> u32 {
        let r = self.row_start(y, z);
        self.run(r, x, x)
    }

    fn from_counts(level: u32, dims: [usize; 3], counts: &[u32], backend: Backend) -> CountLevel {
        let stride = dims[0] + 1;
        let rows = dims[1] * dims[2];
        let full = f64::from(1u32 << (3 * level));
        let mut occupancy: Vec<u8> = counts
            .iter()
            .map(|&c| (c as f64 * 255.0 / full).round() as u8)
            .collect();
        occupancy.push(0);
        let prefix: Vec<Vec<u32>> = backend.map(rows, |r| {
            let mut out = Vec::with_capacity(stride);
            let mut acc = 0u32;
            out.push(0);
            for &c in &counts[r * dims[0]..(r + 1) * dims[0]] {
                acc += c;
                out.push(acc);
            }
            out
        });
        CountLevel {
            level,
            dims,
            stride,
            prefix: prefix.concat(),
            occupancy,
        }
    }

    /// Level 1 from the bit grid.
    fn first(grid: &Grid, backend: Backend) -> CountLevel {
        let [nx, ny, nz] = grid.dims();
        let dims = [nx.div_ceil(2), ny.div_ceil(2), nz.div_ceil(2)];
        let wpr = grid.words_per_row();
        let words = grid.words();
        let rows: Vec<Vec<u32>> = backend.map(dims[1] * dims[2], |r| {
            let (y, z) = (r % dims[1], r / dims[1]);
            let mut out = vec![0u32; dims[0]];
            for (dy, dz) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let (yy, zz) = (2 * y + dy, 2 * z + dz);
                if yy >= ny || zz >= nz {
                    continue;
                }
                let start = grid.row_start(yy, zz);
                for k in 0..wpr {
                    let w = words[start + k];
                    if w == 0 {
                        continue;
                    }
                    // Counts of bit pairs, 2 bits each.
                    let pairs = (w & 0x5555_5555_5555_5555) + ((w >> 1) & 0x5555_5555_5555_5555);
                    for i in 0..32 {
                        let x = k * 32 + i;
                        if x < dims[0] {
                            out[x] += ((pairs >> (2 * i)) & 3) as u32;
                        }
                    }
                }
            }
            out
        });
        CountLevel::from_counts(1, dims, &rows.concat(), backend)
    }

    /// Level l + 1 from level l.
    fn next(&self, backend: Backend) -> CountLevel {
        let d = self.dims;
        let dims = [d[0].div_ceil(2), d[1].div_ceil(2), d[2].div_ceil(2)];
        let rows: Vec<Vec<u32>> = backend.map(dims[1] * dims[2], |r| {
            let (y, z) = (r % dims[1], r / dims[1]);
            let mut out = vec![0u32; dims[0]];
            for (dy, dz) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let (yy, zz) = (2 * y + dy, 2 * z + dz);
                if yy >= d[1] || zz >= d[2] {
                    continue;
                }
                let row = self.row_start(yy, zz);
                for (x, o) in out.iter_mut().enumerate() {
                    *o += self.run(row, 2 * x, (2 * x + 1).min(d[0] - 1));
                }
            }
            out
        });
        CountLevel::from_counts(self.level + 1, dims, &rows.concat(), backend)
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
    pub fn level(&self, level: u32, backend: Backend) -> &CountLevel {
        assert!(
            (1..=MAX_LEVEL).contains(&level),
            "pyramid level {level} out of range"
        );
        let i = level as usize - 1;
        if let Some(l) = self.levels[i].get() {
            return l;
        }
        let built = if level == 1 {
            CountLevel::first(&self.bits, backend)
        } else {
            self.level(level - 1, backend).next(backend)
        };
        self.levels[i].get_or_init(|| built)
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
                    if s % 3 == 0 {
                        g.set(x, y, z);
                    }
                }
            }
        }
        let solid = Solid::new(g.clone());
        for level in 1..=4 {
            let l = solid.level(level, Backend::Parallel);
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
    fn levels_keep_balls_several_blocks_wide() {
        assert_eq!(level_for_radius(5.0, 6.0), 0);
        assert_eq!(level_for_radius(12.0, 6.0), 1);
        assert_eq!(level_for_radius(24.4, 6.0), 2);
        assert_eq!(level_for_radius(73.3, 6.0), 3);
        assert_eq!(level_for_radius(73.3, 10.0), 2);
        assert_eq!(level_for_radius(1e6, 6.0), MAX_LEVEL);
    }
}
