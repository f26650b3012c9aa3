//! Skin voxels: solid voxels with an empty face neighbour. They are the
//! candidate points of the voxel descriptors: every place the template's
//! centre, a surface point, could be.

use super::grid::Grid;

/// The skin of a solid grid (voxels outside the grid count as empty).
pub fn skin(solid: &Grid) -> Grid {
    let [_, ny, nz] = solid.dims();
    let wpr = solid.words_per_row();
    let mut out = solid.clone();
    let words = solid.words();
    let empty_row = vec![0u64; wpr];
    let row = |y: usize, z: usize| -> &[u64] {
        let s = solid.row_start(y, z);
        &words[s..s + wpr]
    };
    for z in 0..nz {
        for y in 0..ny {
            let cur = row(y, z);
            let ym = if y > 0 { row(y - 1, z) } else { &empty_row };
            let yp = if y + 1 < ny {
                row(y + 1, z)
            } else {
                &empty_row
            };
            let zm = if z > 0 { row(y, z - 1) } else { &empty_row };
            let zp = if z + 1 < nz {
                row(y, z + 1)
            } else {
                &empty_row
            };
            let start = solid.row_start(y, z);
            for k in 0..wpr {
                let w = cur[k];
                if w == 0 {
                    continue;
                }
                let prev = if k > 0 { cur[k - 1] } else { 0 };
                let next = if k + 1 < wpr { cur[k + 1] } else { 0 };
                let xm = (w << 1) | (prev >> 63);
                let xp = (w >> 1) | (next << 63);
                let enclosed = xm & xp & ym[k] & yp[k] & zm[k] & zp[k];
                out.words_mut()[start + k] = w & !enclosed;
            }
        }
    }
    out
}

/// The grid grown by one voxel in every direction (the 3 x 3 x 3
/// neighbourhood of each set voxel): "within a voxel of the surface" becomes
/// a single bit test.
pub fn dilate(grid: &Grid) -> Grid {
    let [nx, ny, nz] = grid.dims();
    let wpr = grid.words_per_row();
    let words = grid.words();
    // Along x: OR with the neighbours one bit to each side.
    let mut along_x = vec![0u64; words.len()];
    for r in 0..ny * nz {
        let s = r * wpr;
        for k in 0..wpr {
            let w = words[s + k];
            let prev = if k > 0 { words[s + k - 1] } else { 0 };
            let next = if k + 1 < wpr { words[s + k + 1] } else { 0 };
            along_x[s + k] = w | (w << 1) | (prev >> 63) | (w >> 1) | (next << 63);
        }
        // Keep the bits past nx clear.
        if nx % 64 != 0 {
            along_x[s + wpr - 1] &= (1u64 << (nx % 64)) - 1;
        }
    }
    // Along y, then z: OR of neighbouring rows.
    let mut along_y = along_x.clone();
    for z in 0..nz {
        for y in 0..ny {
            let s = (z * ny + y) * wpr;
            for k in 0..wpr {
                let mut w = along_x[s + k];
                if y > 0 {
                    w |= along_x[s - wpr + k];
                }
                if y + 1 < ny {
                    w |= along_x[s + wpr + k];
                }
                along_y[s + k] = w;
            }
        }
    }
    let plane = ny * wpr;
    let mut out = along_y.clone();
    for z in 0..nz {
        for i in z * plane..(z + 1) * plane {
            let mut w = along_y[i];
            if z > 0 {
                w |= along_y[i - plane];
            }
            if z + 1 < nz {
                w |= along_y[i + plane];
            }
            out[i] = w;
        }
    }
    Grid::from_words(*grid.spec(), out)
}

#[cfg(test)]
mod tests {
    use super::*;
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
        let d = dilate(&g);
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
