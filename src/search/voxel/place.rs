//! Verifying and placing a grid's survivors: the local bests of each
//! anchor checked by the template's placement ([`crate::verify`]),
//! grouped into instances, each aligned on the meshes around it (its pose
//! and score); and an instance carried to a congruent copy of its part.

use super::prepare::PartSearch;
use super::whole::{Components, is_whole, template_index};
use super::work::{CHECK, loose_thresholds};
use crate::align::{Rigid, SurfaceIndex, SurfaceSamples, align, stray_share, surface_fit};
use crate::cascade::Survivor;
use crate::error::Result;
use crate::instances::{
    Instance, Verified, group, local_bests, merge_duplicates, placement_transform, stray_decides,
};
use crate::math::{Aabb, Vec3};
use crate::scene::{PartVoxels, Scene, ScenePart};
use crate::template::VoxelTemplate;

impl PartSearch<'_> {
    /// The placements that pass verification, anchor by anchor: each
    /// anchor's local bests among `survivors`, but for a blob where a copy
    /// already placed puts this anchor (that copy, seen from another
    /// anchor); and how many placements were checked. Refused where the
    /// checks would take more than `work_left`.
    pub(super) fn verify(
        &self,
        voxels: &PartVoxels,
        survivors: &[Survivor],
        work_left: f64,
    ) -> Result<(Vec<Verified>, usize)> {
        let (template, options) = (&self.template, self.options);
        let radii = template.radii();
        let voxel = voxels.grid().spec().voxel_size;
        let position = |p| voxels.position(p);
        let mut verified: Vec<Verified> = Vec::new();
        let mut checks = 0;
        for (a, verifier) in self.verifiers.iter().enumerate() {
            let of_anchor: Vec<Survivor> = survivors
                .iter()
                .filter(|s| s.anchors & (1 << a) != 0)
                .copied()
                .collect();
            let bests: Vec<Survivor> = local_bests(&of_anchor, position, radii[0])
                .into_iter()
                .filter(|b| {
                    let p = position(b.point);
                    verified.iter().all(|v| {
                        v.pose.is_none_or(|pose| {
                            Rigid::from_rows(&pose)
                                .apply(template.anchor_position(a))
                                .distance(p)
                                > radii[0]
                        })
                    })
                })
                .collect();
            checks += bests.len();
            if checks as f64 * CHECK > work_left {
                return Err(loose_thresholds(
                    self.options.max_part_work,
                    format!("{checks} placements passed every layer, each to be verified"),
                ));
            }
            let checked = options.backend.map_each(bests.len(), |b| {
                let v = voxels.skin()[bests[b].point as usize];
                let placement = verifier.check(
                    voxels.solid(),
                    voxels.near_surface(),
                    voxels.skin(),
                    v,
                    options.verify_threshold,
                    self.two_sided,
                );
                let position = voxels.position(bests[b].point) + placement.offset * voxel;
                Verified {
                    survivor: bests[b],
                    score: placement.score(),
                    position,
                    pose: Some(placement_transform(
                        &placement.rotation,
                        template.center(),
                        position,
                    )),
                }
            });
            verified.extend(
                checked
                    .into_iter()
                    .filter(|v| v.score >= options.verify_threshold),
            );
        }
        Ok((verified, checks))
    }

    /// The instances `verified` placements make, grouped with the
    /// `survivors` they gather, aligned on `part`'s meshes, and kept where
    /// the meshes agree at the exact pose; and how many were aligned.
    pub(super) fn place(
        &self,
        part: &ScenePart,
        voxels: &PartVoxels,
        verified: &[Verified],
        survivors: &[Survivor],
    ) -> (Vec<Instance>, usize) {
        let options = self.options;
        let mut instances = group(
            verified,
            survivors,
            |p| voxels.position(p),
            options.group_radius * self.template.radius(),
            Some(&self.extent),
        );
        let landed = align_instances(
            &mut instances,
            self.scene,
            part,
            voxels,
            &self.samples,
            &self.template,
            self.max_hidden,
            options.surface_tolerance,
            options.backend,
        );
        self.tell_whole(&mut instances, part, &landed);
        // The meshes' verdict at the exact pose.
        instances.retain(|i| i.score.is_none_or(|s| s >= options.verify_threshold));
        if options.whole_copies {
            instances.retain(|i| i.whole == Some(true));
        }
        // Placements of one copy kept apart before their poses were
        // refined meet there.
        let reach = options.group_radius * self.template.radius();
        (
            merge_duplicates(instances, reach, Some(&self.extent)),
            landed.len(),
        )
    }

    /// Says of each instance that passes the meshes' verdict whether it is
    /// a whole copy ([`super::whole`]); `landed` holds the scene triangles
    /// its template samples lie on.
    fn tell_whole(&self, instances: &mut [Instance], part: &ScenePart, landed: &[Vec<u32>]) {
        let passes = |i: &Instance| i.score.is_some_and(|s| s >= self.options.verify_threshold);
        if !instances.iter().any(passes) {
            return;
        }
        let mesh = self.scene.mesh();
        // A template of one component searches parts of one component.
        let components = Components::of(mesh, part.triangles(), self.two_sided);
        let tolerance = self.options.surface_tolerance * self.template.radius();
        let index = template_index(&self.surface, tolerance);
        for (instance, landed) in instances.iter_mut().zip(landed) {
            if let (true, Some(pose)) = (passes(instance), instance.pose) {
                let pose = Rigid::from_rows(&pose);
                instance.whole = Some(is_whole(
                    mesh,
                    &components,
                    landed,
                    &self.samples,
                    &index,
                    &pose,
                    tolerance,
                ));
            }
        }
    }
}

/// A sample this share of r_k off the scene's surface, once the pose is
/// refit on what fits closely, is off: a copy meshed anew lies within its
/// chords (about 1e-3 r_k), a near twin's differing part farther.
const STRAY_OFF: f64 = 0.01;

/// Refines each instance's pose on the meshes ([`crate::align`]): the
/// template's samples onto `part`'s triangles around the instance. The
/// instance's position follows its pose, its score falls to the share
/// of the template's surface within `surface_tolerance` of r_k of the
/// scene's there (what lands inside `voxels`' solid is hidden, up to
/// `max_hidden`), and its residual is that surface's distance. Returns,
/// per instance, the scene triangles its samples landed on.
#[allow(clippy::too_many_arguments)]
fn align_instances(
    instances: &mut [Instance],
    scene: &Scene,
    part: &ScenePart,
    voxels: &PartVoxels,
    samples: &SurfaceSamples,
    template: &VoxelTemplate,
    max_hidden: f64,
    surface_tolerance: f64,
    backend: crate::exec::Threads,
) -> Vec<Vec<u32>> {
    if samples.is_empty() {
        return vec![Vec::new(); instances.len()];
    }
    let mesh = scene.mesh();
    let voxel = voxels.grid().spec().voxel_size;
    let reach = template.radius() + 4.0 * voxel;
    let tolerance = surface_tolerance * template.radius();
    // Inside the solid, and a voxel clear of its surface.
    let hidden = |p: Vec3| {
        let v = voxels.grid().spec().voxel_of(p);
        voxels.grid().get(v[0], v[1], v[2]) && !voxels.near_surface().get(v[0], v[1], v[2])
    };
    let refined = backend.map_each(instances.len(), |i| {
        let start = Rigid::from_rows(&instances[i].pose?);
        let p = Vec3::from_array(instances[i].position);
        let bounds = Aabb {
            min: p - Vec3::splat(reach),
            max: p + Vec3::splat(reach),
        };
        let triangles: Vec<u32> = part
            .triangles()
            .iter()
            .copied()
            .filter(|&t| {
                Aabb::around(mesh.corners(t as usize)).is_some_and(|b| b.distance_to(p) <= reach)
            })
            .collect();
        // Cells of 1.5 voxels, or of a 48th of the box for a template of
        // many: queries reach a voxel or three.
        let cell = (1.5 * voxel).max(2.0 * reach / 48.0);
        let index = SurfaceIndex::new(mesh, triangles, bounds, cell);
        let pose = align(samples, &index, start, voxel).pose;
        let fit = surface_fit(samples, &index, pose, tolerance, hidden, max_hidden);
        let (centre, radius) = (template.center(), template.radius());
        let stray = stray_decides(
            fit.score(),
            fit.residual,
            pose.apply(centre),
            centre,
            radius,
        )
        .then(|| stray_share(samples, &index, pose, voxel, STRAY_OFF * radius, hidden));
        Some((pose, fit, stray))
    });
    instances
        .iter_mut()
        .zip(refined)
        .map(|(instance, refined)| {
            let Some((pose, fit, stray)) = refined else {
                return Vec::new();
            };
            instance.stray = stray;
            instance.pose = Some(pose.to_rows());
            instance.position = pose.apply(template.center()).to_array();
            instance.score = Some(fit.score());
            instance.residual = Some(fit.residual);
            fit.landed
        })
        .collect()
}

/// `instance`, found on a part, on that part's copy `motion` away.
pub(super) fn moved_instance(instance: &Instance, motion: &Rigid) -> Instance {
    Instance {
        position: motion.apply(Vec3::from_array(instance.position)).to_array(),
        pose: instance
            .pose
            .map(|pose| motion.after(&Rigid::from_rows(&pose)).to_rows()),
        ..instance.clone()
    }
}
