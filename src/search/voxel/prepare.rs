//! The template's side of a voxel search, prepared once for every part:
//! the lattice it is searched on, its grid and signatures, a verifier per
//! anchor, the surface samples its poses are refined with, and what all
//! of that holds of the memory budget.

use super::near_vertices::{self, template_gap};
use super::signatures::{Signatures, signatures};
use crate::align::SurfaceSamples;
use crate::budget::{Budget, Item, TemplatePiece, TemplateReach};
use crate::descriptor::harmonics::Signature as HarmonicsSignature;
use crate::descriptor::{
    CentroidDescriptor, CentroidTemplate, SphericalTransform, VolumeDescriptor,
};
use crate::error::Result;
use crate::exec::Threads;
use crate::instances::Extent;
use crate::math::{Aabb, Vec3};
use crate::mesh::mesh_bytes;
use crate::mesh::{TriMesh, connected_components};
use crate::options::MatchOptions;
use crate::scene::{Lattice, Parts, Scene};
use crate::template::ball_table_bytes;
use crate::template::{TemplateSource, VoxelTemplate};
use crate::verify::Verifier;
use crate::voxel::Ball;
use crate::voxel::voxel_bytes;

/// What searching one part needs: the template's side, prepared once.
pub(super) struct PartSearch<'a> {
    pub(super) scene: &'a Scene,
    pub(super) options: &'a MatchOptions,
    pub(super) template: VoxelTemplate,
    pub(super) lattice: Lattice,
    /// The volume balls, shared by every part.
    pub(super) balls: Vec<Ball>,
    /// Per anchor: the template's volume and harmonics signatures.
    pub(super) template_volume: Vec<Vec<f64>>,
    pub(super) template_harmonics: Option<Vec<Vec<HarmonicsSignature>>>,
    /// The centroid stage's balls, and the template's readings per anchor
    /// (none unless both the volume and the harmonics are searched).
    pub(super) centroid_balls: Vec<Ball>,
    pub(super) template_centroid: Option<Vec<Vec<CentroidTemplate>>>,
    pub(super) transform: SphericalTransform,
    /// Per anchor: the verifier placed by it.
    pub(super) verifiers: Vec<Verifier>,
    pub(super) samples: SurfaceSamples,
    /// The samples about c_T: what tells copies side by side apart.
    pub(super) extent: Extent,
    /// The template's surface the samples are taken on (template
    /// coordinates): what a whole copy's own part must lie on.
    pub(super) surface: TriMesh,
    pub(super) max_hidden: f64,
    /// A part is one component: what the template does not explain of it
    /// is the copy's own (see `Verifier::check`).
    pub(super) two_sided: bool,
    /// How far from a vertex of its part a copy's anchor can lie.
    pub(super) vertex_reach: f64,
    /// What the search holds besides a part's grids.
    pub(super) held: Budget,
    /// The work of the parts searched so far (f64 bits), that a part's
    /// own checks add theirs to.
    pub(super) work_done: std::sync::atomic::AtomicU64,
}

impl<'a> PartSearch<'a> {
    /// Prepares `source` for searching `scene`; fails when the template's
    /// own structures pass the memory budget.
    pub(super) fn new(
        scene: &'a Scene,
        source: &TemplateSource,
        options: &'a MatchOptions,
    ) -> Result<PartSearch<'a>> {
        let lattice = search_lattice(scene, source, options)?;
        let template = VoxelTemplate::new(source, scene, &lattice, options)?;
        let voxel = lattice.spec.voxel_size;
        let radii_voxels: Vec<f64> = template.radii().iter().map(|r| r / voxel).collect();
        let surface = template_surface(source, scene, &template);
        let held = search_budget(scene, &template, &surface, &radii_voxels, &lattice)?;
        let transform = SphericalTransform::new();
        // The balls' tables are built once, for the template and every part.
        let balls = VolumeDescriptor::balls_at(template.radii(), voxel, options.backend);
        let centroid_balls = CentroidDescriptor::balls_like(&balls, options.backend);
        let Signatures {
            volume: template_volume,
            harmonics: template_harmonics,
            centroid: template_centroid,
        } = signatures(
            source,
            &template,
            &balls,
            &centroid_balls,
            &transform,
            options,
        )?;
        let max_hidden =
            options.hidden_surface_for(matches!(source, TemplateSource::Selection { .. }));
        let verifiers = verifiers(&template, &radii_voxels, max_hidden, options);
        let vertex_reach = near_vertices::reach(
            anchor_gap(scene, source, &template),
            template.candidate_spacing(),
            voxel,
            template.radii()[0],
        );
        let samples = template_samples(&surface, &template, scene.backend());
        let extent = Extent::new(
            samples.points(),
            template.center(),
            &samples.axes(),
            APART_MARGIN_VOXELS * voxel,
        );
        Ok(PartSearch {
            scene,
            options,
            balls,
            template_volume,
            template_harmonics,
            centroid_balls,
            template_centroid,
            transform,
            verifiers,
            samples,
            extent,
            surface,
            max_hidden,
            two_sided: template.parts() == Parts::Components,
            vertex_reach,
            held,
            work_done: std::sync::atomic::AtomicU64::new(0),
            template,
            lattice,
        })
    }
}

/// The lattice `source` is searched on: the scene's, refined for a small
/// template until it spans enough voxels.
pub(super) fn search_lattice(
    scene: &Scene,
    source: &TemplateSource,
    options: &MatchOptions,
) -> Result<Lattice> {
    if options.template_voxels > 0.0 {
        scene.lattice_for(source.bounding_radius(), options.template_voxels)
    } else {
        Ok(scene.lattice())
    }
}

/// A verifier placed by each of the template's anchors.
fn verifiers(
    template: &VoxelTemplate,
    radii_voxels: &[f64],
    max_hidden: f64,
    options: &MatchOptions,
) -> Vec<Verifier> {
    let voxels = template.voxels();
    template
        .anchors()
        .iter()
        .enumerate()
        .map(|(i, &a)| {
            Verifier::new(
                voxels.solid(),
                voxels.skin(),
                voxels.near_surface(),
                a,
                template.center_offset(i),
                radii_voxels,
                max_hidden,
                options.backend,
            )
        })
        .collect()
}

/// How far the template's anchors lie from a vertex of the template: a
/// copy's anchor lies as near a vertex of its part.
fn anchor_gap(scene: &Scene, source: &TemplateSource, template: &VoxelTemplate) -> f64 {
    let anchor_points: Vec<Vec3> = (0..template.anchors().len())
        .map(|a| template.anchor_position(a))
        .collect();
    match source {
        TemplateSource::Model(model) => template_gap(
            &anchor_points,
            (0..model.triangles().len()).flat_map(|t| model.corners(t)),
        ),
        TemplateSource::Selection { .. } => {
            let part = template
                .scene_part()
                .expect("a selection lies on a scene part");
            let mesh = scene.mesh();
            template_gap(
                &anchor_points,
                scene.parts()[part]
                    .triangles()
                    .iter()
                    .flat_map(|&t| mesh.corners(t as usize)),
            )
        }
    }
}

/// The template's surface: a model's, or the selected part's triangles
/// that reach into the sphere.
fn template_surface(source: &TemplateSource, scene: &Scene, template: &VoxelTemplate) -> TriMesh {
    match source {
        TemplateSource::Model(model) => model.clone(),
        TemplateSource::Selection { .. } => {
            let (c, r) = (template.center(), template.radius());
            let part = template
                .scene_part()
                .expect("a selection lies on a scene part");
            let mesh = scene.mesh();
            let near: Vec<u32> = scene.parts()[part]
                .triangles()
                .iter()
                .copied()
                .filter(|&t| {
                    Aabb::around(mesh.corners(t as usize)).is_some_and(|b| b.distance_to(c) <= r)
                })
                .collect();
            mesh.subset(&near)
        }
    }
}

/// Surface samples the template's pose is refined with: the template's
/// `surface` within its sphere, each told its shell for a template of
/// several.
fn template_samples(
    surface: &TriMesh,
    template: &VoxelTemplate,
    backend: Threads,
) -> SurfaceSamples {
    let (c, r) = (template.center(), template.radius());
    let triangles: Vec<[Vec3; 3]> = (0..surface.triangles().len())
        .map(|t| surface.corners(t))
        .collect();
    let samples = SurfaceSamples::new(&triangles, ALIGN_SAMPLES, |p| p.distance(c) <= r);
    if template.parts() == Parts::Components {
        return samples;
    }
    let mut shell_of = vec![0u32; triangles.len()];
    for (shell, members) in connected_components(surface, backend).iter().enumerate() {
        for &t in members {
            shell_of[t as usize] = shell as u32;
        }
    }
    samples.with_pieces(&shell_of)
}

/// Template surface samples for the pose refinement.
const ALIGN_SAMPLES: usize = 1024;

/// Two placements lie apart only with this many voxels between them: a
/// placement before its pose is refined is off by a voxel or two, and one
/// copy must not become two (a thin plate's placements a voxel off along
/// its normal).
const APART_MARGIN_VOXELS: f64 = 2.0;

/// What a voxel search holds besides the part it searches: the scene's
/// mesh, the template's surface and voxel grids and the run tables of the
/// volume and verification balls.
fn search_budget(
    scene: &Scene,
    template: &VoxelTemplate,
    surface: &TriMesh,
    radii: &[f64],
    lattice: &Lattice,
) -> Result<Budget> {
    let reach = TemplateReach {
        outer_voxels: radii.last().copied().unwrap_or_default(),
        resolution: lattice.resolution,
        selection: false,
    };
    let mut held = scene.budget();
    held.reserve(
        Item::Template(TemplatePiece::Surface, reach),
        mesh_bytes(surface.positions().len(), surface.triangles().len()),
    )?
    .reserve(
        Item::Template(TemplatePiece::Grids, reach),
        voxel_bytes(template.voxels().grid().spec()),
    )?
    .reserve(
        Item::Template(TemplatePiece::BallTables, reach),
        ball_table_bytes(radii),
    )?;
    Ok(held)
}
