//! A scene ready to search: its mesh and, built on first use, what each
//! descriptor reads: the solid voxel grid and its skin voxels (the volume and
//! harmonics candidates), or the welded surface (the curvature candidates).
//! Built once, searched any number of times.

use crate::budget::{Budget, Item};
use crate::cascade::{Observer, Progress, Steps};
use crate::clock::now_ms;
use crate::descriptor::curvature::Surface;
use crate::descriptor::curvature::surface_bytes;
use crate::error::{Error, Result};
use crate::exec::Threads;
use crate::math::Aabb;
use crate::mesh::mesh_bytes;
use crate::mesh::{TriMesh, connected_components};
use crate::voxel::{GridSpec, PADDING, WindowedMesh};
use crate::voxel::{voxel_bytes, voxel_work};
use std::borrow::Cow;
use std::sync::OnceLock;

mod part_voxels;
mod parts;

pub use part_voxels::PartVoxels;
pub(crate) use part_voxels::nearest_voxel;
use parts::join_shells;
pub use parts::{ScenePart, ShellRule};

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
    /// A search refines this lattice for a small template and coarsens it
    /// for a large one (`MatchOptions::template_voxels`; 0 keeps it).
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
    #[cfg_attr(feature = "cli", arg(skip = Threads::Parallel))]
    pub backend: Threads,
}

impl SceneOptions {
    /// The defaults.
    pub const DEFAULT: SceneOptions = SceneOptions {
        resolution: 512,
        memory_budget: 2 << 30,
        max_voxel_work: (1u64 << 27) as f64,
        backend: Threads::Parallel,
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
    pub const fn with_backend(mut self, backend: Threads) -> Self {
        self.backend = backend;
        self
    }
}

impl Default for SceneOptions {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The voxel lattice a search reads the scene on: the scene's own, or a
/// finer one for a small template (same origin).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lattice {
    /// The grid over the whole scene.
    pub spec: GridSpec,
    /// Voxels along the scene's longest side.
    pub resolution: u32,
}

/// A template spans at most this many times its least span of voxels
/// (`MatchOptions::template_voxels`): a large part is searched on a
/// coarser lattice. A template's ball tables grow with the cube of its
/// span (the cow searched in a scene of itself spans 558 voxels at
/// resolution 1024 and asked 5.2 GiB), and the meshes, not the voxels,
/// make the pose exact.
pub const SPAN_RANGE: f64 = 3.0;

/// A lattice is never coarsened below this many voxels along the scene's
/// longest side: a selection wider than the scene would otherwise leave
/// it a handful of voxels.
pub const MIN_COARSE_RESOLUTION: f64 = 64.0;

/// The finest lattice a template may ask for, in voxels along the scene's
/// longest side: a 2 km site at a millimetre.
pub const MAX_LATTICE_RESOLUTION: f64 = (1u32 << 21) as f64;

/// A part's grid, or a window of it, may take this share of the memory
/// budget.
const WINDOW_SHARE: u64 = 8;

/// A part's grid may always take this much for its padding.
pub const PAD_FLOOR_BYTES: u64 = 4 << 20;

/// A scene to search.
pub struct Scene {
    mesh: TriMesh,
    spec: GridSpec,
    resolution: u32,
    backend: Threads,
    memory_budget: u64,
    max_voxel_work: f64,
    parts: Vec<ScenePart>,
    surface: OnceLock<(Surface, f64)>,
}

/// How a search divides the scene into parts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Parts {
    /// Each connected component alone: a template of one component.
    Components,
    /// Components that may be shells of one copy, joined: a template made
    /// of several shells (a mug whose handle is a shell of its own, a wheel
    /// pair) is found with its shells together.
    Shells(ShellRule),
}

impl Scene {
    /// Prepares `mesh` for searching: splits it into its connected parts and
    /// checks now that the largest part's voxels fit the memory budget.
    pub fn new(mesh: TriMesh, options: &SceneOptions) -> Result<Scene> {
        Scene::new_observed(mesh, options, &mut ())
    }

    /// [`Scene::new`], telling `observer` as each of [`Scene::BUILD_STEPS`]
    /// ends ([`Progress::SCENE`]): 0.1-0.2 s on the 1.7 M-triangle
    /// buildings, so seconds on tens of millions of triangles. A `Break`
    /// stops it with [`Error::Cancelled`].
    pub fn new_observed(
        mesh: TriMesh,
        options: &SceneOptions,
        observer: &mut dyn Observer,
    ) -> Result<Scene> {
        let mut steps = Steps::new(observer, Progress::SCENE, Scene::BUILD_STEPS);
        let spec = GridSpec::for_scene(mesh.bounds(), options.resolution)?;
        check_voxel_work(
            "scene",
            &mesh,
            spec.voxel_size,
            options.resolution,
            options.max_voxel_work,
            options.backend,
        )?;
        steps.done()?;
        let components = connected_components(&mesh, options.backend);
        steps.done()?;
        let parts = ScenePart::all(&mesh, components, options.backend);
        steps.done()?;
        let mesh_estimate = mesh_bytes(mesh.positions().len(), mesh.triangles().len());
        let largest_grids = |spec: &GridSpec| {
            parts
                .iter()
                .map(|p| {
                    spec.crop(p.bounds(), PADDING)
                        .map_or(u64::MAX, |s| voxel_bytes(&s))
                })
                .max()
                .unwrap_or_default()
        };
        // The largest resolution whose grids fit, found with the same
        // estimate.
        let fitting = || {
            (8..options.resolution).rev().find(|&r| {
                GridSpec::for_scene(mesh.bounds(), r).is_ok_and(|spec| {
                    mesh_estimate.saturating_add(largest_grids(&spec)) <= options.memory_budget
                })
            })
        };
        Budget::new(options.memory_budget)
            .reserve(
                Item::Mesh {
                    triangles: mesh.triangles().len(),
                },
                mesh_estimate,
            )?
            .reserve(
                Item::LargestPartGrids {
                    resolution: options.resolution,
                    fitting: &fitting,
                },
                largest_grids(&spec),
            )?;
        steps.done()?;
        Ok(Scene {
            mesh,
            spec,
            resolution: options.resolution,
            backend: options.backend,
            memory_budget: options.memory_budget,
            max_voxel_work: options.max_voxel_work,
            parts,
            surface: OnceLock::new(),
        })
    }

    /// The steps [`Scene::new_observed`] reports: the voxel work checked,
    /// the connected components, their shapes, the memory checked.
    pub const BUILD_STEPS: usize = 4;

    /// The threads the scene's builds use, and so the searches on it.
    pub fn backend(&self) -> Threads {
        self.backend
    }

    /// The mesh.
    pub fn mesh(&self) -> &TriMesh {
        &self.mesh
    }

    /// The scene's connected components, in order of their first triangle.
    pub fn parts(&self) -> &[ScenePart] {
        &self.parts
    }

    /// The parts a search looks at one by one, in order of their first
    /// triangle: the components, or those `kind` joins.
    pub fn parts_for(&self, kind: Parts) -> Cow<'_, [ScenePart]> {
        match kind {
            Parts::Components => Cow::Borrowed(&self.parts),
            Parts::Shells(rule) => {
                Cow::Owned(join_shells(&self.mesh, &self.parts, rule, self.backend))
            }
        }
    }

    /// The connected component holding triangle `t`.
    pub fn part_of_triangle(&self, t: usize) -> usize {
        self.parts
            .iter()
            .position(|p| p.triangles().binary_search(&(t as u32)).is_ok())
            .expect("every triangle is in a part")
    }

    /// The scene's own lattice.
    pub fn lattice(&self) -> Lattice {
        Lattice {
            spec: self.spec,
            resolution: self.resolution,
        }
    }

    /// The lattice on which a template of bounding radius `radius` spans at
    /// least `voxels` voxels and at most [`SPAN_RANGE`] times that: the
    /// scene's own, or finer for a small template, or coarser for a large
    /// one. A part too large for one grid on it is searched in windows
    /// (`search::windows`), so the scene's extent does not coarsen it.
    pub fn lattice_for(&self, radius: f64, voxels: f64) -> Result<Lattice> {
        let bounds = self.mesh.bounds();
        let longest = bounds.extent().max_element();
        let own = f64::from(self.resolution);
        let fewest = (longest * voxels / radius).ceil();
        let most = (longest * SPAN_RANGE * voxels / radius).ceil();
        let resolution = if fewest.is_finite() && fewest > own {
            fewest.min(MAX_LATTICE_RESOLUTION)
        } else if most.is_finite() && most < own {
            most.max(MIN_COARSE_RESOLUTION.min(own))
        } else {
            return Ok(self.lattice());
        } as u32;
        // As `GridSpec::for_scene` places it, past its limit of a grid's
        // side: only crops of it are ever allocated.
        Ok(Lattice {
            spec: GridSpec::lattice(bounds, longest / f64::from(resolution)),
            resolution,
        })
    }

    /// Voxelizes `part` on its own for a template reaching `reach` voxels
    /// from its centre, after checking that its grids fit the memory budget
    /// beside the scene's mesh.
    pub fn voxelize_part(
        &self,
        part: &ScenePart,
        lattice: &Lattice,
        reach: f64,
    ) -> Result<PartVoxels> {
        self.voxelize_part_beside(part, lattice, reach, &self.budget())
    }

    /// [`Scene::voxelize_part`] beside what a search holds already.
    pub(crate) fn voxelize_part_beside(
        &self,
        part: &ScenePart,
        lattice: &Lattice,
        reach: f64,
        held: &Budget,
    ) -> Result<PartVoxels> {
        let spec = self.part_spec(part, lattice, reach)?;
        held.clone().reserve(
            Item::PartGrids {
                triangles: part.triangles().len(),
                dims: spec.dims,
                resolution: lattice.resolution,
            },
            voxel_bytes(&spec),
        )?;
        // The part's own mesh is part of voxelizing it.
        let started = now_ms();
        let mesh = self.mesh.subset(part.triangles());
        let mut voxels = PartVoxels::build(&mesh, &spec, self.backend);
        voxels.voxelize_ms = now_ms() - started;
        Ok(voxels)
    }

    /// A window of a part too large for one grid may take this much:
    /// smaller windows skip more of a part where no copy can lie.
    pub fn window_bytes(&self) -> u64 {
        self.memory_budget / WINDOW_SHARE
    }

    /// Whether `part`'s whole grid, padded by `reach` voxels, takes at most
    /// half the memory budget; a larger part is searched in windows.
    pub fn fits_one_grid(&self, part: &ScenePart, lattice: &Lattice, reach: f64) -> bool {
        self.part_spec(part, lattice, reach)
            .is_ok_and(|spec| voxel_bytes(&spec) <= self.memory_budget / 2)
    }

    /// Voxelizes the window of `part` around `focus`, padded by `reach`
    /// voxels: what of a part too large for one grid a selection reads.
    pub(crate) fn voxelize_around(
        &self,
        part: &ScenePart,
        lattice: &Lattice,
        focus: Aabb,
        reach: f64,
        held: &Budget,
    ) -> Result<PartVoxels> {
        let pad = reach.ceil().clamp(0.0, f64::from(u16::MAX)) as usize + 2;
        let spec = lattice.spec.crop(focus, pad)?;
        let windowed = WindowedMesh::new(self.mesh.subset(part.triangles()), self.backend);
        held.clone()
            .reserve(Item::WindowMesh { selection: true }, windowed.bytes())?
            .reserve(Item::WindowGrids { selection: true }, voxel_bytes(&spec))?;
        Ok(PartVoxels::build_window(&windowed, &spec, self.backend))
    }

    /// The grid of `part`, padded so that the template's spheres and balls
    /// around its surface (`reach` voxels) stay inside it: samples past a
    /// grid's border take the readers' slow path, which made a search of
    /// many small parts twice as slow. The padding may at most double the
    /// part's memory (or take [`PAD_FLOOR_BYTES`]); past that it shrinks.
    pub fn part_spec(&self, part: &ScenePart, lattice: &Lattice, reach: f64) -> Result<GridSpec> {
        let tight = lattice.spec.crop(part.bounds(), PADDING)?;
        let cap = 2 * voxel_bytes(&tight) + PAD_FLOOR_BYTES;
        let mut pad = if reach.is_finite() && reach > 0.0 {
            reach.ceil().min(f64::from(u16::MAX)) as usize + 2
        } else {
            PADDING
        };
        while pad > PADDING {
            if let Ok(spec) = lattice.spec.crop(part.bounds(), pad)
                && voxel_bytes(&spec) <= cap
            {
                return Ok(spec);
            }
            pad /= 2;
        }
        Ok(tight)
    }

    /// The welded surface, built on first use with `step` told how many of
    /// [`Surface::BUILD_STEPS`] are done; `None` when `step` stops it (a
    /// later call starts again).
    pub(crate) fn surface_observed(
        &self,
        step: &mut dyn FnMut(usize) -> std::ops::ControlFlow<()>,
    ) -> Option<&Surface> {
        if self.surface.get().is_none() {
            let start = now_ms();
            let surface = Surface::build(&self.mesh, self.backend, step)?;
            // Another thread may have built it meanwhile: the same surface.
            let _ = self.surface.set((surface, now_ms() - start));
        }
        self.surface.get().map(|(surface, _)| surface)
    }

    /// The welded surface with its adjacency (built on first use).
    pub fn surface(&self) -> &Surface {
        &self
            .surface
            .get_or_init(|| {
                let start = now_ms();
                let surface = Surface::new(&self.mesh, self.backend);
                (surface, now_ms() - start)
            })
            .0
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

    /// The estimate of what the scene holds between searches: its mesh, and
    /// its welded surface once built.
    pub fn built_bytes(&self) -> u64 {
        mesh_bytes(self.mesh.positions().len(), self.mesh.triangles().len())
            + if self.surface.get().is_some() {
                surface_bytes(self.mesh.triangles().len())
            } else {
                0
            }
    }

    /// The memory budget with the scene's mesh held (a search reserves
    /// its own structures beside it).
    pub(crate) fn budget(&self) -> Budget {
        let mut budget = Budget::new(self.memory_budget);
        budget.hold(
            Item::Mesh {
                triangles: self.mesh.triangles().len(),
            },
            mesh_bytes(self.mesh.positions().len(), self.mesh.triangles().len()),
        );
        budget
    }

    /// The resolution it is voxelized at.
    pub fn resolution(&self) -> u32 {
        self.resolution
    }

    /// Edge length of a voxel in world units.
    pub fn voxel_size(&self) -> f64 {
        self.spec.voxel_size
    }

    /// The grid of the whole scene: the lattice every part's grid is cut from.
    pub fn spec(&self) -> &GridSpec {
        &self.spec
    }

    /// How long building the welded surface took, in milliseconds (0 if
    /// not built).
    pub fn surface_ms(&self) -> f64 {
        self.surface.get().map_or(0.0, |s| s.1)
    }
}

impl std::fmt::Debug for Scene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scene")
            .field("triangles", &self.mesh.triangles().len())
            .field("resolution", &self.resolution)
            .field("voxel_size", &self.voxel_size())
            .field("parts", &self.parts.len())
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
    backend: Threads,
) -> Result<()> {
    let work = voxel_work(mesh, voxel_size, backend);
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
