//! One error type for the whole pipeline.
//!
//! Every failure a user can cause (a bad file, an impossible option, a grid
//! that does not fit in memory) is a variant here with a message that says
//! what to change. Nothing in the library panics on bad input.

mod file_text;

use std::fmt;

pub use crate::budget::MemoryEstimate;
pub use file_text::{FileText, escape, escape_bytes};

use crate::budget::mib;

/// The mesh file formats the loaders understand.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    /// glTF 2.0, binary (`.glb`) or JSON (`.gltf`).
    Gltf,
    /// Wavefront OBJ.
    Obj,
    /// Stanford PLY, ASCII or binary.
    Ply,
    /// STL, ASCII or binary.
    Stl,
}

impl Format {
    /// The format a file extension names, if any (case-insensitive, without the dot).
    pub fn from_extension(ext: &str) -> Option<Format> {
        match ext.to_ascii_lowercase().as_str() {
            "glb" | "gltf" => Some(Format::Gltf),
            "obj" => Some(Format::Obj),
            "ply" => Some(Format::Ply),
            "stl" => Some(Format::Stl),
            _ => None,
        }
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Format::Gltf => "glTF",
            Format::Obj => "OBJ",
            Format::Ply => "PLY",
            Format::Stl => "STL",
        })
    }
}

/// Everything that can go wrong, from bytes to instances.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The bytes are not any supported mesh format.
    #[error(
        "unrecognized mesh data: expected glTF (.glb/.gltf), OBJ, PLY or STL{}",
        if *.len == 0 { " (the input is empty)".to_string() } else { format!("; the content starts with {}", .start) }
    )]
    UnknownFormat {
        /// Size of the input in bytes.
        len: usize,
        /// What the input starts with: a line of text, or bytes in hex.
        start: FileText,
    },

    /// The file claims a format but its content is malformed or cut short.
    #[error("malformed {format} data ({location}): {message}")]
    Malformed {
        /// The format being parsed.
        format: Format,
        /// Where: a line number, a byte offset or a glTF object.
        location: FileText,
        /// What is wrong, in words (what it quotes from the file escaped).
        message: FileText,
    },

    /// A glTF file refers to an external buffer that was not supplied.
    #[error(
        "glTF buffer '{uri}' is not available: put it beside the .gltf file or use a .glb with embedded buffers"
    )]
    MissingResource {
        /// The URI as written in the file, escaped and bounded.
        uri: FileText,
    },

    /// A glTF file refers to an external buffer that may not or cannot be
    /// read: a URI leading out of the model's folder, a link, a device.
    #[error("glTF buffer '{uri}' is not read: {reason}")]
    ResourceRefused {
        /// The URI as written in the file, escaped and bounded.
        uri: FileText,
        /// Why, in words.
        reason: FileText,
    },

    /// The mesh, as the file builds it (polygons split into triangles,
    /// instances placed), passes the loaders' size limits.
    #[error(
        "the mesh would have {vertices} vertices and {triangles} triangles (polygons split, every glTF instance placed), above the limit of {} of each or {} in all: split the model, or place fewer copies",
        .limit, mib(*.max_bytes)
    )]
    MeshTooLarge {
        /// The loaders' limit on vertices and on triangles.
        limit: u64,
        /// Vertices placed so far, with the copy that passed the limit.
        vertices: u64,
        /// Triangles placed so far, with that copy.
        triangles: u64,
        /// The cap on the placed mesh's bytes.
        max_bytes: u64,
    },

    /// The file parsed but holds no usable triangle.
    #[error("the mesh has no triangles{}", if *.degenerate > 0 { format!(" ({} degenerate ones were ignored)", .degenerate) } else { String::new() })]
    EmptyMesh {
        /// Triangles dropped because they had no area.
        degenerate: usize,
    },

    /// A vertex coordinate is NaN or infinite.
    #[error("vertex {vertex} has a non-finite coordinate {value:?}: the mesh is corrupt")]
    NonFiniteCoordinate {
        /// Index of the offending vertex.
        vertex: usize,
        /// The offending value.
        value: f32,
    },

    /// A triangle refers to a vertex that does not exist.
    #[error(
        "triangle {triangle} refers to vertex {vertex}, but the mesh has only {vertices} vertices"
    )]
    IndexOutOfRange {
        /// Index of the offending triangle.
        triangle: usize,
        /// The vertex index it uses.
        vertex: u64,
        /// The number of vertices.
        vertices: usize,
    },

    /// The voxel grid would have more voxels along a side than a voxel
    /// coordinate holds (65535).
    #[error("a {dims:?} voxel grid is too large: at most 65535 voxels fit along a side; {advice}")]
    GridTooLarge {
        /// Voxels along x, y, z (as far as they could be computed).
        dims: [u64; 3],
        /// What would work, or why nothing would.
        advice: String,
    },

    /// The structures a scene or a search needs would pass the memory
    /// budget; nothing was allocated for them.
    #[error(
        "not enough memory: this needs about {} ({estimate}), above the budget of {}; {advice}",
        mib(.estimate.total()), mib(*.budget)
    )]
    OverBudget {
        /// What was estimated, item by item.
        estimate: MemoryEstimate,
        /// The budget in bytes.
        budget: u64,
        /// What would work, or why nothing would.
        advice: String,
    },

    /// Voxelizing would take longer than the work limit allows: the
    /// triangles' area is huge next to a voxel (large triangles crossing
    /// the whole scene, many times over).
    #[error(
        "the {what}'s triangles cover about {work:.3e} voxel faces at resolution {resolution}, above the limit of {limit:.3e} (a few seconds of voxelizing); {advice}"
    )]
    TooMuchWork {
        /// "scene" or "template".
        what: &'static str,
        /// The projected area in voxel faces.
        work: f64,
        /// The limit.
        limit: f64,
        /// The scene's resolution.
        resolution: u32,
        /// What would work.
        advice: String,
    },

    /// The curvature search would measure more triangles than its work
    /// limit allows: where triangles are long next to the spacing of the
    /// vertices (slivers, fans), every vertex's ball holds thousands.
    #[error(
        "the curvature search would measure about {work:.3e} triangles (about {per_ball:.0} in each vertex's ball), above the limit of {limit:.3e} (minutes of work); {advice}"
    )]
    CurvatureTooMuchWork {
        /// The triangles measured, projected over every candidate.
        work: f64,
        /// Of those, per candidate and layer.
        per_ball: f64,
        /// The limit.
        limit: f64,
        /// What would work.
        advice: String,
    },

    /// Searching the scene's distinct parts would take more work than the
    /// limit allows, judged from a sample of them searched first: every
    /// part that could hold a copy and copies no other is searched on its
    /// own, a few milliseconds each.
    #[error(
        "searching the scene's {parts} distinct parts would take about {work:.3e} units of work ({time} of one core), above the limit of {limit:.3e}; {advice}",
        time = one_core(*work)
    )]
    PartsTooMuchWork {
        /// The distinct parts to search.
        parts: usize,
        /// Their work, projected (about nanoseconds of one core).
        work: f64,
        /// The limit.
        limit: f64,
        /// What would work.
        advice: String,
    },

    /// One part's search passed the work limit as it went: its layers let
    /// most candidates through, and each would be checked at length.
    #[error(
        "the search passed its work limit of {limit:.3e} units ({time} of one core) where {doing}; {advice}",
        time = one_core(*limit)
    )]
    WorkLimit {
        /// The limit.
        limit: f64,
        /// Where it was passed, in words.
        doing: String,
        /// What would work.
        advice: String,
    },

    /// The parts a search would voxelize one by one have bounding boxes far
    /// larger together than the scene's: they overlap many times over
    /// (large triangles crossing each other, each its own part), and each
    /// part's grid fills its box.
    #[error(
        "the scene's parts that could hold the template span {voxels:.3e} voxels together at resolution {resolution}, over {limit:.3e} ({factor} times the whole scene's grid, padded as theirs are): their bounding boxes overlap many times; {advice}"
    )]
    PartsOverlap {
        /// The voxels of the parts' grids, together.
        voxels: f64,
        /// The limit.
        limit: f64,
        /// The limit as a multiple of the scene's grid.
        factor: u32,
        /// The scene's resolution.
        resolution: u32,
        /// What would work.
        advice: String,
    },

    /// The template is too small for the voxel size to describe it.
    #[error(
        "the template's smallest radius is {radius_voxels:.2} voxels, below the {min_voxels} needed; {advice}"
    )]
    TemplateTooSmall {
        /// The smallest onion radius in voxels.
        radius_voxels: f64,
        /// The minimum accepted.
        min_voxels: f64,
        /// What would work, or why nothing would.
        advice: String,
    },

    /// The template is larger than the whole scene, so it cannot occur in it.
    #[error(
        "the template ({} across) is larger than the whole scene ({} across), so it cannot occur in it; {advice}",
        length(*.template_size), length(*.scene_size)
    )]
    TemplateLargerThanScene {
        /// The template's extent: the diameter of its outer onion ball.
        template_size: f64,
        /// The scene's extent: its bounding box diagonal.
        scene_size: f64,
        /// What would work.
        advice: String,
    },

    /// The selection sphere contains no part of the scene's surface.
    #[error(
        "the selection sphere (centre {center:?}, radius {radius}) touches no surface: the nearest surface point is {distance:.4} away from its centre"
    )]
    SelectionMissesScene {
        /// Centre as given.
        center: [f64; 3],
        /// Radius as given.
        radius: f64,
        /// Distance from the centre to the nearest surface point.
        distance: f64,
    },

    /// A template's triangles mark no voxel: each is thinner than f64
    /// rounding at the grid's coordinates (a sliver far from the origin
    /// under huge voxels), so there is nothing to describe.
    #[error(
        "the {what} fills no voxel (voxels {voxel_size:e} wide): its triangles are slivers at these coordinates; check the file's units and coordinates"
    )]
    NothingVoxelized {
        /// "template" or "selected part".
        what: &'static str,
        /// The voxel size.
        voxel_size: f64,
    },

    /// An option has a value the matcher cannot use.
    #[error("invalid option {name}: {message}")]
    InvalidOption {
        /// The option's name.
        name: &'static str,
        /// Why the value is rejected and what is accepted (a caller's
        /// text in it escaped).
        message: FileText,
    },

    /// A model cannot be written as glTF as it stands.
    #[error("the model cannot be written as glTF: {reason}")]
    Unwritable {
        /// What stands in the way, in words (names from the file escaped).
        reason: FileText,
    },

    /// The caller's observer asked to stop.
    #[error("the search was cancelled")]
    Cancelled,

    /// A GPU was asked for and cannot be used.
    #[error("no usable GPU: {reason}")]
    Gpu {
        /// What failed (no adapter, no device, a device error), in the
        /// driver's words, escaped.
        reason: FileText,
    },
}

/// The library's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// Shorthand for a [`Error::Malformed`].
    pub(crate) fn malformed(
        format: Format,
        location: impl Into<String>,
        message: impl Into<String>,
    ) -> Error {
        Error::Malformed {
            format,
            location: FileText::new(&location.into()),
            message: FileText::new(&message.into()),
        }
    }

    /// The message, with an option named as the caller's surface spells
    /// it (`--volume-threshold` on the command line, `volumeThreshold` in
    /// JavaScript) rather than in the core's words ("volume threshold").
    pub fn describe_with(&self, spell: impl Fn(&str) -> String) -> String {
        match self {
            Error::InvalidOption { name, message } => {
                format!("invalid option {}: {message}", spell(name))
            }
            other => other.to_string(),
        }
    }

    /// Shorthand for an [`Error::InvalidOption`].
    pub(crate) fn invalid_option(name: &'static str, message: impl Into<String>) -> Error {
        Error::InvalidOption {
            name,
            message: FileText::new(&message.into()),
        }
    }
}

/// The conversion sits here, not in `crate::budget`, so that the budget
/// names nothing above it.
impl From<crate::budget::Exceeded> for Error {
    fn from(e: crate::budget::Exceeded) -> Error {
        Error::OverBudget {
            estimate: e.estimate,
            budget: e.budget,
            advice: e.advice,
        }
    }
}

/// A length for messages: fixed point where readable, else scientific.
pub(crate) fn length(x: f64) -> String {
    if (1e-3..1e6).contains(&x.abs()) {
        format!("{x:.4}")
    } else {
        format!("{x:.3e}")
    }
}

/// Work in about nanoseconds of one core, as a time a person reads.
fn one_core(work: f64) -> String {
    match work / 1e9 {
        s if s < 90.0 => format!("about {s:.0} s"),
        s => format!("about {:.0} minutes", s / 60.0),
    }
}
