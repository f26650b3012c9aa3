//! The dense path: per-axis parity of a shell's crossings in a block, by
//! watertight rasterization and prefix XOR, and the three-axis vote.

use super::Block;
use crate::math::{Vec3, ceil, floor, max_of, min_of};
use crate::voxel::grid::AtomicGrid;

/// The parity of the crossings along `axis` of every column of `block`:
/// a crossing toggles the voxel where "inside" starts, and a prefix XOR
/// along the axis turns the toggles into parity.
pub(super) fn parity_along(axis: usize, corners: &[[Vec3; 3]], block: &Block) -> Vec<u64> {
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
pub(super) fn for_each_crossing<const AXIS: usize>(
    tri: &[Vec3; 3],
    block: &Block,
    mut toggle: impl FnMut([usize; 3]),
) {
    let (u, v) = ((AXIS + 1) % 3, (AXIS + 2) % 3);
    // Column (cu, cv) runs through (cu + 0.5, cv + 0.5); most triangles of a
    // fine mesh contain no column centre at all, so find that out first.
    let min_u = min_of(min_of(tri[0][u], tri[1][u]), tri[2][u]);
    let max_u = max_of(max_of(tri[0][u], tri[1][u]), tri[2][u]);
    let (u0, u1) = (
        max_of(ceil(min_u - 0.5), block.lo[u] as f64),
        min_of(floor(max_u - 0.5), block.hi[u] as f64),
    );
    if u1 < u0 {
        return;
    }
    let min_v = min_of(min_of(tri[0][v], tri[1][v]), tri[2][v]);
    let max_v = max_of(max_of(tri[0][v], tri[1][v]), tri[2][v]);
    let (v0, v1) = (
        max_of(ceil(min_v - 0.5), block.lo[v] as f64),
        min_of(floor(max_v - 0.5), block.hi[v] as f64),
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
pub(super) const NARROW_ROW: i64 = 8;

/// Twice the signed area of (a, b, c).
pub(super) fn edge(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// The edge function of the directed edge a->b at `c`, when `c` is on its
/// inner side or on the edge and the edge owns its points; `None` otherwise.
///
/// The value is computed from the lexicographically smaller endpoint, so the
/// two triangles sharing an edge see exactly opposite values, and exactly one
/// of the two directions owns points on the edge: together, a point is inside
/// exactly one triangle of a closed fan.
pub(super) fn owned_edge(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> Option<f64> {
    let e = if (a[0], a[1]) < (b[0], b[1]) {
        edge(a, b, c)
    } else {
        -edge(b, a, c)
    };
    let owns = (b[1] < a[1]) || (b[1] == a[1] && b[0] > a[0]);
    (e > 0.0 || (e == 0.0 && owns)).then_some(e)
}

/// Prefix XOR along x within each row: bit x becomes the XOR of bits 0..=x.
pub(super) fn prefix_xor_x(bits: &mut [u64], block: &Block) {
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
pub(super) fn prefix_xor_rows(bits: &mut [u64], words: usize, ny: usize, nz: usize, step: usize) {
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
pub(super) fn vote(parity: &[Vec<u64>], b: &Block, out: &AtomicGrid) {
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
