//! Windows: a part too large for one dense grid, voxelized a box at a time.
//!
//! A window is a crop of the part's lattice. Its voxels are those of the
//! whole part's grid, except on its outermost layer: the fill's columns
//! count every crossing of the whole shell (those before the window toggle
//! its first voxel, those past it its last), and the surface pass marks
//! what a triangle reaching past the window overhangs on the border. So a
//! window is padded by more than anything reads around its core, and only
//! the core's skin voxels are candidates. Dense grids keep the readers
//! (pyramid, balls, spheres) as they are: a window costs its padding, and
//! the memory of a search no longer grows with the largest part's box.

use super::fill::{Shell, fill_shells, shells};
use super::grid::{Grid, GridSpec};
use super::surface::voxelize_triangles;
use crate::exec::Threads;
use crate::math::{Aabb, Vec3};
use crate::mesh::TriMesh;

/// A part's mesh with its shells, found once for all its windows: a shell
/// cut by a window must keep the closedness of the whole.
pub struct WindowedMesh {
    mesh: TriMesh,
    shells: Vec<Shell>,
    boxes: Vec<Aabb>,
}

impl WindowedMesh {
    /// Splits `mesh` (one part) into shells and boxes its triangles.
    pub fn new(mesh: TriMesh, backend: Threads) -> WindowedMesh {
        let shells = shells(&mesh, backend);
        let boxes = (0..mesh.triangles().len())
            .map(|t| {
                let [a, b, c] = mesh.corners(t);
                Aabb {
                    min: a.min(b).min(c),
                    max: a.max(b).max(c),
                }
            })
            .collect();
        WindowedMesh {
            mesh,
            shells,
            boxes,
        }
    }

    /// Bytes it holds: the mesh, its shells and its triangles' boxes.
    pub fn bytes(&self) -> u64 {
        let triangles = self.mesh.triangles().len() as u64;
        12 * self.mesh.positions().len() as u64 + (12 + 4 + 48) * triangles
    }

    /// The box of the triangles whose boxes meet `bounds`, or `None` when
    /// none does.
    pub fn content_in(&self, bounds: &Aabb) -> Option<Aabb> {
        self.boxes
            .iter()
            .filter(|b| overlapping_axes(b, bounds) == 3)
            .fold(None, |acc: Option<Aabb>, b| {
                Some(acc.map_or(*b, |a| Aabb {
                    min: a.min.min(b.min),
                    max: a.max.max(b.max),
                }))
            })
    }

    /// The solid voxels of the window `spec`, equal to the whole part's off
    /// its outermost layer.
    pub fn voxelize(&self, spec: &GridSpec, backend: Threads) -> Grid {
        let bounds = Aabb {
            min: spec.origin,
            max: spec.origin
                + Vec3::new(
                    spec.dims[0] as f64,
                    spec.dims[1] as f64,
                    spec.dims[2] as f64,
                ) * spec.voxel_size,
        };
        // A column along an axis crosses only triangles whose box overlaps
        // the window on the two other axes; the surface pass needs all three.
        let overlaps: Vec<u8> = self
            .boxes
            .iter()
            .map(|b| overlapping_axes(b, &bounds))
            .collect();
        let crossing: Vec<Shell> = self
            .shells
            .iter()
            .map(|s| Shell {
                triangles: s
                    .triangles
                    .iter()
                    .copied()
                    .filter(|&t| overlaps[t as usize] >= 2)
                    .collect(),
                closed: s.closed,
                one_sided: s.one_sided,
            })
            .collect();
        let touching: Vec<u32> = (0..overlaps.len() as u32)
            .filter(|&t| overlaps[t as usize] == 3)
            .collect();
        let (solid, interior) = backend.join(
            || voxelize_triangles(&self.mesh, &touching, spec, backend),
            || fill_shells(&self.mesh, &crossing, spec, backend),
        );
        super::union(solid, &interior)
    }
}

/// On how many axes the boxes' ranges meet.
fn overlapping_axes(a: &Aabb, b: &Aabb) -> u8 {
    (0..3)
        .map(|k| u8::from(a.min[k] <= b.max[k] && a.max[k] >= b.min[k]))
        .sum()
}
