//! What a search reports: the template, the instances, per-layer
//! statistics and stage timings, in the shape of the CLI's JSON.

use crate::cascade::LayerStats;
use crate::instances::Instance;
use crate::math::Vec3;

/// The template as the report shows it.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct TemplateInfo {
    /// c_T: template-model coordinates, or world for a selection.
    pub center: [f64; 3],
    /// r_k.
    pub radius: f64,
}

impl TemplateInfo {
    pub(super) fn of(center: Vec3, radius: f64) -> TemplateInfo {
        TemplateInfo {
            center: center.to_array(),
            radius,
        }
    }
}

/// The welded surface as the report shows it (curvature searches).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct SurfaceInfo {
    /// Welded vertices: the candidate points.
    pub vertices: usize,
    /// Triangles.
    pub triangles: usize,
}

/// The grid as the report shows it.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct GridInfo {
    /// Voxels along the longest side.
    pub resolution: u32,
    /// Edge length of a voxel.
    pub voxel_size: f64,
    /// Candidate points.
    pub skin_voxels: usize,
    /// Windows that parts too large for one grid were searched in (those
    /// where a copy could lie); 0 when every part fit one grid.
    pub windows: usize,
}

/// Milliseconds per stage. The total is computed ([`Timings::total`]) and
/// written to JSON beside the stages.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Timings {
    /// Reading and parsing the files and splitting the scene into its
    /// parts (`Scene::new`; filled in by whoever loaded them).
    pub load: f64,
    /// Voxelizing the scene (voxel descriptors).
    pub voxelize: f64,
    /// Welding the scene's mesh and building its adjacency (curvature).
    pub surface: f64,
    /// Building the template and its descriptors.
    pub template: f64,
    /// The cascade, with what each part's search does besides voxelizing
    /// and verifying (its candidates near vertices, its mesh, its count
    /// pyramid).
    pub match_: f64,
    /// Verifying and grouping survivors.
    pub group: f64,
    /// Time two stages ran at once (a separate template model is voxelized
    /// beside the scene), counted once in the total.
    pub shared: f64,
}

impl Timings {
    /// A search's stages from the clock marks before the template, the
    /// cascade and grouping and after grouping; `load` is the caller's.
    pub(super) fn of_search(voxelize: f64, surface: f64, [t0, t1, t2, t3]: [f64; 4]) -> Timings {
        Timings {
            voxelize,
            surface,
            template: t1 - t0,
            match_: t2 - t1,
            group: t3 - t2,
            ..Timings::default()
        }
    }

    /// All stages as wall-clock time: their sum less the time they shared.
    pub fn total(&self) -> f64 {
        self.load + self.voxelize + self.surface + self.template + self.match_ + self.group
            - self.shared
    }
}

#[cfg(feature = "serde")]
impl serde::Serialize for Timings {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut s = serializer.serialize_struct("Timings", 7)?;
        s.serialize_field("load", &self.load)?;
        s.serialize_field("voxelize", &self.voxelize)?;
        s.serialize_field("surface", &self.surface)?;
        s.serialize_field("template", &self.template)?;
        s.serialize_field("match", &self.match_)?;
        s.serialize_field("group", &self.group)?;
        s.serialize_field("total", &self.total())?;
        s.end()
    }
}

/// Where the cascade's harmonics layers ran when a GPU was given.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct GpuInfo {
    /// The adapter, as wgpu names it, with its API.
    pub adapter: String,
    /// Why layers went back to the CPU, when one did (a buffer past the
    /// device's limits, a lost device); the instances are the same.
    pub fallback: Option<String>,
}

/// Everything a search found, in the shape of the CLI's JSON.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct MatchReport {
    /// The template's centre and outer radius.
    pub template: TemplateInfo,
    /// The occurrences, best first.
    pub instances: Vec<Instance>,
    /// Per-layer statistics of every stage.
    pub stages: Vec<LayerStats>,
    /// The voxel grid (voxel descriptors; None for curvature).
    pub grid: Option<GridInfo>,
    /// The welded surface (curvature; None for the voxel descriptors).
    pub surface: Option<SurfaceInfo>,
    /// The GPU the search was given; absent when it ran on the CPU only.
    pub gpu: Option<GpuInfo>,
    /// Stage timings.
    #[cfg_attr(feature = "serde", serde(rename = "timings_ms"))]
    pub timings: Timings,
}
