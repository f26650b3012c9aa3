//! The bit-packed voxel grid and its placement in world space.

use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Error, Result};
use crate::math::{Aabb, Vec3};

/// Empty voxels kept around the content on every side, so that every skin
/// voxel has an in-grid empty neighbour and every fill column starts and ends
/// outside.
pub const PADDING: usize = 1;

/// Where a grid sits in world space: cubic voxels of `voxel_size`, voxel
/// `(0, 0, 0)` with its lowest corner at `origin`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridSpec {
    /// World position of the lowest corner of voxel (0, 0, 0).
    pub origin: Vec3,
    /// Edge length of a voxel in world units.
    pub voxel_size: f64,
    /// Voxels along x, y and z.
    pub dims: [usize; 3],
}

impl GridSpec {
    /// The grid for a scene: `resolution` voxels along the longest side of
    /// `bounds`, plus [`PADDING`] on every side.
    pub fn for_scene(bounds: Aabb, resolution: u32) -> Result<GridSpec> {
        if !(8..=16384).contains(&resolution) {
            return Err(Error::invalid_option(
                "resolution",
                format!("{resolution} is outside 8..=16384"),
            ));
        }
        let longest = bounds.extent().max_element();
        if longest <= 0.0 || !longest.is_finite() {
            return Err(Error::invalid_option(
                "resolution",
                "the scene has no extent (all its vertices coincide)",
            ));
        }
        GridSpec::around(bounds, longest / resolution as f64)
    }

    /// The grid with voxels of `voxel_size` that holds `bounds` plus padding
    /// (templates use the scene's voxel size so that radii agree). Fails when
    /// a side would need more voxels than a voxel coordinate (u16) holds.
    pub(crate) fn around(bounds: Aabb, voxel_size: f64) -> Result<GridSpec> {
        let sides = Self::sides(bounds, voxel_size);
        let ext = bounds.extent();
        if !sides.iter().all(|s| (1.0..=u16::MAX as f64).contains(s)) {
            return Err(Error::GridTooLarge {
                // `as` saturates: NaN reads 0, anything past u64 reads u64::MAX.
                dims: sides.map(|s| s as u64),
                advice: format!(
                    "the voxels ({voxel_size:e} wide) are too small for a box of {:e} x {:e} x {:e}",
                    ext.x, ext.y, ext.z
                ),
            });
        }
        Ok(GridSpec::unchecked(bounds, voxel_size, sides))
    }

    /// As [`GridSpec::around`], with no limit on a side: a lattice that is
    /// only ever allocated in crops (a search's, refined for a small
    /// template over a large scene).
    pub fn lattice(bounds: Aabb, voxel_size: f64) -> GridSpec {
        GridSpec::unchecked(bounds, voxel_size, Self::sides(bounds, voxel_size))
    }

    /// Voxels along each side of the grid around `bounds`, in f64 (which
    /// cannot wrap): floor + 1, so that a vertex exactly on the far face
    /// lands in a voxel of its own and the padding still follows it.
    fn sides(bounds: Aabb, voxel_size: f64) -> [f64; 3] {
        let ext = bounds.extent();
        [ext.x, ext.y, ext.z].map(|e| (e / voxel_size).floor() + 1.0 + 2.0 * PADDING as f64)
    }

    fn unchecked(bounds: Aabb, voxel_size: f64, sides: [f64; 3]) -> GridSpec {
        let pad = PADDING as f64 * voxel_size;
        GridSpec {
            origin: bounds.min - Vec3::new(pad, pad, pad),
            voxel_size,
            dims: sides.map(|s| s as usize),
        }
    }

    /// The grid on this one's lattice that holds `bounds` with `pad` empty
    /// voxels on every side (at least [`PADDING`]); it may reach past this
    /// grid. A part's voxels are then those of the whole, and balls around
    /// its surface stay inside its grid. Fails like [`GridSpec::around`].
    pub fn crop(&self, bounds: Aabb, pad: usize) -> Result<GridSpec> {
        let low = self.to_grid(bounds.min);
        let high = self.to_grid(bounds.max);
        let pad = pad.max(PADDING) as f64;
        let first = [0, 1, 2].map(|a| low[a].floor() - pad);
        let sides = [0, 1, 2].map(|a| high[a].floor() + pad - first[a] + 1.0);
        if !sides.iter().all(|s| (1.0..=u16::MAX as f64).contains(s)) {
            return Err(Error::GridTooLarge {
                dims: sides.map(|s| s as u64),
                advice: format!(
                    "a part needs more than {} voxels along a side at voxels {:e} wide: lower the resolution",
                    u16::MAX,
                    self.voxel_size
                ),
            });
        }
        Ok(GridSpec {
            origin: self.origin + Vec3::new(first[0], first[1], first[2]) * self.voxel_size,
            voxel_size: self.voxel_size,
            dims: sides.map(|s| s as usize),
        })
    }

    /// Number of voxels.
    pub fn voxel_count(&self) -> u64 {
        self.dims.iter().map(|&d| d as u64).product()
    }

    /// Bytes of one bit grid of this size (rows padded to 64 bits).
    pub fn grid_bytes(&self) -> u64 {
        self.dims[0].div_ceil(64) as u64 * 8 * self.dims[1] as u64 * self.dims[2] as u64
    }

    /// A world point in grid units (voxel `i` spans `[i, i + 1)`).
    pub fn to_grid(self, p: Vec3) -> Vec3 {
        (p - self.origin) * (1.0 / self.voxel_size)
    }

    /// World position of the centre of voxel `v`.
    pub fn center(&self, v: [u16; 3]) -> Vec3 {
        self.origin
            + Vec3::new(v[0] as f64 + 0.5, v[1] as f64 + 0.5, v[2] as f64 + 0.5) * self.voxel_size
    }

    /// The voxel holding world point `p` (any integers: [`Grid::get`] is
    /// false outside).
    pub fn voxel_of(&self, p: Vec3) -> [i64; 3] {
        ((p - self.origin) / self.voxel_size)
            .floor()
            .to_array()
            .map(|c| c as i64)
    }
}

/// The rows `(y, z)` of a grid that may hold set voxels: `y[0]..y[1]` and
/// `z[0]..z[1]`. A part's grid is padded by the template's radius on every
/// side, so most of its rows are empty; the passes over a whole grid (the
/// union, the skin, the pyramid's first level, counting and listing)
/// leave the others unread, as reading them was most of their work.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Rows {
    /// Rows `y[0]..y[1]` along y.
    pub y: [usize; 2],
    /// Planes `z[0]..z[1]` along z.
    pub z: [usize; 2],
}

impl Rows {
    /// Every row of a grid of `dims`.
    pub(crate) fn all(dims: [usize; 3]) -> Rows {
        Rows {
            y: [0, dims[1]],
            z: [0, dims[2]],
        }
    }

    /// No row.
    pub(crate) const NONE: Rows = Rows {
        y: [0, 0],
        z: [0, 0],
    };

    /// The rows of the voxels holding points `lo..=hi` (y and z, in grid
    /// units), within a grid of `dims`.
    pub(crate) fn around(lo: [f64; 2], hi: [f64; 2], dims: [usize; 3]) -> Rows {
        let first = |v: f64| v.floor().max(0.0);
        let end = |v: f64, n: usize| (v.floor() + 1.0).clamp(0.0, n as f64);
        let (y0, z0) = (first(lo[0]) as usize, first(lo[1]) as usize);
        let (y1, z1) = (end(hi[0], dims[1]) as usize, end(hi[1], dims[2]) as usize);
        match y0 < y1 && z0 < z1 {
            true => Rows {
                y: [y0, y1],
                z: [z0, z1],
            },
            false => Rows::NONE,
        }
    }

    /// Whether it holds no row.
    pub(crate) fn is_empty(&self) -> bool {
        self.y[0] >= self.y[1] || self.z[0] >= self.z[1]
    }

    /// Whether row `(y, z)` is one of them.
    pub(crate) fn holds(&self, y: usize, z: usize) -> bool {
        (self.y[0]..self.y[1]).contains(&y) && (self.z[0]..self.z[1]).contains(&z)
    }

    /// The smallest rows holding both.
    pub(crate) fn union(self, other: Rows) -> Rows {
        match (self.is_empty(), other.is_empty()) {
            (true, _) => other,
            (_, true) => self,
            _ => Rows {
                y: [self.y[0].min(other.y[0]), self.y[1].max(other.y[1])],
                z: [self.z[0].min(other.z[0]), self.z[1].max(other.z[1])],
            },
        }
    }

    /// The rows both hold.
    pub(crate) fn intersection(self, other: Rows) -> Rows {
        let y = [self.y[0].max(other.y[0]), self.y[1].min(other.y[1])];
        let z = [self.z[0].max(other.z[0]), self.z[1].min(other.z[1])];
        match y[0] < y[1] && z[0] < z[1] {
            true => Rows { y, z },
            false => Rows::NONE,
        }
    }

    /// These rows and their neighbours, within a grid of `dims`.
    pub(crate) fn grown(self, dims: [usize; 3]) -> Rows {
        match self.is_empty() {
            true => self,
            false => Rows {
                y: [self.y[0].saturating_sub(1), (self.y[1] + 1).min(dims[1])],
                z: [self.z[0].saturating_sub(1), (self.z[1] + 1).min(dims[2])],
            },
        }
    }

    /// The rows of blocks of 2 x 2 voxels that hold these rows.
    pub(crate) fn halved(self) -> Rows {
        match self.is_empty() {
            true => self,
            false => Rows {
                y: [self.y[0] / 2, self.y[1].div_ceil(2)],
                z: [self.z[0] / 2, self.z[1].div_ceil(2)],
            },
        }
    }
}

/// A bit per voxel, rows along x packed into 64-bit words.
///
/// Word `w` of row `(y, z)` is at `(z * ny + y) * words_per_row + w`; bits past
/// `nx` in a row's last word stay zero. A trailing zero word lets readers
/// fetch two consecutive words without a bounds check at the very end.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    spec: GridSpec,
    words_per_row: usize,
    words: Vec<u64>,
    /// Every set voxel lies in these rows.
    rows: Rows,
}

impl Grid {
    /// An empty grid.
    pub fn new(spec: GridSpec) -> Grid {
        let words_per_row = spec.dims[0].div_ceil(64);
        Grid {
            spec,
            words_per_row,
            words: vec![0; words_per_row * spec.dims[1] * spec.dims[2] + 1],
            rows: Rows::all(spec.dims),
        }
    }

    /// Wraps words laid out as [`Grid`] describes (used by parallel builders).
    pub(crate) fn from_words(spec: GridSpec, words: Vec<u64>) -> Grid {
        let words_per_row = spec.dims[0].div_ceil(64);
        debug_assert_eq!(words.len(), words_per_row * spec.dims[1] * spec.dims[2] + 1);
        Grid {
            spec,
            words_per_row,
            words,
            rows: Rows::all(spec.dims),
        }
    }

    /// The rows that may hold set voxels.
    pub(crate) fn rows(&self) -> Rows {
        self.rows
    }

    /// This grid, known to hold set voxels in `rows` only (checked in
    /// debug builds).
    pub(crate) fn within(mut self, rows: Rows) -> Grid {
        let rows = rows.intersection(self.rows);
        debug_assert!(
            (0..self.spec.dims[2]).all(|z| (0..self.spec.dims[1])
                .all(|y| rows.holds(y, z) || self.row(y, z).iter().all(|&w| w == 0))),
            "set voxels outside {rows:?}"
        );
        self.rows = rows;
        self
    }

    /// The word ranges of the rows that may hold set voxels: one run of
    /// rows per plane.
    pub(crate) fn row_runs(&self) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
        let rows = self.rows;
        (rows.z[0]..rows.z[1])
            .filter(move |_| !rows.is_empty())
            .map(move |z| self.row_start(rows.y[0], z)..self.row_start(rows.y[1], z))
    }

    /// Placement in world space.
    pub fn spec(&self) -> &GridSpec {
        &self.spec
    }

    /// Voxels along x, y, z.
    pub fn dims(&self) -> [usize; 3] {
        self.spec.dims
    }

    /// 64-bit words per row.
    pub fn words_per_row(&self) -> usize {
        self.words_per_row
    }

    /// All words (rows in z-major, then y order), plus one trailing zero word.
    pub fn words(&self) -> &[u64] {
        &self.words
    }

    /// Mutable words; callers must keep the bits past `nx` zero, and set
    /// none outside [`Grid::rows`].
    pub(crate) fn words_mut(&mut self) -> &mut [u64] {
        &mut self.words
    }

    /// The rows that may hold set voxels from now on: `rows` too.
    pub(crate) fn widen_rows(&mut self, rows: Rows) {
        self.rows = self.rows.union(rows);
    }

    /// Index of the first word of row `(y, z)`.
    pub fn row_start(&self, y: usize, z: usize) -> usize {
        (z * self.spec.dims[1] + y) * self.words_per_row
    }

    /// The words of row `(y, z)`.
    pub fn row(&self, y: usize, z: usize) -> &[u64] {
        let s = self.row_start(y, z);
        &self.words[s..s + self.words_per_row]
    }

    /// Whether voxel `(x, y, z)` is set; out-of-grid voxels read as empty.
    pub fn get(&self, x: i64, y: i64, z: i64) -> bool {
        let [nx, ny, nz] = self.spec.dims.map(|d| d as i64);
        if x < 0 || y < 0 || z < 0 || x >= nx || y >= ny || z >= nz {
            return false;
        }
        let w = self.words[self.row_start(y as usize, z as usize) + (x as usize >> 6)];
        (w >> (x & 63)) & 1 == 1
    }

    /// Sets voxel `(x, y, z)`, which must be inside the grid.
    pub fn set(&mut self, x: usize, y: usize, z: usize) {
        let i = self.row_start(y, z) + (x >> 6);
        self.words[i] |= 1 << (x & 63);
        if !self.rows.holds(y, z) {
            self.rows = self.rows.union(Rows {
                y: [y, y + 1],
                z: [z, z + 1],
            });
        }
    }

    /// Number of set voxels.
    pub fn count_ones(&self) -> u64 {
        self.row_runs()
            .map(|run| {
                self.words[run]
                    .iter()
                    .map(|w| w.count_ones() as u64)
                    .sum::<u64>()
            })
            .sum()
    }

    /// Every set voxel, in z, y, x order.
    pub fn iter_ones(&self) -> impl Iterator<Item = [u16; 3]> + '_ {
        self.row_runs().flat_map(|run| Ones {
            words: &self.words[..run.end],
            words_per_row: self.words_per_row,
            ny: self.spec.dims[1],
            next: run.start,
            bits: 0,
            at: [0; 3],
        })
    }
}

/// The set voxels of a grid's words, word by word: a word's place is worked
/// out once for all its bits, and empty words (most of a padded part's grid)
/// cost one test each.
struct Ones<'a> {
    words: &'a [u64],
    words_per_row: usize,
    ny: usize,
    /// The word after the one whose bits are left.
    next: usize,
    bits: u64,
    /// The voxel of bit 0 of that word.
    at: [u16; 3],
}

impl Iterator for Ones<'_> {
    type Item = [u16; 3];

    #[inline]
    fn next(&mut self) -> Option<[u16; 3]> {
        while self.bits == 0 {
            let w = *self.words.get(self.next)?;
            if w != 0 {
                let row = self.next / self.words_per_row;
                let x = (self.next % self.words_per_row) * 64;
                self.at = [x as u16, (row % self.ny) as u16, (row / self.ny) as u16];
                self.bits = w;
            }
            self.next += 1;
        }
        let b = self.bits.trailing_zeros() as u16;
        self.bits &= self.bits - 1;
        Some([self.at[0] + b, self.at[1], self.at[2]])
    }
}

/// A grid that several threads set bits in at once; OR is order-independent,
/// so the result does not depend on scheduling.
pub(crate) struct AtomicGrid {
    spec: GridSpec,
    words_per_row: usize,
    words: Vec<AtomicU64>,
}

impl AtomicGrid {
    pub(crate) fn new(spec: GridSpec) -> AtomicGrid {
        let words_per_row = spec.dims[0].div_ceil(64);
        let n = words_per_row * spec.dims[1] * spec.dims[2] + 1;
        AtomicGrid {
            spec,
            words_per_row,
            words: (0..n).map(|_| AtomicU64::new(0)).collect(),
        }
    }

    /// Sets voxel `(x, y, z)`, which must be inside the grid.
    pub(crate) fn set(&self, x: usize, y: usize, z: usize) {
        let i = (z * self.spec.dims[1] + y) * self.words_per_row + (x >> 6);
        let bit = 1u64 << (x & 63);
        // Neighbouring triangles hit the same voxels: a plain load avoids most
        // read-modify-write traffic.
        if self.words[i].load(Ordering::Relaxed) & bit == 0 {
            self.words[i].fetch_or(bit, Ordering::Relaxed);
        }
    }

    /// ORs `bits` into word `word` of row `(y, z)`.
    pub(crate) fn or_word(&self, word: usize, y: usize, z: usize, bits: u64) {
        if bits != 0 {
            let i = (z * self.spec.dims[1] + y) * self.words_per_row + word;
            self.words[i].fetch_or(bits, Ordering::Relaxed);
        }
    }

    pub(crate) fn into_grid(self) -> Grid {
        Grid::from_words(
            self.spec,
            self.words.into_iter().map(AtomicU64::into_inner).collect(),
        )
    }
}

/// Positions of the set bits of a word, lowest first.
#[cfg(test)]
mod tests {
    use super::*;

    fn spec(dims: [usize; 3]) -> GridSpec {
        GridSpec {
            origin: Vec3::ZERO,
            voxel_size: 1.0,
            dims,
        }
    }

    #[test]
    fn set_get_count_and_iterate() {
        let mut g = Grid::new(spec([70, 3, 2]));
        for v in [[0, 0, 0], [63, 1, 0], [64, 1, 0], [69, 2, 1]] {
            g.set(v[0], v[1], v[2]);
        }
        assert!(g.get(63, 1, 0) && g.get(64, 1, 0) && g.get(69, 2, 1));
        assert!(!g.get(62, 1, 0) && !g.get(-1, 0, 0) && !g.get(70, 2, 1));
        assert_eq!(g.count_ones(), 4);
        let ones: Vec<_> = g.iter_ones().collect();
        assert_eq!(ones, vec![[0, 0, 0], [63, 1, 0], [64, 1, 0], [69, 2, 1]]);
    }

    #[test]
    fn iterating_finds_every_set_voxel_in_order() {
        let dims = [130, 7, 5];
        let mut g = Grid::new(spec(dims));
        let mut s: u64 = 99;
        let mut want = Vec::new();
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    s ^= s << 13;
                    s ^= s >> 7;
                    s ^= s << 17;
                    // Dense rows, empty rows and the last voxel.
                    let keep = (y != 3 && s.is_multiple_of(5)) || [x, y, z] == [129, 6, 4];
                    if keep {
                        g.set(x, y, z);
                        want.push([x as u16, y as u16, z as u16]);
                    }
                }
            }
        }
        assert_eq!(g.iter_ones().collect::<Vec<_>>(), want);
    }

    #[test]
    fn scene_spec_puts_resolution_voxels_on_the_longest_side() {
        let b = Aabb {
            min: Vec3::new(-1.0, 0.0, 0.0),
            max: Vec3::new(3.0, 1.0, 2.0),
        };
        let s = GridSpec::for_scene(b, 100).unwrap();
        assert!((s.voxel_size - 0.04).abs() < 1e-12);
        assert_eq!(s.dims, [103, 28, 53]);
        assert!(GridSpec::for_scene(b, 4).is_err());
    }

    #[test]
    fn a_grid_too_large_for_u16_coordinates_is_an_error_not_a_wrap() {
        let b = |e: f64| Aabb {
            min: Vec3::ZERO,
            max: Vec3::new(e, 1.0, 1.0),
        };
        assert!(GridSpec::around(b(70000.0), 1.0).is_err());
        assert!(GridSpec::around(b(1e30), 1.0).is_err());
        assert!(GridSpec::around(b(f64::INFINITY), 1.0).is_err());
        assert!(GridSpec::around(b(1.0), 0.0).is_err());
        assert_eq!(GridSpec::around(b(65000.0), 2.0).unwrap().dims[0], 32503);
    }
}
