//! A template for the curvature descriptor, prepared on the mesh: no
//! voxels, c_T is a mesh vertex.

use super::{TemplateSource, check_extent, check_layers, evenly_spaced, snap_selection};
use crate::descriptor::curvature::Surface;
use crate::error::Result;
use crate::math::Vec3;
use crate::mesh::minimal_bounding_sphere;
use crate::scene::Scene;

/// A template for the curvature descriptor, prepared on the mesh: no voxels.
pub struct CurvatureTemplate {
    vertex: u32,
    center: Vec3,
    radius: f64,
    radii: Vec<f64>,
    own_surface: Option<Surface>,
}

impl CurvatureTemplate {
    /// Prepares `source` for searching `scene`'s surface with `layers` radii.
    /// c_T is the template's (or for a selection, the scene's) mesh vertex
    /// nearest to the surface point the voxel templates use.
    pub fn new(source: &TemplateSource, scene: &Scene, layers: usize) -> Result<CurvatureTemplate> {
        check_layers(layers)?;
        let (own_surface, target, radius) = match source {
            TemplateSource::Model(mesh) => {
                let surface = Surface::new(mesh, scene.backend());
                let used: Vec<Vec3> = surface
                    .used_vertices()
                    .map(|v| surface.position(v))
                    .collect();
                let sphere = minimal_bounding_sphere(&used).expect("a TriMesh has triangles");
                check_extent(2.0 * sphere.radius, scene, false)?;
                (Some(surface), mesh.closest_point(sphere.center).point, None)
            }
            &TemplateSource::Selection { center, radius } => {
                let snapped = snap_selection(scene, center, radius)?;
                check_extent(radius, scene, true)?;
                (None, snapped, Some(radius))
            }
        };
        let surface = own_surface.as_ref().unwrap_or(scene.surface());
        let vertex = surface
            .nearest_vertex(target)
            .expect("a surface with triangles has a used vertex");
        let center = surface.position(vertex);
        let radius = radius.unwrap_or_else(|| {
            surface
                .used_vertices()
                .map(|v| surface.position(v).distance(center))
                .fold(0.0, f64::max)
        });
        Ok(CurvatureTemplate {
            vertex,
            center,
            radius,
            radii: evenly_spaced(radius, layers),
            own_surface,
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

    /// The vertex the template's descriptor is computed at, on
    /// [`CurvatureTemplate::surface`].
    pub fn vertex(&self) -> u32 {
        self.vertex
    }

    /// The surface the template's descriptor is read from.
    pub fn surface<'a>(&'a self, scene: &'a Scene) -> &'a Surface {
        self.own_surface.as_ref().unwrap_or(scene.surface())
    }
}
