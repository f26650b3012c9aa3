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
