//! A template for the voxel descriptors: c_T and the radii, and the grid
//! its descriptors are read from (its own anchor part's for a model, the
//! selected scene part's for a selection).

use super::anchor::{Anchor, Thresholds, further_anchors, stable_anchor};
use super::{
    MIN_RADIUS_VOXELS, TemplateSource, check_extent, check_layers, evenly_spaced, snap_selection,
};
use crate::budget::{Item, TemplatePiece, TemplateReach};
use crate::descriptor::volume::BLOCKS_PER_RADIUS;
use crate::descriptor::{Anchors, all_anchors};
use crate::error::{Error, Result};
use crate::math::{Aabb, Vec3, from_f32};
use crate::mesh::{Sphere, TriMesh, connected_components, mesh_bytes, minimal_bounding_sphere};
use crate::options::MatchOptions;
use crate::scene::{Lattice, PartVoxels, Parts, Scene, ShellRule, check_voxel_work, nearest_voxel};
use crate::verify::moment_level;
use crate::voxel::{GridSpec, ball_bytes, level_for_radius, voxel_bytes};

/// The anchor of a template of `radius` and `layers` voxelized on `voxels`
/// whose c_T is at voxel `nearest` ([`stable_anchor`]), or `nearest`
/// itself where the first layer is too thin to read (the template is
/// refused later).
fn choose_anchor(
    model: Option<&TriMesh>,
    voxels: &PartVoxels,
    nearest: [u16; 3],
    radius: f64,
    layers: usize,
    options: &MatchOptions,
) -> Result<Anchor> {
    let voxel_size = voxels.grid().spec().voxel_size;
    if radius / layers as f64 / voxel_size < MIN_RADIUS_VOXELS {
        return Ok(Anchor {
            voxel: nearest,
            rough: false,
            steady: true,
        });
    }
    stable_anchor(
        model,
        voxels,
        nearest,
        &evenly_spaced(radius, layers),
        Thresholds::of(options),
        options.candidate_spacing,
        options.backend,
    )
}

/// The candidate spacing searched with: every skin voxel where the anchor
/// is rough, its neighbours being no stand-ins for it.
fn candidate_spacing(anchor: &Anchor, options: &MatchOptions) -> u32 {
    if anchor.rough {
        1
    } else {
        options.candidate_spacing
    }
}

/// Fails when voxelizing `model` on `spec`, and turned within the cube
/// around its bounding `sphere` for its anchor's test, would take too long
/// or pass the memory budget.
fn check_model_fits(
    model: &TriMesh,
    sphere: &Sphere,
    spec: &GridSpec,
    scene: &Scene,
    lattice: &Lattice,
) -> Result<()> {
    let voxel_size = lattice.spec.voxel_size;
    let turned = GridSpec::around(
        Aabb {
            min: sphere.center - Vec3::splat(sphere.radius),
            max: sphere.center + Vec3::splat(sphere.radius),
        },
        voxel_size,
    )?;
    check_voxel_work(
        "template",
        model,
        voxel_size,
        lattice.resolution,
        scene.max_voxel_work(),
        scene.backend(),
    )?;
    let reach = TemplateReach {
        outer_voxels: sphere.radius / voxel_size,
        resolution: lattice.resolution,
        selection: false,
    };
    scene
        .budget()
        .reserve(
            Item::TemplateMesh {
                triangles: model.triangles().len(),
            },
            mesh_bytes(model.positions().len(), model.triangles().len()),
        )?
        .reserve(
            Item::Template(TemplatePiece::Grids, reach),
            voxel_bytes(spec),
        )?
        .reserve(
            Item::Template(TemplatePiece::Turned, reach),
            voxel_bytes(&turned),
        )?;
    Ok(())
}

/// A template prepared against a scene.
pub struct VoxelTemplate {
    center: Vec3,
    radius: f64,
    radii: Vec<f64>,
    /// A model's anchor part voxelized on its own, or the scene part a
    /// selection was made on.
    voxels: PartVoxels,
    /// For a selection, the scene part [`VoxelTemplate::voxels`] are of.
    scene_part: Option<usize>,
    /// They are that part's whole grid (not a window around the sphere).
    whole_part: bool,
    /// How the scene is divided for it.
    parts: Parts,
    /// No copy can lie on a part whose bounding sphere is smaller.
    min_part_radius: f64,
    /// The voxels its descriptors are read at, the primary first.
    anchors: Vec<[u16; 3]>,
    /// How many of `anchors` every candidate is read at; the rest only
    /// where no copy was found.
    first_anchors: usize,
    /// How many connected components a model has (1 for a selection).
    shells: usize,
    candidate_spacing: u32,
}

/// A copy's part may be this much smaller than the template's (remeshing,
/// noise and bending shrink a bounding sphere a little); anything smaller
/// misses material the template has, which no rule excuses.
const PART_RADIUS_SLACK: f64 = 0.8;

impl VoxelTemplate {
    /// Prepares `source` for searching `scene` with `layers` radii.
    ///
    /// Scene points are described by their own part: a connected
    /// component for a template of one ([`Parts`]); for one of several
    /// shells, the components that may be one copy's shells.
    pub fn new(
        source: &TemplateSource,
        scene: &Scene,
        lattice: &Lattice,
        options: &MatchOptions,
    ) -> Result<VoxelTemplate> {
        check_layers(options.layers)?;
        let template = match source {
            TemplateSource::Model(model) => Self::of_model(model, scene, lattice, options)?,
            &TemplateSource::Selection { center, radius } => {
                Self::of_selection(center, radius, scene, lattice, options)?
            }
        };
        let first = template.radius / options.layers as f64 / lattice.spec.voxel_size;
        if first < MIN_RADIUS_VOXELS {
            return Err(too_small(first, lattice.resolution));
        }
        Ok(template)
    }

    /// A separate model, voxelized on its own grid of the lattice.
    fn of_model(
        model: &TriMesh,
        scene: &Scene,
        lattice: &Lattice,
        options: &MatchOptions,
    ) -> Result<VoxelTemplate> {
        let (layers, backend) = (options.layers, options.backend);
        let voxel_size = lattice.spec.voxel_size;
        let sphere = bounding_sphere(model);
        check_extent(2.0 * sphere.radius, scene, false)?;
        let shells = connected_components(model, scene.backend());
        let parts = if shells.len() == 1 {
            Parts::Components
        } else {
            Parts::Shells(ShellRule::of_template(
                model,
                &shells,
                sphere.radius,
                PART_RADIUS_SLACK * sphere.radius,
                backend,
            ))
        };
        let spec = GridSpec::around(model.bounds(), voxel_size)?;
        check_model_fits(model, &sphere, &spec, scene, lattice)?;
        let voxels = PartVoxels::build(model, &spec, backend);
        // The surface of the template is the boundary of its solid: with
        // overlapping shells, the nearest point of a mesh may be buried
        // inside another shell. So: the nearest skin voxel, then the mesh
        // point nearest to it.
        let nearest =
            nearest_voxel(&spec, voxels.skin(), sphere.center).ok_or(Error::NothingVoxelized {
                what: "template",
                voxel_size,
            })?;
        let center = model.closest_point(spec.center(nearest)).point;
        let radius = model
            .positions()
            .iter()
            .map(|&p| from_f32(p).distance(center))
            .fold(0.0, f64::max);
        let anchor = choose_anchor(Some(model), &voxels, nearest, radius, layers, options)?;
        // Where c_T's descriptors drift, a copy lost at the anchor chosen
        // instead may be found at another: every candidate is read at all
        // of them. A copy of several shells is a part gathered with the
        // components near it, which may bury a steady anchor (the pin of
        // a knee between its thigh and shin): the further anchors are read
        // again where no copy was found.
        let mut anchors = vec![anchor.voxel];
        let first_anchors = if anchor.steady { 1 } else { usize::MAX };
        if !anchor.steady || parts != Parts::Components {
            anchors.extend(further_anchors(
                model,
                &voxels,
                anchor.voxel,
                &evenly_spaced(radius, layers),
                Thresholds::of(options),
                options.candidate_spacing,
                backend,
            )?);
        }
        Ok(VoxelTemplate {
            center,
            radius,
            radii: evenly_spaced(radius, layers),
            voxels,
            scene_part: None,
            whole_part: false,
            parts,
            min_part_radius: PART_RADIUS_SLACK * sphere.radius,
            first_anchors: first_anchors.min(anchors.len()),
            shells: shells.len(),
            anchors,
            candidate_spacing: candidate_spacing(&anchor, options),
        })
    }

    /// The scene's material within the sphere at `center` of `radius`:
    /// the part it lies on, voxelized whole where it fits one grid, else
    /// the sphere's window of it.
    fn of_selection(
        center: [f64; 3],
        radius: f64,
        scene: &Scene,
        lattice: &Lattice,
        options: &MatchOptions,
    ) -> Result<VoxelTemplate> {
        let voxel_size = lattice.spec.voxel_size;
        let snapped = snap_selection(scene, center, radius)?;
        check_extent(radius, scene, true)?;
        let part = scene.part_of_triangle(scene.mesh().closest_point(snapped).triangle);
        // The search's ball tables first: they grow faster with the radius
        // than the part's grid.
        let mut held = scene.budget();
        let radii_voxels: Vec<f64> = evenly_spaced(radius, options.layers)
            .iter()
            .map(|r| r / voxel_size)
            .collect();
        let reach = TemplateReach {
            outer_voxels: radius / voxel_size,
            resolution: lattice.resolution,
            selection: true,
        };
        held.reserve(
            Item::Template(TemplatePiece::BallTables, reach),
            ball_table_bytes(&radii_voxels),
        )?;
        let selected = &scene.parts()[part];
        let whole_part = scene.fits_one_grid(selected, lattice, radius / voxel_size);
        let voxels = if whole_part {
            scene.voxelize_part_beside(selected, lattice, radius / voxel_size, &held)?
        } else {
            // A part too large for one grid: the sphere's window.
            let sphere = Aabb {
                min: snapped - Vec3::splat(radius),
                max: snapped + Vec3::splat(radius),
            };
            scene.voxelize_around(selected, lattice, sphere, radius / voxel_size, &held)?
        };
        let nearest = nearest_voxel(voxels.grid().spec(), voxels.skin(), snapped).ok_or(
            Error::NothingVoxelized {
                what: "selected part",
                voxel_size,
            },
        )?;
        let anchor = choose_anchor(None, &voxels, nearest, radius, options.layers, options)?;
        // The selected material holds c_T and every selected vertex, so its
        // bounding sphere is at least half their distance.
        let mesh = scene.mesh();
        let reach = selected
            .triangles()
            .iter()
            .flat_map(|&t| mesh.corners(t as usize))
            .map(|p| p.distance(snapped))
            .filter(|&d| d <= radius)
            .fold(0.0, f64::max);
        Ok(VoxelTemplate {
            center: snapped,
            radius,
            radii: evenly_spaced(radius, options.layers),
            voxels,
            scene_part: Some(part),
            whole_part,
            parts: Parts::Components,
            min_part_radius: PART_RADIUS_SLACK * reach / 2.0,
            // One anchor: another, away from c_T, would read beyond the
            // sphere, material the selection did not take.
            anchors: vec![anchor.voxel],
            first_anchors: 1,
            shells: 1,
            candidate_spacing: candidate_spacing(&anchor, options),
        })
    }

    /// c_T: in the model's coordinates, or in world coordinates for a selection.
    pub fn center(&self) -> Vec3 {
        self.center
    }

    /// The outer radius r_k.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// r_1..r_k.
    pub fn radii(&self) -> &[f64] {
        &self.radii
    }

    /// The voxels the template's descriptors are read from.
    pub fn voxels(&self) -> &PartVoxels {
        &self.voxels
    }

    /// For a selection, the scene part it was made on.
    pub fn scene_part(&self) -> Option<usize> {
        self.scene_part
    }

    /// The voxels of scene part `part` when they are this template's (a
    /// selection on a part that fits one grid): the search reuses them.
    pub fn voxels_of_part(&self, part: usize) -> Option<&PartVoxels> {
        (self.scene_part == Some(part) && self.whole_part).then_some(&self.voxels)
    }

    /// How the scene is divided into parts for this template.
    pub fn parts(&self) -> Parts {
        self.parts
    }

    /// Scene parts whose bounding sphere is smaller than this cannot hold a
    /// copy.
    pub fn min_part_radius(&self) -> f64 {
        self.min_part_radius
    }

    /// The voxels the template's descriptors are computed at, the primary
    /// (c_T's, or the steadiest near it) first: a copy is found where any
    /// of them matches.
    pub fn anchors(&self) -> &[[u16; 3]] {
        &self.anchors
    }

    /// The anchors every candidate is read at: all of them where c_T's
    /// descriptors drift, else the primary alone.
    pub fn first_anchors(&self) -> Anchors {
        all_anchors(self.first_anchors)
    }

    /// The anchors read again at the candidates that no copy found at
    /// [`VoxelTemplate::first_anchors`] explains: a steady template of
    /// several shells' further anchors, else none.
    pub fn fallback_anchors(&self) -> Anchors {
        all_anchors(self.anchors.len()) & !self.first_anchors()
    }

    /// How many connected components the template has: a part of fewer
    /// cannot hold a copy whose shells stand apart.
    pub fn shells(&self) -> usize {
        self.shells
    }

    /// One candidate per cube of this many voxels: the option's, or 1
    /// where even the steadiest anchor differs from its neighbours by
    /// more than a threshold.
    pub fn candidate_spacing(&self) -> u32 {
        self.candidate_spacing
    }

    /// c_T relative to the centre of anchor `anchor`, in voxels.
    pub fn center_offset(&self, anchor: usize) -> Vec3 {
        let spec = self.voxels.grid().spec();
        (self.center - spec.center(self.anchors[anchor])) * (1.0 / spec.voxel_size)
    }

    /// Where anchor `anchor` lies in the template's coordinates.
    pub fn anchor_position(&self, anchor: usize) -> Vec3 {
        self.voxels.grid().spec().center(self.anchors[anchor])
    }
}

/// The minimal bounding sphere of the vertices `mesh`'s triangles use.
pub(super) fn bounding_sphere(mesh: &TriMesh) -> Sphere {
    // Each vertex once, whatever the number of triangles using it.
    let mut is_used = vec![false; mesh.positions().len()];
    for &i in mesh.triangles().iter().flatten() {
        is_used[i as usize] = true;
    }
    let used: Vec<Vec3> = (0..is_used.len())
        .filter(|&i| is_used[i])
        .map(|i| mesh.vertex(i as u32))
        .collect();
    minimal_bounding_sphere(&used).expect("a TriMesh has triangles")
}

/// The error for a first radius of `radius_voxels` voxels at `resolution`,
/// with the resolution that would fit it, if any.
fn too_small(radius_voxels: f64, resolution: u32) -> Error {
    let needed = (f64::from(resolution) * MIN_RADIUS_VOXELS / radius_voxels).ceil();
    let advice = if needed <= 16384.0 {
        format!(
            "raise the resolution to at least {needed} (now {resolution}), use fewer layers, or pick a larger template"
        )
    } else {
        format!(
            "no resolution fits: it would need {needed:.3e} voxels along the scene, above the maximum of 16384; check that both files use the same units, or search a smaller part of the scene"
        )
    };
    Error::TemplateTooSmall {
        radius_voxels,
        min_voxels: MIN_RADIUS_VOXELS,
        advice,
    }
}

/// The run tables of the volume and verification balls for layer radii of
/// `radii` voxels.
pub(crate) fn ball_table_bytes(radii: &[f64]) -> u64 {
    radii.iter().fold(0u64, |sum, &r| {
        sum.saturating_add(ball_bytes(r, level_for_radius(r, BLOCKS_PER_RADIUS)))
            .saturating_add(ball_bytes(r, moment_level(r)))
    })
}
