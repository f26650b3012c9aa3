//! Templates: what to look for, reduced to a centre c_T, radii r_1..r_k and
//! the voxel grid its descriptors are read from.
//!
//! - A separate model: c_T is the surface point nearest to the centre of the
//!   model's minimal bounding sphere, r_k the distance from c_T to the
//!   farthest model point (paper, sec. 5). "Surface" is the boundary of the
//!   model's solid: where shells overlap, a point of one shell buried in
//!   another is not on it. The model is voxelized with the
//!   scene's voxel size, so that radii and fractions mean the same on both
//!   sides.
//! - A selection sphere on the scene: its centre snapped to the nearest
//!   surface point, and its radius; the descriptors are read from the scene.
//!
//! The radii are evenly spaced, r_i = r_k i / k. The voxel descriptors are
//! computed at the skin voxel nearest to c_T, a point of the same kind as the
//! scene's candidates; the curvature descriptor at the mesh vertex nearest to
//! c_T ([`CurvatureTemplate`]), for the same reason.

mod anchor;
mod curvature;
mod voxel;

pub use curvature::CurvatureTemplate;
pub use voxel::VoxelTemplate;
pub(crate) use voxel::ball_table_bytes;

use crate::error::{Error, Result};
use crate::math::Vec3;
use crate::mesh::TriMesh;
use crate::scene::Scene;

/// Below this many voxels, the first layer cannot describe anything.
pub const MIN_RADIUS_VOXELS: f64 = 1.5;

/// Where a template comes from.
#[derive(Clone, Debug)]
pub enum TemplateSource {
    /// A separate model, in its own coordinates.
    Model(TriMesh),
    /// A part of the scene inside a sphere (world coordinates).
    Selection {
        /// Centre of the sphere.
        center: [f64; 3],
        /// Its radius.
        radius: f64,
    },
}

impl TemplateSource {
    /// The radius the template spans before it is built: a model's
    /// bounding sphere, a selection's sphere. It sizes a search's voxels
    /// ([`Scene::lattice_for`]).
    pub fn bounding_radius(&self) -> f64 {
        match self {
            TemplateSource::Model(model) => voxel::bounding_sphere(model).radius,
            TemplateSource::Selection { radius, .. } => *radius,
        }
    }
}

/// Fails when the template is wider than the whole scene (the bounding
/// box's diagonal): it cannot occur there, and its onion balls would be
/// far larger than anything the scene holds. `size` is a model's diameter
/// or a selection sphere's radius (a sphere centred on the surface covers
/// the whole scene once its radius reaches the diagonal).
pub(super) fn check_extent(size: f64, scene: &Scene, selection: bool) -> Result<()> {
    let diagonal = scene.mesh().bounds().extent().length();
    if size <= diagonal * (1.0 + 1e-9) {
        return Ok(());
    }
    let advice = if selection {
        format!(
            "the sphere takes in all of it: pick a radius that holds one part, below {}",
            crate::error::length(diagonal)
        )
    } else {
        format!(
            "it is {:.3e} times larger: check that both files use the same units (millimetres and metres differ 1000 times)",
            size / diagonal
        )
    };
    Err(Error::TemplateLargerThanScene {
        template_size: if selection { 2.0 * size } else { size },
        scene_size: diagonal,
        advice,
    })
}

/// r_i = r_k i / k for i = 1..=k.
pub(super) fn evenly_spaced(radius: f64, layers: usize) -> Vec<f64> {
    (1..=layers)
        .map(|i| radius * i as f64 / layers as f64)
        .collect()
}

pub(super) fn check_layers(layers: usize) -> Result<()> {
    if layers == 0 {
        return Err(Error::invalid_option(
            "layers",
            "at least one layer is needed",
        ));
    }
    Ok(())
}

/// The selection sphere's centre snapped to the nearest point of the
/// scene's mesh; an error if the sphere is unusable or touches no surface.
pub(super) fn snap_selection(scene: &Scene, center: [f64; 3], radius: f64) -> Result<Vec3> {
    let c = Vec3::new(center[0], center[1], center[2]);
    let finite = c.x.is_finite() && c.y.is_finite() && c.z.is_finite();
    if !(finite && radius.is_finite() && radius > 0.0) {
        return Err(Error::invalid_option(
            "select",
            format!(
                "the sphere needs a finite centre and a positive radius, got {center:?} and {radius}"
            ),
        ));
    }
    let nearest = scene.mesh().closest_point(c);
    let distance = nearest.distance2.sqrt();
    if distance > radius {
        return Err(Error::SelectionMissesScene {
            center,
            radius,
            distance,
        });
    }
    Ok(nearest.point)
}

#[cfg(test)]
mod tests;
