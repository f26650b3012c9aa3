//! Skin voxels: solid voxels with an empty face neighbour. They are the
//! candidate points of the voxel descriptors: every place the template's
//! centre, a surface point, could be.

use super::grid::{Grid, Rows};
use crate::exec::Threads;

/// One voxel of `skin` (sorted by (z, y, x)) per cube of `spacing`
/// voxels a side: the first in that order. The indices of those kept, in
/// order.
pub fn spaced(skin: &[[u16; 3]], spacing: u16) -> Vec<u32> {
    if spacing <= 1 {
        return (0..skin.len() as u32).collect();
    }
    let s = spacing as usize;
    let cube = Quotient::by(spacing);
    // The quotient grows with the coordinate.
    let cells = |i: usize| skin.iter().map(|v| v[i]).max().map_or(0, |m| cube.of(m)) + 1;
    let (nx, ny) = (cells(0), cells(1));
    // Each column of cubes remembers the last layer of cubes it gave a
    // voxel to (plus one): z never falls along the list.
    let mut taken = vec![0u32; nx * ny];
    let mut kept = Vec::with_capacity(skin.len() / (s * s) + 1);
    for (i, v) in skin.iter().enumerate() {
        let column = cube.of(v[1]) * nx + cube.of(v[0]);
        let layer = cube.of(v[2]) as u32 + 1;
        if taken[column] != layer {
            taken[column] = layer;
            kept.push(i as u32);
        }
    }
    kept
}

/// Division of a voxel coordinate by a fixed divisor as one multiply and
/// shift: a division per coordinate of every skin voxel was half of
/// choosing the candidates. Exact for every 16-bit dividend: with
/// `m = ceil(2^32 / d)`, `m d - 2^32 < d <= 2^16`, so the error stays
/// below one (Granlund and Montgomery, 1994); a test checks every case.
#[derive(Clone, Copy)]
struct Quotient {
    reciprocal: u64,
}

impl Quotient {
    fn by(divisor: u16) -> Quotient {
        let d = u64::from(divisor.max(1));
        Quotient {
            reciprocal: (1u64 << 32).div_ceil(d),
        }
    }

    /// `n / divisor`, rounded down.
    #[inline]
    fn of(self, n: u16) -> usize {
        ((u64::from(n) * self.reciprocal) >> 32) as usize
    }
}

/// The skin of a solid grid (voxels outside the grid count as empty).
pub fn skin(solid: &Grid, backend: Threads) -> Grid {
    let [_, ny, _] = solid.dims();
    let wpr = solid.words_per_row();
    let mut out = vec![0u64; solid.words().len()];
    let rows = solid.rows();
    // Plane by plane, the rows that may hold solid only.
    let plane = ny * wpr;
    let (first, end) = (rows.z[0].min(rows.z[1]), rows.z[1]);
    let empty_row = vec![0u64; wpr];
    backend.for_each_row(&mut out[first * plane..end * plane], plane, |i, out| {
        for y in rows.y[0]..rows.y[1] {
            let out = &mut out[y * wpr..(y + 1) * wpr];
            skin_row(solid, y, first + i, &empty_row, out);
        }
    });
    Grid::from_words(*solid.spec(), out).within(rows)
}

/// The skin of row `(y, z)` of `solid` into `out`, which an empty row
/// leaves as allocated (zero). `empty_row`: a row of zeros.
fn skin_row(solid: &Grid, y: usize, z: usize, empty_row: &[u64], out: &mut [u64]) {
    let [_, ny, nz] = solid.dims();
    let wpr = solid.words_per_row();
    let words = solid.words();
    let row = |y: usize, z: usize| -> &[u64] { &words[solid.row_start(y, z)..][..wpr] };
    let cur = row(y, z);
    if cur.iter().all(|&w| w == 0) {
        // Most rows of a padded part's grid are empty, and writing their
        // zeros was most of the work.
        return;
    }
    let ym = if y > 0 { row(y - 1, z) } else { empty_row };
    let yp = if y + 1 < ny { row(y + 1, z) } else { empty_row };
    let zm = if z > 0 { row(y, z - 1) } else { empty_row };
    let zp = if z + 1 < nz { row(y, z + 1) } else { empty_row };
    for k in 0..wpr {
        let w = cur[k];
        let prev = if k > 0 { cur[k - 1] } else { 0 };
        let next = if k + 1 < wpr { cur[k + 1] } else { 0 };
        let xm = (w << 1) | (prev >> 63);
        let xp = (w >> 1) | (next << 63);
        let enclosed = xm & xp & ym[k] & yp[k] & zm[k] & zp[k];
        out[k] = w & !enclosed;
    }
}

/// The grid grown by one voxel in every direction (the 3 x 3 x 3
/// neighbourhood of each set voxel): "within a voxel of the surface" becomes
/// a single bit test.
pub fn dilate(grid: &Grid, backend: Threads) -> Grid {
    let [nx, ny, nz] = grid.dims();
    let wpr = grid.words_per_row();
    let words = grid.words();
    let rows = ny * nz;
    // Bits past nx stay clear.
    let last_word = if nx % 64 != 0 {
        (1u64 << (nx % 64)) - 1
    } else {
        !0
    };
    // Word k of row r grown along x: OR with the neighbours one bit to
    // each side.
    let along_x = |r: usize, k: usize| {
        let s = r * wpr;
        let w = words[s + k];
        let prev = if k > 0 { words[s + k - 1] } else { 0 };
        let next = if k + 1 < wpr { words[s + k + 1] } else { 0 };
        let grown = w | (w << 1) | (prev >> 63) | (w >> 1) | (next << 63);
        if k + 1 == wpr {
            grown & last_word
        } else {
            grown
        }
    };
    // Set voxels lie in `held`; the grown ones in its neighbours, and
    // along x and y in `flat`.
    let held = grid.rows();
    let grown_rows = held.grown(grid.dims());
    let flat = Rows {
        y: grown_rows.y,
        z: held.z,
    };
    // Along x and y in one pass: the grown rows y - 1, y and y + 1.
    let mut along_xy = vec![0u64; words.len()];
    backend.for_each_row(&mut along_xy, wpr, |r, out| {
        if r >= rows || !flat.holds(r % ny, r / ny) {
            return;
        }
        let y = r % ny;
        for (k, o) in out.iter_mut().enumerate() {
            let mut w = along_x(r, k);
            if y > 0 {
                w |= along_x(r - 1, k);
            }
            if y + 1 < ny {
                w |= along_x(r + 1, k);
            }
            *o = w;
        }
    });
    // Along z: OR of neighbouring planes.
    let plane = ny * wpr;
    let mut grown = vec![0u64; words.len()];
    backend.for_each_row(&mut grown, wpr, |r, out| {
        if r >= rows || !grown_rows.holds(r % ny, r / ny) {
            return;
        }
        let (z, s) = (r / ny, r * wpr);
        for (k, o) in out.iter_mut().enumerate() {
            let mut w = along_xy[s + k];
            if z > 0 {
                w |= along_xy[s + k - plane];
            }
            if z + 1 < nz {
                w |= along_xy[s + k + plane];
            }
            *o = w;
        }
    });
    Grid::from_words(*grid.spec(), grown).within(grown_rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quotient_by_multiplying_is_the_division() {
        for d in (1..=300u16).chain([1000, 4097, 32768, 65535]) {
            let q = Quotient::by(d);
            for n in 0..=u16::MAX {
                assert_eq!(q.of(n), usize::from(n / d), "{n} / {d}");
            }
        }
    }
    use crate::math::Vec3;
    use crate::voxel::GridSpec;

    #[test]
    fn dilation_covers_the_neighbourhood_and_nothing_more() {
        let spec = GridSpec {
            origin: Vec3::ZERO,
            voxel_size: 1.0,
            dims: [70, 5, 5],
        };
        let mut g = Grid::new(spec);
        g.set(63, 2, 2);
        g.set(0, 0, 0);
        for backend in [Threads::Serial, Threads::Parallel] {
            let d = dilate(&g, backend);
            let mut n = 0;
            for z in 0..5 {
                for y in 0..5 {
                    for x in 0..70 {
                        let near = |c: [i64; 3]| {
                            (x - c[0]).abs() <= 1 && (y - c[1]).abs() <= 1 && (z - c[2]).abs() <= 1
                        };
                        let want = near([63, 2, 2]) || near([0, 0, 0]);
                        assert_eq!(d.get(x, y, z), want, "{x} {y} {z}");
                        n += want as u64;
                    }
                }
            }
            assert_eq!(d.count_ones(), n);
        }
    }
}
