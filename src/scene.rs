//! A scene ready to search: its mesh and, built on first use, what each
//! descriptor reads: the solid voxel grid and its skin voxels (the volume and
//! harmonics candidates), or the welded surface (the curvature candidates).
//! Built once, searched any number of times.

use crate::budget::{mesh_bytes, surface_bytes, voxel_bytes, voxel_work};
use crate::clock::now_ms;
use crate::descriptor::curvature::Surface;
use crate::error::MemoryEstimate;
use crate::error::{Error, Result};
use crate::exec::Backend;
use crate::math::Vec3;
use crate::mesh::TriMesh;
use crate::voxel::{Grid, GridSpec, Solid, dilate, skin, voxelize};
use std::sync::OnceLock;

/// How to voxelize a scene.
///
/// Like [`crate::MatchOptions`], the one schema of these settings for the
/// CLI (clap) and JavaScript (serde); only the resolution is a user's
/// setting there, the rest the embedder's.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(
    feature = "serde",
    serde(rename_all = "camelCase", deny_unknown_fields, default)
)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[non_exhaustive]
pub struct SceneOptions {
    /// Voxels along the scene's longest side.
    ///
    /// Default: 512 (the paper's).
    #[cfg_attr(feature = "cli", arg(long, long_help = None, default_value_t = SceneOptions::DEFAULT.resolution))]
    pub resolution: u32,
    /// The memory budget in bytes for the scene and every search on it:
    /// what would pass it is refused before it is allocated with
    /// [`crate::Error::OverBudget`], which says what would fit. Default: 2 GiB.
    /// The CLI takes it in MiB; the wasm binding sizes it from its memory.
    #[cfg_attr(feature = "serde", serde(skip))]
    #[cfg_attr(feature = "cli", arg(skip = SceneOptions::DEFAULT.memory_budget))]
    pub memory_budget: u64,
    /// Refuse to voxelize a mesh whose triangles, projected on the three
    /// axis planes, cover more voxel faces than this: the voxelizer's
    /// time follows it. Default: 2^27,
    /// about 5 s on one core; the shared scenes need under 10^6 at 512.
    #[cfg_attr(feature = "serde", serde(skip))]
    #[cfg_attr(feature = "cli", arg(skip = SceneOptions::DEFAULT.max_voxel_work))]
    pub max_voxel_work: f64,
    /// Serial or parallel. Default: parallel.
    #[cfg_attr(feature = "serde", serde(skip))]
    #[cfg_attr(feature = "cli", arg(skip = Backend::Parallel))]
    pub backend: Backend,
}

impl SceneOptions {
    /// The defaults.
    pub const DEFAULT: SceneOptions = SceneOptions {
        resolution: 512,
        memory_budget: 2 << 30,
        max_voxel_work: (1u64 << 27) as f64,
        backend: Backend::Parallel,
    };

    /// With another resolution.
    pub const fn with_resolution(mut self, resolution: u32) -> Self {
        self.resolution = resolution;
        self
    }

    /// With another memory budget.
    pub const fn with_memory_budget(mut self, bytes: u64) -> Self {
        self.memory_budget = bytes;
        self
    }

    /// With another limit on the voxelizer's work.
    pub const fn with_max_voxel_work(mut self, faces: f64) -> Self {
        self.max_voxel_work = faces;
        self
    }

    /// With another backend.
    pub const fn with_backend(mut self, backend: Backend) -> Self {
        self.backend = backend;
        self
    }
}

impl Default for SceneOptions {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// A scene to search.
pub struct Scene {
    mesh: TriMesh,
    spec: GridSpec,
    resolution: u32,
    backend: Backend,
    memory_budget: u64,
    max_voxel_work: f64,
    voxels: OnceLock<Voxels>,
    surface: OnceLock<(Surface, f64)>,
}

/// The voxelized scene.
struct Voxels {
    solid: Solid,
    skin: Vec<[u16; 3]>,
    near_surface: Grid,
    voxelize_ms: f64,
}

impl Scene {
    /// Prepares `mesh` for searching; checks now that its voxels fit the
    /// memory budget, and voxelizes on first use.
    pub fn new(mesh: TriMesh, options: &SceneOptions) -> Result<Scene> {
        let spec = GridSpec::for_scene(mesh.bounds(), options.resolution)?;
        check_voxel_work(
            "scene",
            &mesh,
            spec.voxel_size,
            options.resolution,
            options.max_voxel_work,
        )?;
        let budget = options.memory_budget;
        let mesh_estimate = mesh_bytes(mesh.positions().len(), mesh.triangles().len());
        let fits = |spec: &GridSpec| {
            let mut estimate = MemoryEstimate::new();
            estimate
                .add("the mesh", mesh_estimate)
                .add("voxel grids and count pyramid", voxel_bytes(spec));
            estimate
        };
        fits(&spec).check(budget, || {
            // The largest resolution whose grids fit, found with the same
            // estimate.
            let fitting = (8..options.resolution).rev().find(|&r| {
                GridSpec::for_scene(mesh.bounds(), r)
                    .is_ok_and(|spec| fits(&spec).total() <= budget)
            });
            match fitting {
                Some(r) => format!(
                    "lower the resolution to at most {r} (now {}), or raise the memory budget",
                    options.resolution
                ),
                None => "no resolution fits: raise the memory budget, or split the scene".into(),
            }
        })?;
        Ok(Scene {
            mesh,
            spec,
            resolution: options.resolution,
            backend: options.backend,
            memory_budget: budget,
            max_voxel_work: options.max_voxel_work,
            voxels: OnceLock::new(),
            surface: OnceLock::new(),
        })
    }

    fn voxels(&self) -> &Voxels {
        self.voxels.get_or_init(|| {
            let start = now_ms();
            let grid = voxelize(&self.mesh, &self.spec, self.backend);
            let skin_grid = skin(&grid, self.backend);
            let near_surface = dilate(&skin_grid, self.backend);
            // Sized exactly: a messy scene's skin can run to tens of
            // millions of voxels, and doubling would take twice that.
            let mut skin = Vec::with_capacity(skin_grid.count_ones() as usize);
            skin.extend(skin_grid.iter_ones());
            Voxels {
                solid: Solid::new(grid),
                skin,
                near_surface,
                voxelize_ms: now_ms() - start,
            }
        })
    }

    /// The mesh.
    pub fn mesh(&self) -> &TriMesh {
        &self.mesh
    }

    /// The welded surface with its adjacency (built on first use).
    pub fn surface(&self) -> &Surface {
        &self
            .surface
            .get_or_init(|| {
                let start = now_ms();
                let surface = Surface::new(&self.mesh);
                (surface, now_ms() - start)
            })
            .0
    }

    /// The solid bit grid.
    pub fn grid(&self) -> &Grid {
        self.solid().bits()
    }

    /// The solid with its count pyramid.
    pub fn solid(&self) -> &Solid {
        &self.voxels().solid
    }

    /// The candidate points: skin voxels in z, y, x order.
    pub fn skin(&self) -> &[[u16; 3]] {
        &self.voxels().skin
    }

    /// Voxels within one voxel (26-neighbourhood) of a skin voxel.
    pub fn near_surface(&self) -> &Grid {
        &self.voxels().near_surface
    }

    /// The memory budget in bytes for the scene and its searches.
    pub fn memory_budget(&self) -> u64 {
        self.memory_budget
    }

    /// The limit on the voxelizer's work (a template model is held to it too).
    pub fn max_voxel_work(&self) -> f64 {
        self.max_voxel_work
    }

    /// Changes the memory budget for the searches to come (a host whose
    /// free memory changes, such as a wasm module holding other scenes).
    pub fn set_memory_budget(&mut self, bytes: u64) {
        self.memory_budget = bytes;
    }

    /// The estimate of what the scene has built so far: its mesh, and its
    /// voxels or welded surface once built.
    pub fn built_bytes(&self) -> u64 {
        let mut estimate = MemoryEstimate::new();
        estimate.add(
            "the mesh",
            mesh_bytes(self.mesh.positions().len(), self.mesh.triangles().len()),
        );
        if self.is_voxelized() {
            estimate.add("voxel grids and count pyramid", voxel_bytes(&self.spec));
        }
        if self.surface.get().is_some() {
            estimate.add("welded surface", surface_bytes(self.mesh.triangles().len()));
        }
        estimate.total()
    }

    /// What the scene holds or will hold for voxel descriptors: its mesh,
    /// grids and pyramid (a search adds its own structures to this).
    pub(crate) fn voxel_estimate(&self) -> MemoryEstimate {
        let mut estimate = MemoryEstimate::new();
        estimate
            .add(
                "the mesh",
                mesh_bytes(self.mesh.positions().len(), self.mesh.triangles().len()),
            )
            .add("voxel grids and count pyramid", voxel_bytes(&self.spec));
        estimate
    }

    /// The resolution it is voxelized at.
    pub fn resolution(&self) -> u32 {
        self.resolution
    }

    /// Edge length of a voxel in world units.
    pub fn voxel_size(&self) -> f64 {
        self.spec.voxel_size
    }

    /// Whether the scene has been voxelized yet.
    pub fn is_voxelized(&self) -> bool {
        self.voxels.get().is_some()
    }

    /// How long voxelization took, in milliseconds (0 if not voxelized).
    pub fn voxelize_ms(&self) -> f64 {
        self.voxels.get().map_or(0.0, |v| v.voxelize_ms)
    }

    /// How long building the welded surface took, in milliseconds (0 if
    /// not built).
    pub fn surface_ms(&self) -> f64 {
        self.surface.get().map_or(0.0, |s| s.1)
    }

    /// World position of candidate point `i`.
    pub fn position(&self, i: u32) -> Vec3 {
        self.spec.center(self.skin()[i as usize])
    }
}

impl std::fmt::Debug for Scene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scene")
            .field("triangles", &self.mesh.triangles().len())
            .field("resolution", &self.resolution)
            .field("voxel_size", &self.voxel_size())
            .field("voxelized", &self.voxels.get().is_some())
            .finish()
    }
}

/// Fails when voxelizing `mesh` on voxels of `voxel_size` would pass
/// `limit` ([`voxel_work`]); the work falls with the square of the
/// resolution, so the message names the one that fits.
pub(crate) fn check_voxel_work(
    what: &'static str,
    mesh: &TriMesh,
    voxel_size: f64,
    resolution: u32,
    limit: f64,
) -> Result<()> {
    let work = voxel_work(mesh, voxel_size);
    if work <= limit {
        return Ok(());
    }
    let fits = (f64::from(resolution) * (limit / work).sqrt()).floor();
    let advice = if fits >= 8.0 {
        format!("lower the resolution to at most {fits} (the work falls with its square)")
    } else {
        "no resolution fits: the triangles are too large and too many; simplify the mesh".into()
    };
    Err(Error::TooMuchWork {
        what,
        work,
        limit,
        resolution,
        advice,
    })
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
