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
//! c_T ([`SurfaceTemplate`]), for the same reason.

use crate::budget::{mesh_bytes, voxel_bytes};
use crate::descriptor::curvature::Surface;
use crate::error::{Error, Result};
use crate::exec::Backend;
use crate::math::Vec3;
use crate::mesh::{TriMesh, minimal_bounding_sphere};
use crate::scene::{Scene, check_voxel_work, nearest_voxel};
use crate::voxel::{GridSpec, Solid, skin, voxelize};

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

/// A template prepared against a scene.
pub struct Template {
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

impl Template {
    /// Prepares `source` for searching `scene` with `layers` radii.
    pub fn new(
        source: &TemplateSource,
        scene: &Scene,
        layers: usize,
        backend: Backend,
    ) -> Result<Template> {
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
                let radius = used.iter().map(|p| p.dist(center)).fold(0.0, f64::max);
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
        Ok(Template {
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

    /// The skin voxels of [`Template::solid`].
    pub fn skin<'a>(&'a self, scene: &'a Scene) -> &'a [[u16; 3]] {
        self.own.as_ref().map_or(scene.skin(), |own| &own.skin)
    }

    /// The voxel the template's descriptors are computed at.
    pub fn voxel(&self) -> [u16; 3] {
        self.voxel
    }

    /// c_T relative to the centre of [`Template::voxel`], in voxels.
    pub fn center_offset(&self, scene: &'_ Scene) -> Vec3 {
        let spec = self.solid(scene).bits().spec();
        (self.center - spec.center(self.voxel)) * (1.0 / spec.voxel_size)
    }
}

/// A template for the curvature descriptor, prepared on the mesh: no voxels.
pub struct SurfaceTemplate {
    vertex: u32,
    center: Vec3,
    radius: f64,
    radii: Vec<f64>,
    own_surface: Option<Surface>,
}

impl SurfaceTemplate {
    /// Prepares `source` for searching `scene`'s surface with `layers` radii.
    /// c_T is the template's (or for a selection, the scene's) mesh vertex
    /// nearest to the surface point the voxel templates use.
    pub fn new(source: &TemplateSource, scene: &Scene, layers: usize) -> Result<SurfaceTemplate> {
        check_layers(layers)?;
        let (own_surface, target, radius) = match source {
            TemplateSource::Model(mesh) => {
                let surface = Surface::new(mesh);
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
                .map(|v| surface.position(v).dist(center))
                .fold(0.0, f64::max)
        });
        Ok(SurfaceTemplate {
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
    /// [`SurfaceTemplate::surface`].
    pub fn vertex(&self) -> u32 {
        self.vertex
    }

    /// The surface the template's descriptor is read from.
    pub fn surface<'a>(&'a self, scene: &'a Scene) -> &'a Surface {
        self.own_surface.as_ref().unwrap_or(scene.surface())
    }
}

/// Fails when the template is wider than the whole scene (the bounding
/// box's diagonal): it cannot occur there, and its onion balls would be
/// far larger than anything the scene holds. `size` is a model's diameter
/// or a selection sphere's radius (a sphere centred on the surface covers
/// the whole scene once its radius reaches the diagonal).
fn check_extent(size: f64, scene: &Scene, selection: bool) -> Result<()> {
    let diagonal = scene.mesh().bounds().extent().norm();
    if size <= diagonal * (1.0 + 1e-9) {
        return Ok(());
    }
    let advice = if selection {
        format!(
            "the sphere takes in all of it: pick a radius that holds one part, below {}",
            crate::budget::length(diagonal)
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

/// r_i = r_k i / k for i = 1..=k.
fn evenly_spaced(radius: f64, layers: usize) -> Vec<f64> {
    (1..=layers)
        .map(|i| radius * i as f64 / layers as f64)
        .collect()
}

fn check_layers(layers: usize) -> Result<()> {
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
fn snap_selection(scene: &Scene, center: [f64; 3], radius: f64) -> Result<Vec3> {
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
