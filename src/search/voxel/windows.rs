//! Windows: a part too large for one dense grid at the template's voxel
//! size (a floor slab, a scan, a game level welded into one mesh) is
//! searched a box at a time (see `voxel::window`).
//!
//! The cores of a part's windows tile its box, so every skin voxel is a
//! candidate in exactly one window; each window is padded by twice the
//! template's radius and a margin, as far as a placed template reaches
//! from its anchor, so that a candidate near a core's side reads what the
//! whole part's grid would give. A copy whose points fall in two cores is
//! found in both; the search merges such finds.

use std::collections::BTreeSet;

use super::near_vertices::NearVertices;
use crate::budget::{Budget, Item};
use crate::error::{Error, Result};
use crate::math::{Aabb, Vec3};
use crate::scene::{Lattice, Scene, ScenePart};
use crate::voxel::GridSpec;
use crate::voxel::voxel_bytes;

/// Voxels past twice the template's radius that a window adds on each
/// side: verification's shifts, the pose refinement, and the outermost
/// layer that is not exact.
const MARGIN: usize = 8;

/// Most voxels a window may have along a side: a voxel coordinate is u16.
const MAX_SIDE: usize = 60_000;

/// One box of a part's search.
pub(super) struct Window {
    /// The window's grid, on the search's lattice.
    pub spec: GridSpec,
    /// Its core, `[lo, hi)` per axis in the window's voxels.
    core: [[usize; 2]; 3],
    /// The lattice, the core in its voxels (`[first, last)`), the padding.
    lattice: GridSpec,
    first: [i64; 3],
    last: [i64; 3],
    pad: usize,
}

impl Window {
    /// The window whose core is the lattice's voxels `[first, last)`.
    fn new(lattice: &GridSpec, first: [i64; 3], last: [i64; 3], pad: usize) -> Window {
        let start = [0, 1, 2].map(|a| (first[a] - pad as i64) as f64);
        let len = [0, 1, 2].map(|a| (last[a] - first[a]) as usize);
        Window {
            spec: GridSpec {
                origin: lattice.origin
                    + Vec3::new(start[0], start[1], start[2]) * lattice.voxel_size,
                voxel_size: lattice.voxel_size,
                dims: len.map(|l| l + 2 * pad),
            },
            core: [0, 1, 2].map(|a| [pad, pad + len[a]]),
            lattice: *lattice,
            first,
            last,
            pad,
        }
    }

    /// This window with its core cut down to `content` (and a voxel more
    /// on each side), or `None` when they miss: a window over a sheet (a
    /// terrain, a scan) is mostly empty space above and below it.
    pub fn fitted(&self, content: &Aabb) -> Option<Window> {
        let (low, high) = (
            self.lattice.to_grid(content.min),
            self.lattice.to_grid(content.max),
        );
        let first = [0, 1, 2].map(|a| self.first[a].max(low[a].floor() as i64 - 1));
        let last = [0, 1, 2].map(|a| self.last[a].min(high[a].floor() as i64 + 2));
        (0..3)
            .all(|a| first[a] < last[a])
            .then(|| Window::new(&self.lattice, first, last, self.pad))
    }

    /// Whether window voxel `v` lies in the core (is a candidate here).
    pub fn holds(&self, v: [u16; 3]) -> bool {
        (0..3).all(|a| (self.core[a][0]..self.core[a][1]).contains(&usize::from(v[a])))
    }

    /// The core in world space.
    pub fn core_bounds(&self) -> Aabb {
        let corner = |i: usize| {
            let [x, y, z] = [0, 1, 2].map(|a| self.core[a][i] as f64);
            self.spec.origin + Vec3::new(x, y, z) * self.spec.voxel_size
        };
        Aabb {
            min: corner(0),
            max: corner(1),
        }
    }
}

/// The windows that `part` is searched in, each at most
/// [`Scene::window_bytes`], or `None` when it fits one grid
/// ([`Scene::fits_one_grid`]).
///
/// A part thousands of times the template's size has millions of windows
/// on the template's lattice: then only those within reach of a vertex
/// (`near`) are listed, since no copy can be anchored in the others, and
/// a list that would still pass its share of the memory budget is refused
/// before it is built.
pub(super) fn part_windows(
    scene: &Scene,
    part: &ScenePart,
    lattice: &Lattice,
    reach: f64,
    near: Option<&NearVertices>,
) -> Result<Option<Vec<Window>>> {
    if scene.fits_one_grid(part, lattice, reach) {
        return Ok(None);
    }
    let tiling = Tiling::new(&lattice.spec, part.bounds(), reach, scene.window_bytes());
    let most = max_listed(scene.memory_budget());
    let all = tiling.count.iter().map(|&c| c as f64).product::<f64>();
    if all <= most as f64 {
        let mut windows = Vec::new();
        for k in 0..tiling.count[2] {
            for j in 0..tiling.count[1] {
                for i in 0..tiling.count[0] {
                    windows.extend(tiling.window([i, j, k]));
                }
            }
        }
        return Ok(Some(windows));
    }
    // Too many to list: those whose core may hold a vertex's surroundings.
    let Some(near) = near else {
        return Err(too_many_windows(scene, part, lattice, all, most));
    };
    let listed = tiling
        .near_vertices(near, most)
        .map_err(|listed| too_many_windows(scene, part, lattice, listed as f64, most))?;
    Ok(Some(
        listed
            .into_iter()
            .filter_map(|[k, j, i]| tiling.window([i, j, k]))
            .collect(),
    ))
}

/// A part's box on the lattice cut into equal cores, each padded into a
/// window that fits the window budget.
struct Tiling {
    spec: GridSpec,
    /// The part's voxels, `[lo, hi)` per axis, and one more on each side:
    /// a vertex on a voxel's side may round into either.
    lo: [i64; 3],
    hi: [i64; 3],
    /// Cores along each axis, and their side in voxels.
    count: [usize; 3],
    side: [usize; 3],
    pad: usize,
}

impl Tiling {
    /// The longest core split until a window of `bounds` on `spec`, padded
    /// for a template of `reach` voxels, fits `limit` bytes.
    fn new(spec: &GridSpec, bounds: Aabb, reach: f64, limit: u64) -> Tiling {
        let pad = (2.0 * reach).ceil().max(0.0) as usize + MARGIN;
        let (low, high) = (spec.to_grid(bounds.min), spec.to_grid(bounds.max));
        let lo = [0, 1, 2].map(|a| low[a].floor() as i64 - 1);
        let hi = [0, 1, 2].map(|a| high[a].floor() as i64 + 2);
        let extent = [0, 1, 2].map(|a| (hi[a] - lo[a]).max(1) as usize);
        let mut count = [1usize; 3];
        let core = |count: &[usize; 3]| [0, 1, 2].map(|a| extent[a].div_ceil(count[a]));
        loop {
            let sides = core(&count).map(|c| c + 2 * pad);
            let window = GridSpec {
                origin: spec.origin,
                voxel_size: spec.voxel_size,
                dims: sides,
            };
            let fits = voxel_bytes(&window) <= limit && sides.iter().all(|&s| s <= MAX_SIDE);
            let cores = core(&count);
            let axis = (0..3)
                .filter(|&a| cores[a] > pad.max(1))
                .max_by_key(|&a| cores[a]);
            match axis {
                Some(a) if !fits => count[a] += 1,
                _ => break,
            }
        }
        Tiling {
            spec: *spec,
            lo,
            hi,
            count,
            side: core(&count),
            pad,
        }
    }

    /// The window of the core at `at` (in cores), unless it is empty.
    fn window(&self, at: [usize; 3]) -> Option<Window> {
        let first = [0, 1, 2].map(|a| self.lo[a] + (at[a] * self.side[a]) as i64);
        let last = [0, 1, 2].map(|a| (first[a] + self.side[a] as i64).min(self.hi[a]));
        (0..3)
            .all(|a| first[a] < last[a])
            .then(|| Window::new(&self.spec, first, last, self.pad))
    }

    /// The cores (as `[k, j, i]`, in listing order) that may hold a
    /// vertex's surroundings, found from `near`'s cells: a superset of the
    /// windows the search keeps. Past `most` of them, how many were
    /// listed.
    fn near_vertices(
        &self,
        near: &NearVertices,
        most: usize,
    ) -> std::result::Result<BTreeSet<[usize; 3]>, usize> {
        let mut listed = BTreeSet::new();
        for cell in near.cells() {
            let (a, b) = (self.spec.to_grid(cell.min), self.spec.to_grid(cell.max));
            let range = [0, 1, 2].map(|x| {
                let index = |v: f64| (v.floor() as i64 - self.lo[x]).max(0) as usize / self.side[x];
                (
                    index(a[x] - 1.0).min(self.count[x] - 1),
                    index(b[x] + 1.0).min(self.count[x] - 1),
                )
            });
            for k in range[2].0..=range[2].1 {
                for j in range[1].0..=range[1].1 {
                    for i in range[0].0..=range[0].1 {
                        listed.insert([k, j, i]);
                    }
                }
            }
            if listed.len() > most {
                return Err(listed.len());
            }
        }
        Ok(listed)
    }
}

/// Bytes a listed window takes, with its share of the list's slack.
const LISTED_BYTES: u64 = (std::mem::size_of::<Window>() + 32) as u64;

/// Windows a list may hold: a sixteenth of the memory budget.
fn max_listed(budget: u64) -> usize {
    usize::try_from(budget / 16 / LISTED_BYTES).unwrap_or(usize::MAX)
}

/// The refusal for a part that needs more windows than a list may hold.
fn too_many_windows(
    scene: &Scene,
    part: &ScenePart,
    lattice: &Lattice,
    windows: f64,
    most: usize,
) -> Error {
    let extent = part.bounds().extent().max_element();
    let item = Item::WindowList {
        extent: crate::error::length(extent),
        extent_voxels: extent / lattice.spec.voxel_size,
        windows,
        most,
    };
    let bytes = (windows * LISTED_BYTES as f64).min(u64::MAX as f64) as u64;
    Budget::new(scene.memory_budget())
        .refuse(item, bytes)
        .into()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::SceneOptions;
    use crate::mesh::shapes::cuboid;

    #[test]
    fn the_cores_of_a_large_parts_windows_tile_its_voxels_once() {
        let slab = cuboid(Vec3::new(-50.0, -40.0, -0.3), Vec3::new(50.0, 40.0, 0.0));
        let scene = Scene::new(slab, &SceneOptions::DEFAULT).unwrap();
        let lattice = scene.lattice_for(0.1, 32.0).unwrap();
        let part = &scene.parts()[0];
        let reach = 0.1 / lattice.spec.voxel_size;
        let windows = part_windows(&scene, part, &lattice, reach, None)
            .unwrap()
            .expect("windows");
        assert!(windows.len() > 1);
        let limit = scene.window_bytes();
        let mut covered = 0.0;
        for w in &windows {
            assert!(voxel_bytes(&w.spec) <= limit);
            let c = w.core_bounds();
            let e = c.extent();
            covered += e.x * e.y * e.z;
            // Cores do not overlap.
            for v in &windows {
                if !std::ptr::eq(v, w) {
                    let d = v.core_bounds();
                    let meet =
                        (0..3).all(|a| d.min[a] < c.max[a] - 1e-9 && c.min[a] < d.max[a] - 1e-9);
                    assert!(!meet, "{c:?} and {d:?}");
                }
            }
            // On the lattice.
            let o = (w.spec.origin - lattice.spec.origin) / lattice.spec.voxel_size;
            assert!((o - o.round()).abs().max_element() < 1e-6);
        }
        // Together the cores hold the part's box, to a voxel.
        let b = part.bounds().extent();
        let voxel = lattice.spec.voxel_size;
        let want = (b.x + voxel) * (b.y + voxel) * (b.z + voxel);
        assert!((covered / want - 1.0).abs() < 0.05, "{covered} of {want}");
        // A small part is one grid.
        let small =
            Scene::new(cuboid(Vec3::ZERO, Vec3::splat(1.0)), &SceneOptions::DEFAULT).unwrap();
        let lattice = small.lattice_for(0.1, 32.0).unwrap();
        let part = &small.parts()[0];
        assert!(
            part_windows(&small, part, &lattice, 32.0, None)
                .unwrap()
                .is_none()
        );
    }
}
