//! Where a sphere's samples fall on the solid, and their trilinear reads:
//! from the bit grid for small radii, from a count-pyramid level for large
//! ones.

use super::transform::{phi, theta};
use super::{RINGS, SECTORS};
use crate::exec::Threads;
use crate::voxel::{Grid, Solid, level_for_radius};
use std::sync::OnceLock;

/// Spheres are sampled from pyramid blocks at least this many times smaller
/// than their radius: the degrees kept (l < 16) only resolve features of
/// about 0.2 r, so a block average up to 0.1 r loses nothing they could see,
/// and it removes the aliasing of sampling a binary grid far sparser than
/// its voxels.
pub const BLOCKS_PER_RADIUS: f64 = 10.0;

/// Fractional bits of the fixed-point sample positions: block coordinates
/// stay below 2^15, and 1/65536 of a block is far below any precision that
/// matters, while integer floors and fractions vectorize where float-to-int
/// conversions do not.
const FIXED: u32 = 16;

/// The sample directions (sin theta cos phi, sin theta sin phi, cos theta),
/// ring by ring, computed once: every part's spheres share them, and a
/// scene of thousands of parts spent 4% of its search on their sines.
fn unit_directions() -> &'static [[f64; 3]] {
    static DIRECTIONS: OnceLock<Vec<[f64; 3]>> = OnceLock::new();
    DIRECTIONS.get_or_init(|| {
        let mut out = Vec::with_capacity(RINGS * SECTORS);
        for j in 0..RINGS {
            let (st, ct) = theta(j).sin_cos();
            for k in 0..SECTORS {
                let (sp, cp) = phi(k).sin_cos();
                out.push([st * cp, st * sp, ct]);
            }
        }
        out
    })
}

/// Samples are processed in chunks: positions and weights in one pass, the
/// scattered reads in another, the interpolation in a third, so that the
/// arithmetic passes vectorize.
pub(super) const CHUNK: usize = 64;

/// Where the samples of one sphere fall, bound to one solid's layout (arrays
/// of structures are split into one array per field, for vectorization).
pub struct SphereSampler {
    radius: f64,
    level: u32,
    /// Level 0: offset of the lower interpolation corner (voxels), the byte
    /// offset of its row, and the fractional position.
    off: [Vec<i32>; 3],
    row: Vec<i32>,
    frac: [Vec<f32>; 3],
    /// Level > 0: the sample directions times the radius, in blocks, fixed
    /// point with [`FIXED`] fractional bits.
    reach: [Vec<i32>; 3],
    /// How far a sample's cell corners can lie from the centre's cell, in
    /// cells of the level read (voxels, or blocks with the centre's offset
    /// within its block).
    cell_reach: i64,
    wpr: usize,
    plane: usize,
    dims: [usize; 3],
}

impl SphereSampler {
    /// The sampling pattern of a sphere of `radius` voxels on `solid`.
    pub fn new(radius: f64, solid: &Solid, backend: Threads) -> SphereSampler {
        let level = level_for_radius(radius, BLOCKS_PER_RADIUS);
        let grid = solid.bits();
        let dims = grid.dims();
        let wpr = grid.words_per_row();
        let mut s = SphereSampler {
            radius,
            level,
            off: Default::default(),
            row: Vec::new(),
            frac: Default::default(),
            reach: Default::default(),
            cell_reach: if level == 0 {
                radius.ceil() as i64 + 1
            } else {
                (radius / f64::from(1u32 << level)).ceil() as i64 + 2
            },
            wpr,
            plane: wpr * dims[1],
            dims,
        };
        let scale = f64::from(1u32 << level);
        for j in 0..RINGS {
            for k in 0..SECTORS {
                // (st cp, st sp, ct) times the radius, rounded as before.
                let u = unit_directions()[j * SECTORS + k];
                let d = [u[0] * radius, u[1] * radius, u[2] * radius];
                if level > 0 {
                    for a in 0..3 {
                        s.reach[a].push((d[a] / scale * f64::from(1u32 << FIXED)).round() as i32);
                    }
                    continue;
                }
                let b = d.map(|c| c.floor());
                for a in 0..3 {
                    s.off[a].push(b[a] as i32);
                    s.frac[a].push((d[a] - b[a]) as f32);
                }
                let row_words = (b[2] as i64 * dims[1] as i64 + b[1] as i64) * wpr as i64;
                s.row.push(
                    i32::try_from(8 * row_words).expect("a sphere spans less than 2 GiB of grid"),
                );
            }
        }
        if level > 0 {
            solid.level(level, backend).occupancy_with(backend);
        }
        s
    }

    /// The radius in voxels.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// The pyramid level it reads.
    pub fn level(&self) -> u32 {
        self.level
    }

    /// Samples the solid fraction on the sphere around voxel `v` of `solid`
    /// (the solid it was made for; outside the grid reads as empty).
    pub fn sample(&self, solid: &Solid, v: [u16; 3], out: &mut [f32; RINGS * SECTORS]) {
        if self.level > 0 {
            return self.sample_blocks(solid, v, out);
        }
        let grid = solid.bits();
        debug_assert_eq!(grid.dims(), self.dims);
        let c = v.map(|x| x as i64);
        let words = grid.words();
        let bytes: &[u8] = bytemuck::cast_slice(words);
        let base = (c[2] * self.dims[1] as i64 + c[1]) * self.wpr as i64;
        let (wpr, plane) = (self.wpr, self.plane);
        let (row_bytes, plane_bytes) = (8 * wpr, 8 * plane);
        // The lower corner must leave room for the upper one.
        let limit = self.dims.map(|d| d as u64 - 1);
        let inside_xy = spans_xy(c, self.cell_reach, self.dims);
        // Little-endian words laid out as bytes: bit x of a row is bit x % 8
        // of its byte x / 8, so two neighbours are one u16 read away. The
        // centre's byte, and its bit within it.
        let origin = 8 * base + (c[0] >> 3);
        let phase = (c[0] & 7) as i32;
        let mut code = [0u32; CHUNK];
        let mut byte = [0i32; CHUNK];
        let mut shift = [0u32; CHUNK];
        for start in (0..out.len()).step_by(CHUNK) {
            let z = c[2] + self.off[2][start] as i64;
            let reads = ring_reads(z, limit[2] as i64, inside_xy);
            if reads == RingReads::Empty {
                out[start..start + CHUNK].fill(0.0);
                continue;
            }
            if reads == RingReads::Unchecked && cfg!(target_endian = "little") {
                // Byte offsets and shifts in one vector pass, the reads in
                // another.
                for i in 0..CHUNK {
                    let x = phase + self.off[0][start + i];
                    byte[i] = self.row[start + i] + (x >> 3);
                    shift[i] = (x & 7) as u32;
                }
                for i in 0..CHUNK {
                    let cell =
                        &bytes[(origin + byte[i] as i64) as usize..][..plane_bytes + row_bytes + 2];
                    let at = |o: usize| {
                        ((u16::from_le_bytes([cell[o], cell[o + 1]]) >> shift[i]) & 3) as u32
                    };
                    code[i] = at(0)
                        | at(row_bytes) << 2
                        | at(plane_bytes) << 4
                        | at(plane_bytes + row_bytes) << 6;
                }
            } else {
                for i in 0..CHUNK {
                    let s = start + i;
                    let (x, y) = (c[0] + self.off[0][s] as i64, c[1] + self.off[1][s] as i64);
                    code[i] = if (x as u64) < limit[0]
                        && (y as u64) < limit[1]
                        && (z as u64) < limit[2]
                    {
                        let w = (base + self.row[s] as i64 / 8) as usize + (x >> 6) as usize;
                        let b = (x & 63) as u32;
                        pair(words, w, b)
                            | pair(words, w + wpr, b) << 2
                            | pair(words, w + plane, b) << 4
                            | pair(words, w + plane + wpr, b) << 6
                    } else {
                        corners_near_border(grid, x, y, z)
                    };
                }
            }
            // A ring wholly outside or inside the solid (most, on a sheet
            // or in a large solid) reads exactly 0 or 1 everywhere.
            let (any, all) = code
                .iter()
                .fold((0u32, 0xff), |(any, all), &c| (any | c, all & c));
            if any == 0 || all == 0xff {
                out[start..start + CHUNK].fill(if any == 0 { 0.0 } else { 1.0 });
                continue;
            }
            let (fx, fy, fz) = (
                &self.frac[0][start..start + CHUNK],
                &self.frac[1][start..start + CHUNK],
                &self.frac[2][start..start + CHUNK],
            );
            for i in 0..CHUNK {
                let corner = |k: u32| ((code[i] >> k) & 1) as f32;
                out[start + i] = trilinear(
                    [
                        corner(0),
                        corner(1),
                        corner(2),
                        corner(3),
                        corner(4),
                        corner(5),
                        corner(6),
                        corner(7),
                    ],
                    [fx[i], fy[i], fz[i]],
                );
            }
        }
    }

    /// Where the samples around voxel `v` start from: the voxel itself at
    /// level 0, its centre in block coordinates (block b's centre at b) in
    /// fixed point above.
    pub fn origin(&self, v: [u16; 3]) -> [i32; 3] {
        if self.level == 0 {
            return v.map(i32::from);
        }
        let s = 1i64 << self.level;
        let one = 1i64 << FIXED;
        v.map(|c| {
            let c = c as i64;
            ((c >> self.level) * one + ((c & (s - 1)) * 2 - (s - 1)) * one / (2 * s)) as i32
        })
    }

    /// The per-sample tables a kernel reads, ring by ring: at level 0 the
    /// lower corner's offset from [`Self::origin`] in voxels and its
    /// fraction; above, the offset in fixed point with 16 fractional bits
    /// (fractions unused). The fourth lane pads to 16 bytes.
    pub fn sample_tables(&self) -> (Vec<[i32; 4]>, Vec<[f32; 4]>) {
        let n = RINGS * SECTORS;
        if self.level > 0 {
            let offsets = (0..n)
                .map(|s| [self.reach[0][s], self.reach[1][s], self.reach[2][s], 0])
                .collect();
            return (offsets, vec![[0.0; 4]; n]);
        }
        (
            (0..n)
                .map(|s| [self.off[0][s], self.off[1][s], self.off[2][s], 0])
                .collect(),
            (0..n)
                .map(|s| [self.frac[0][s], self.frac[1][s], self.frac[2][s], 0.0])
                .collect(),
        )
    }

    /// Level > 0: trilinear interpolation of block occupancy.
    fn sample_blocks(&self, solid: &Solid, v: [u16; 3], out: &mut [f32; RINGS * SECTORS]) {
        let level = solid.level(self.level, Threads::Serial);
        let dims = level.dims();
        let occ = level.occupancy();
        let (row, plane) = (dims[0], dims[0] * dims[1]);
        let one = 1i64 << FIXED;
        let centre = self.origin(v);
        let limit = dims.map(|d| d as u32 - 1);
        let mask = (one - 1) as i32;
        let scale = 1.0 / one as f32;
        let home = centre.map(|c| c >> FIXED);
        let reach = self.cell_reach as i32;
        let inside_xy = spans_xy(home.map(i64::from), self.cell_reach, dims);
        let mut at = [[0i32; CHUNK]; 3];
        let mut frac = [[0.0f32; CHUNK]; 3];
        let mut offset = [0u32; CHUNK];
        // Occupancy of the lower and upper corner along x, as two bytes.
        let mut pairs = [[0u16; CHUNK]; 4];
        for start in (0..out.len()).step_by(CHUNK) {
            for a in 0..3 {
                let reach = &self.reach[a][start..start + CHUNK];
                for i in 0..CHUNK {
                    let q = centre[a] + reach[i];
                    at[a][i] = q >> FIXED;
                    frac[a][i] = (q & mask) as f32 * scale;
                }
            }
            let z = at[2][0];
            let reads = ring_reads(z as i64, limit[2] as i64, inside_xy);
            if reads == RingReads::Unchecked {
                // Offsets from the lowest cell corner the ring can reach.
                let corner = [home[0] - reach, home[1] - reach];
                let first = (z as usize * dims[1] + corner[1] as usize) * row + corner[0] as usize;
                let ring = &occ[first..];
                for i in 0..CHUNK {
                    offset[i] =
                        ((at[1][i] - corner[1]) * row as i32 + (at[0][i] - corner[0])) as u32;
                }
                for i in 0..CHUNK {
                    cell_pairs(&ring[offset[i] as usize..], row, plane, &mut pairs, i);
                }
            } else if reads == RingReads::Empty {
                out[start..start + CHUNK].fill(0.0);
                continue;
            } else {
                for i in 0..CHUNK {
                    pairs_near_border(occ, dims, [at[0][i], at[1][i], z], &mut pairs, i);
                }
            }
            const NORM: f32 = 1.0 / 255.0;
            for i in 0..CHUNK {
                let c =
                    [0, 1, 2, 3].map(|k| [(pairs[k][i] & 0xff) as f32, (pairs[k][i] >> 8) as f32]);
                let c = [
                    c[0][0], c[0][1], c[1][0], c[1][1], c[2][0], c[2][1], c[3][0], c[3][1],
                ];
                out[start + i] = trilinear(c, [frac[0][i], frac[1][i], frac[2][i]]) * NORM;
            }
        }
    }
}

/// How one ring of a sphere (one z: a chunk) reads its cells.
#[derive(Clone, Copy, PartialEq, Eq)]
enum RingReads {
    /// Both planes of its cells lie above or below the grid: all empty.
    Empty,
    /// Inside the grid across x and y and both planes inside: no checks.
    Unchecked,
    /// Crossing a border: every sample checked.
    Checked,
}

/// The reads of a ring whose cells' lower plane is `z`, on a grid whose
/// last plane is `last`, for a sphere whose cells `inside_xy` or not.
fn ring_reads(z: i64, last: i64, inside_xy: bool) -> RingReads {
    if z < -1 || z > last {
        RingReads::Empty
    } else if inside_xy && (0..last).contains(&z) {
        RingReads::Unchecked
    } else {
        RingReads::Checked
    }
}

/// Whether every cell within `reach` of cell `centre` lies inside `dims`
/// across x and y (most spheres: the shared scenes are flat, so it is z
/// where spheres leave the grid, ring by ring).
fn spans_xy(centre: [i64; 3], reach: i64, dims: [usize; 3]) -> bool {
    (0..2).all(|a| centre[a] - reach >= 0 && centre[a] + reach < dims[a] as i64)
}

/// The corner pairs (x, x + 1) of the four rows of the cell starting at
/// `cell[0]`, as sample `i` of `pairs` (one bounds check for all eight).
#[inline(always)]
fn cell_pairs(cell: &[u8], row: usize, plane: usize, pairs: &mut [[u16; CHUNK]; 4], i: usize) {
    let cell = &cell[..plane + row + 2];
    pairs[0][i] = u16::from_le_bytes([cell[0], cell[1]]);
    pairs[1][i] = u16::from_le_bytes([cell[row], cell[row + 1]]);
    pairs[2][i] = u16::from_le_bytes([cell[plane], cell[plane + 1]]);
    pairs[3][i] = u16::from_le_bytes([cell[plane + row], cell[plane + row + 1]]);
}

/// The corner pairs of sample `i` at block `at` of a level with `dims`,
/// checked against the level's bounds (outside reads as empty).
fn pairs_near_border(
    occ: &[u8],
    dims: [usize; 3],
    at: [i32; 3],
    pairs: &mut [[u16; CHUNK]; 4],
    i: usize,
) {
    let (row, plane) = (dims[0], dims[0] * dims[1]);
    let limit = dims.map(|d| d as u32 - 1);
    let [x, y, z] = at;
    // Negative coordinates wrap to large unsigned ones and fail too.
    if (x as u32) < limit[0] && (y as u32) < limit[1] && (z as u32) < limit[2] {
        let b = (z as usize * dims[1] + y as usize) * row + x as usize;
        cell_pairs(&occ[b..], row, plane, pairs, i);
        return;
    }
    for (k, (dy, dz)) in [(0, 0), (1, 0), (0, 1), (1, 1)].into_iter().enumerate() {
        let mut pair = 0u16;
        for dx in 0..2 {
            let (x, y, z) = (x + dx, y + dy, z + dz);
            let inside = x >= 0
                && y >= 0
                && z >= 0
                && x as u32 <= limit[0]
                && y as u32 <= limit[1]
                && z as u32 <= limit[2];
            if inside {
                pair |= (occ[(z as usize * dims[1] + y as usize) * row + x as usize] as u16)
                    << (8 * dx);
            }
        }
        pairs[k][i] = pair;
    }
}

/// The eight corner bits of a sample whose cell crosses the grid's border.
#[cold]
fn corners_near_border(grid: &Grid, x: i64, y: i64, z: i64) -> u32 {
    let mut code = 0u32;
    for (i, (dy, dz)) in [(0, 0), (1, 0), (0, 1), (1, 1)].into_iter().enumerate() {
        for dx in 0..2 {
            if grid.get(x + dx, y + dy, z + dz) {
                code |= 1 << (2 * i as i64 + dx);
            }
        }
    }
    code
}

/// Bits b and b + 1 counted from word `i` (b + 1 may fall in the next word,
/// which always exists: the grid keeps a trailing word).
#[inline]
fn pair(words: &[u64], i: usize, b: u32) -> u32 {
    let v = words[i] as u128 | (words[i + 1] as u128) << 64;
    ((v >> b) & 3) as u32
}

/// Trilinear interpolation of corners ordered (x, x + 1) along x for the
/// rows (y, z), (y + 1, z), (y, z + 1), (y + 1, z + 1).
#[inline(always)]
fn trilinear(c: [f32; 8], f: [f32; 3]) -> f32 {
    let x00 = c[0] + (c[1] - c[0]) * f[0];
    let x10 = c[2] + (c[3] - c[2]) * f[0];
    let x01 = c[4] + (c[5] - c[4]) * f[0];
    let x11 = c[6] + (c[7] - c[6]) * f[0];
    let y0 = x00 + (x10 - x00) * f[1];
    let y1 = x01 + (x11 - x01) * f[1];
    y0 + (y1 - y0) * f[2]
}
