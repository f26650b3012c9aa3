//! A part's voxels for one search: its solid with the count pyramid, its
//! skin voxels (the candidates) and the voxels near its surface.

use std::sync::OnceLock;

use crate::clock::now_ms;
use crate::exec::{Threads, made_once};
use crate::math::Vec3;
use crate::mesh::TriMesh;
use crate::voxel::{Grid, GridSpec, Solid, WindowedMesh, dilate, skin, voxelize};

/// A part's solid and skin voxels, built for one search.
pub struct PartVoxels {
    solid: Solid,
    skin: Vec<[u16; 3]>,
    /// The skin as a bit grid, kept to grow `near_surface` from.
    skin_grid: Grid,
    /// Grown only where a survivor is verified: on a building of distinct
    /// parts most parts have none, and growing every part's skin was a
    /// tenth of the search.
    near_surface: OnceLock<Grid>,
    backend: Threads,
    pub(super) voxelize_ms: f64,
}

impl PartVoxels {
    /// Voxelizes `mesh` on `spec`: its solid, skin and the voxels near its
    /// surface.
    pub(crate) fn build(mesh: &TriMesh, spec: &GridSpec, backend: Threads) -> PartVoxels {
        let start = now_ms();
        let grid = voxelize(mesh, spec, backend);
        PartVoxels::from_solid(grid, start, backend)
    }

    /// Voxelizes the window `spec` of a part too large for one grid: equal
    /// to the whole part's voxels off the window's outermost layer.
    pub(crate) fn build_window(
        mesh: &WindowedMesh,
        spec: &GridSpec,
        backend: Threads,
    ) -> PartVoxels {
        let start = now_ms();
        let grid = mesh.voxelize(spec, backend);
        PartVoxels::from_solid(grid, start, backend)
    }

    fn from_solid(grid: Grid, start: f64, backend: Threads) -> PartVoxels {
        let skin_grid = skin(&grid, backend);
        // Sized exactly: a messy part's skin can run to tens of millions of
        // voxels, and doubling would take twice that.
        let mut skin = Vec::with_capacity(skin_grid.count_ones() as usize);
        skin.extend(skin_grid.iter_ones());
        PartVoxels {
            solid: Solid::new(grid),
            skin,
            skin_grid,
            near_surface: OnceLock::new(),
            backend,
            voxelize_ms: now_ms() - start,
        }
    }

    /// The solid with its count pyramid.
    pub fn solid(&self) -> &Solid {
        &self.solid
    }

    /// The solid bit grid.
    pub fn grid(&self) -> &Grid {
        self.solid.bits()
    }

    /// The candidate points: skin voxels in z, y, x order.
    pub fn skin(&self) -> &[[u16; 3]] {
        &self.skin
    }

    /// Voxels within one voxel (26-neighbourhood) of a skin voxel.
    pub fn near_surface(&self) -> &Grid {
        // Asked for inside the verifier's parallel loops: see [`made_once`].
        made_once(&self.near_surface, || dilate(&self.skin_grid, self.backend))
    }

    /// How long voxelizing took, in milliseconds.
    pub fn voxelize_ms(&self) -> f64 {
        self.voxelize_ms
    }

    /// World position of candidate point `i`.
    pub fn position(&self, i: u32) -> Vec3 {
        self.solid.bits().spec().center(self.skin[i as usize])
    }
}

/// The set voxel of `points` whose centre is nearest to world point `p`.
pub(crate) fn nearest_voxel(spec: &GridSpec, points: &[[u16; 3]], p: Vec3) -> Option<[u16; 3]> {
    points
        .iter()
        .min_by(|a, b| {
            (spec.center(**a) - p)
                .length_squared()
                .total_cmp(&(spec.center(**b) - p).length_squared())
        })
        .copied()
}
