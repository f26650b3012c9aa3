//! The sparse path: a shell's crossings sorted into groups of columns, for
//! blocks too large to hold densely.

use super::Block;
use super::parity::for_each_crossing;
use crate::math::Vec3;
use crate::voxel::grid::AtomicGrid;

/// A shell's block is filled densely when it has at most this many words
/// per axis and (estimated) crossing: sorting a crossing costs about as
/// much as a dozen word operations.
pub(super) const DENSE_WORDS_PER_CROSSING: f64 = 12.0;

/// An open shell whose crossings are sorted is still voted densely when its
/// block has at most this many words per axis and word that some axis
/// calls inside (the sparse vote looks the other two axes up there).
pub(super) const DENSE_WORDS_PER_VOTE: usize = 16;

/// The crossings of a shell along one axis, sorted into groups of columns:
/// the rows (y, z) along x, and along y and z the 64 columns of one x word
/// (at one z, or one y), so that a group's state at a position is one word
/// as in the dense block. Gives the same parity as [`parity_along`].
pub(super) struct Columns {
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
    pub(super) inside_words: usize,
}

impl Columns {
    /// `valid_only`: leave the inside of odd columns out (as the vote does).
    pub(super) fn new(
        axis: usize,
        corners: &[[Vec3; 3]],
        block: &Block,
        valid_only: bool,
    ) -> Columns {
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
    pub(super) fn at(&self, group: u64, position: u32) -> (u64, u64) {
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
    pub(super) fn for_each_inside(
        &self,
        block: &Block,
        mut visit: impl FnMut(usize, usize, usize, u64),
    ) {
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
    pub(super) fn emit_parity(&self, block: &Block, out: &AtomicGrid) {
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
pub(super) fn vote_sparse(columns: &[Columns; 3], block: &Block, out: &AtomicGrid) {
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
