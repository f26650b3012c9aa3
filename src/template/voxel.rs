//! A template for the voxel descriptors: c_T and the radii, and the grid
//! its descriptors are read from (its own for a model, the scene's for a
//! selection).

use super::{
    MIN_RADIUS_VOXELS, TemplateSource, check_extent, check_layers, evenly_spaced, snap_selection,
};
use crate::budget::{mesh_bytes, voxel_bytes};
use crate::error::{Error, Result};
use crate::exec::Backend;
use crate::math::Vec3;
use crate::mesh::minimal_bounding_sphere;
use crate::scene::{Scene, check_voxel_work, nearest_voxel};
use crate::voxel::{GridSpec, Solid, skin, voxelize};

/// A template prepared against a scene.
pub struct VoxelTemplate {
    center: Vec3,
    radius: f64,
    radii: Vec<f64>,
    /// A separate model's own voxels; a selection reads the scene's.
    own: Option<OwnVoxels>,
    voxel: [u16; 3],
}

/// A template model's solid and its skin voxels (z, y, x order).
struct OwnVoxels {
    solid: Solid,
    skin: Vec<[u16; 3]>,
}

impl VoxelTemplate {
    /// Prepares `source` for searching `scene` with `layers` radii.
    pub fn new(
        source: &TemplateSource,
        scene: &Scene,
        layers: usize,
        backend: Backend,
    ) -> Result<VoxelTemplate> {
        check_layers(layers)?;
        let voxel_size = scene.voxel_size();
        let (center, radius, own, voxel) = match source {
            TemplateSource::Model(mesh) => {
                // Each vertex once, whatever the number of triangles using it.
                let mut is_used = vec![false; mesh.positions().len()];
                for &i in mesh.triangles().iter().flatten() {
                    is_used[i as usize] = true;
                }
                let used: Vec<Vec3> = (0..is_used.len())
                    .filter(|&i| is_used[i])
                    .map(|i| mesh.vertex(i as u32))
                    .collect();
                let sphere = minimal_bounding_sphere(&used).expect("a TriMesh has triangles");
                check_extent(2.0 * sphere.radius, scene, false)?;
                let spec = GridSpec::around(mesh.bounds(), voxel_size)?;
                check_voxel_work(
                    "template",
                    mesh,
                    voxel_size,
                    scene.resolution(),
                    scene.max_voxel_work(),
                )?;
                let mut estimate = scene.voxel_estimate();
                estimate
                    .add(
                        "the template's mesh",
                        mesh_bytes(mesh.positions().len(), mesh.triangles().len()),
                    )
                    .add("the template's voxel grids", voxel_bytes(&spec));
                estimate.check(scene.memory_budget(), || {
                    format!(
                        "lower the resolution (now {}), or raise the memory budget",
                        scene.resolution()
                    )
                })?;
                let grid = voxelize(mesh, &spec, backend);
                let skin: Vec<[u16; 3]> = skin(&grid, backend).iter_ones().collect();
                // The surface of the template is the boundary of its solid:
                // with overlapping shells, the nearest point of a mesh may be
                // buried inside another shell. So: the nearest skin voxel,
                // then the mesh point nearest to it.
                let voxel =
                    nearest_voxel(&spec, &skin, sphere.center).expect("a voxelized mesh has skin");
                let center = mesh.closest_point(spec.center(voxel)).point;
                let radius = used.iter().map(|p| p.distance(center)).fold(0.0, f64::max);
                let own = OwnVoxels {
                    solid: Solid::new(grid),
                    skin,
                };
                (center, radius, Some(own), voxel)
            }
            &TemplateSource::Selection { center, radius } => {
                let snapped = snap_selection(scene, center, radius)?;
                check_extent(radius, scene, true)?;
                let voxel = nearest_voxel(scene.grid().spec(), scene.skin(), snapped)
                    .expect("a scene has skin");
                (snapped, radius, None, voxel)
            }
        };
        let first = radius / layers as f64;
        if first / voxel_size < MIN_RADIUS_VOXELS {
            return Err(too_small(first / voxel_size, scene.resolution()));
        }
        Ok(VoxelTemplate {
            center,
            radius,
            radii: evenly_spaced(radius, layers),
            own,
            voxel,
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

    /// The solid the template's descriptors are read from.
    pub fn solid<'a>(&'a self, scene: &'a Scene) -> &'a Solid {
        self.own.as_ref().map_or(scene.solid(), |own| &own.solid)
    }

    /// The skin voxels of [`VoxelTemplate::solid`].
    pub fn skin<'a>(&'a self, scene: &'a Scene) -> &'a [[u16; 3]] {
        self.own.as_ref().map_or(scene.skin(), |own| &own.skin)
    }

    /// The voxel the template's descriptors are computed at.
    pub fn voxel(&self) -> [u16; 3] {
        self.voxel
    }

    /// c_T relative to the centre of [`VoxelTemplate::voxel`], in voxels.
    pub fn center_offset(&self, scene: &'_ Scene) -> Vec3 {
        let spec = self.solid(scene).bits().spec();
        (self.center - spec.center(self.voxel)) * (1.0 / spec.voxel_size)
    }
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
