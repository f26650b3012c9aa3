//! Voxelization: the scene as a solid bit grid, and its skin.
//!
//! The solid is the union of the surface voxels (every voxel a triangle
//! touches, so thin parts and open sheets survive) and the filled interior of
//! every shell (voxels whose centre is inside). The skin, the solid voxels
//! with an empty face neighbour, is the set of candidate points.

mod ball;
mod estimate;
mod fill;
mod grid;
mod pyramid;
mod skin;
mod surface;
mod window;

pub use ball::{Ball, BallMoment};
pub(crate) use estimate::{ball_bytes, part_voxel_work, voxel_bytes, voxel_work};
pub use fill::fill_solid;
pub(crate) use grid::AtomicGrid;
pub use grid::{Grid, GridSpec, PADDING};
pub use pyramid::{CountLevel, MAX_LEVEL, Solid, level_for_radius};
pub use skin::{dilate, skin, spaced};
pub use surface::voxelize_surface;
pub use window::WindowedMesh;

use crate::exec::Threads;
use crate::mesh::TriMesh;

/// The solid voxels of a mesh: its surface voxels and its filled interior.
pub fn voxelize(mesh: &TriMesh, spec: &GridSpec, backend: Threads) -> Grid {
    // Finding shells is partly serial: it overlaps the surface pass.
    let (solid, interior) = backend.join(
        || voxelize_surface(mesh, spec, backend),
        || fill_solid(mesh, spec, backend),
    );
    union(solid, &interior)
}

/// The solid: the surface voxels with the filled interior.
fn union(mut surface: Grid, interior: &Grid) -> Grid {
    surface.widen_rows(interior.rows());
    let words = surface.words_mut();
    for run in interior.row_runs() {
        for (s, i) in words[run.clone()].iter_mut().zip(&interior.words()[run]) {
            *s |= i;
        }
    }
    surface
}

#[cfg(test)]
mod tests;
