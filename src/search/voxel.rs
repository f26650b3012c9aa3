//! The voxel pipeline, part by part: each scene part's solid and skin
//! voxels, a template with its own grid or a selection of a part's, the
//! volume and harmonics stages, then verification by placement and
//! grouping.

use super::GpuRef;
use super::congruent_parts::congruent_parts;
use super::near_vertices::{self, NearVertices, template_gap};
use super::options::{DescriptorKind, MatchOptions};
use super::report::{GridInfo, MatchReport, TemplateInfo, Timings};
use super::windows::{Window, part_windows};
use crate::align::{Rigid, SurfaceIndex, SurfaceSamples, align, surface_agreement};
use crate::budget::{add_ball_tables, candidate_bytes, voxel_bytes};
use crate::cascade::{LayerStats, Observer, Stage, Survivor, all_anchors, run_cascade};
use crate::clock::now_ms;
use crate::descriptor::harmonics::ClutterGuard;
use crate::descriptor::harmonics::Signature as HarmonicsSignature;
use crate::descriptor::{HarmonicsDescriptor, LayerBatch, SphericalTransform, VolumeDescriptor};
use crate::error::{Error, MemoryEstimate, Result};
use crate::instances::{
    Instance, Verified, best_first, group, local_bests, merge_duplicates, placement_transform,
};
use crate::math::{Aabb, Vec3};
use crate::scene::{Lattice, PartVoxels, Parts, Scene, ScenePart};
use crate::template::{TemplateSource, VoxelTemplate};
use crate::verify::Verifier;
use crate::voxel::{Ball, WindowedMesh, spaced};

/// Searches `scene`'s skin voxels for `source` with the voxel descriptors,
/// part by part: each connected part of the scene large enough to hold a
/// copy is voxelized on its own, so that what touches it or sits in it does
/// not hide it.
pub(super) async fn search_voxels(
    scene: &Scene,
    source: &TemplateSource,
    options: &MatchOptions,
    observer: &mut dyn Observer,
    gpu: GpuRef<'_>,
) -> Result<MatchReport> {
    let t0 = now_ms();
    // A small template refines the grid until it spans enough voxels.
    let lattice = if options.template_voxels > 0.0 {
        scene.lattice_for(
            VoxelTemplate::bounding_radius(source),
            options.template_voxels,
        )?
    } else {
        scene.lattice()
    };
    let template = VoxelTemplate::new(source, scene, &lattice, options)?;
    let radii = template.radii();
    let (tvoxels, anchors, backend) = (template.voxels(), template.anchors(), options.backend);
    let voxel = lattice.spec.voxel_size;
    let radii_voxels: Vec<f64> = radii.iter().map(|r| r / voxel).collect();
    let held = search_estimate(scene, &template, &radii_voxels);
    held.check(scene.memory_budget(), || {
        too_much_for_template(&radii_voxels, &lattice)
    })?;
    let transform = SphericalTransform::new();
    // The balls' tables are built once: read at the template's one point,
    // then bound to each part's layout.
    let balls = VolumeDescriptor::unbound_balls(radii, voxel, backend);
    let template_volume: Vec<Vec<f64>> = anchors
        .iter()
        .map(|&a| VolumeDescriptor::describe_with(tvoxels.solid(), a, &balls, backend))
        .collect();
    let template_harmonics = (options.descriptor != DescriptorKind::Volume).then(|| {
        anchors
            .iter()
            .map(|&a| HarmonicsDescriptor::describe(tvoxels.solid(), a, radii, &transform, backend))
            .collect::<Vec<_>>()
    });
    let max_hidden = options.hidden_surface_for(matches!(source, TemplateSource::Selection { .. }));
    let verifiers: Vec<Verifier> = anchors
        .iter()
        .enumerate()
        .map(|(i, &a)| {
            Verifier::new(
                tvoxels.solid(),
                tvoxels.skin(),
                tvoxels.near_surface(),
                a,
                template.center_offset(i),
                &radii_voxels,
                max_hidden,
                backend,
            )
        })
        .collect();
    let reach = template.radius() / voxel;
    let parts: Vec<(usize, &ScenePart)> = scene
        .parts(template.parts())
        .iter()
        .enumerate()
        .filter(|(_, part)| part.radius() >= template.min_part_radius())
        .collect();
    check_part_volume(scene, &lattice, &parts, reach)?;
    let samples = template_samples(source, scene, &template);
    // A copy's anchor lies as near a vertex of its part as the template's
    // anchors lie near one of the template's.
    let mesh = scene.mesh();
    let anchor_points: Vec<Vec3> = (0..anchors.len())
        .map(|a| template.anchor_position(a))
        .collect();
    let gap = match source {
        TemplateSource::Model(model) => template_gap(
            &anchor_points,
            (0..model.triangles().len()).flat_map(|t| model.corners(t)),
        ),
        TemplateSource::Selection { .. } => {
            let part = template
                .scene_part()
                .expect("a selection lies on a scene part");
            template_gap(
                &anchor_points,
                scene.parts(Parts::Components)[part]
                    .triangles()
                    .iter()
                    .flat_map(|&t| mesh.corners(t as usize)),
            )
        }
    };
    let searcher = PartSearch {
        scene,
        template: &template,
        options,
        balls,
        template_volume,
        template_harmonics,
        transform,
        verifiers,
        samples,
        max_hidden,
        // A part is one component: what the template does not explain of
        // it is the copy's own (see `Verifier::check`).
        two_sided: template.parts() == Parts::Components,
        vertex_reach: near_vertices::reach(gap, template.candidate_spacing(), voxel, radii[0]),
        held,
        lattice: &lattice,
    };
    let template_ms = now_ms() - t0;
    let mut found = Found::default();
    // What a part's copies take from it, moved.
    let lists: Vec<&[u32]> = parts.iter().map(|(_, p)| p.triangles()).collect();
    let copies = congruent_parts(mesh, &lists);
    let mut found_on: Vec<Vec<Instance>> = vec![Vec::new(); parts.len()];
    for (k, &(i, part)) in parts.iter().enumerate() {
        if let Some((original, motion)) = &copies[k] {
            let moved: Vec<Instance> = found_on[*original]
                .iter()
                .map(|instance| moved_instance(instance, motion))
                .collect();
            found.instances.extend(moved);
            continue;
        }
        let mut runner = Runner { observer, gpu };
        let instances = searcher.part(i, part, &mut found, &mut runner).await?;
        found_on[k] = instances.clone();
        found.instances.extend(instances);
    }
    // Best first over all parts, as within one.
    found.instances.sort_by(best_first);
    Ok(MatchReport {
        template: TemplateInfo::of(template.center(), template.radius()),
        instances: found.instances,
        stages: found.stages,
        grid: Some(GridInfo {
            resolution: lattice.resolution,
            voxel_size: voxel,
            skin_voxels: found.skin_voxels,
            windows: found.windows,
        }),
        surface: None,
        gpu: gpu_info(gpu, found.gpu_fallback),
        timings: Timings {
            template: template_ms,
            ..found.timings
        },
    })
}

/// What searching one part needs: the template's side, prepared once.
struct PartSearch<'a> {
    scene: &'a Scene,
    template: &'a VoxelTemplate,
    options: &'a MatchOptions,
    lattice: &'a Lattice,
    /// The volume balls' tables, bound to each grid's layout.
    balls: Vec<Ball>,
    /// Per anchor: the template's volume and harmonics signatures.
    template_volume: Vec<Vec<f64>>,
    template_harmonics: Option<Vec<Vec<HarmonicsSignature>>>,
    transform: SphericalTransform,
    /// Per anchor: the verifier placed by it.
    verifiers: Vec<Verifier>,
    samples: SurfaceSamples,
    max_hidden: f64,
    two_sided: bool,
    /// How far from a vertex of its part a copy's anchor can lie.
    vertex_reach: f64,
    /// What the search holds besides a part's grids.
    held: MemoryEstimate,
}

/// The report's line on the GPU given.
#[cfg(feature = "gpu")]
fn gpu_info(gpu: GpuRef<'_>, fallback: Option<String>) -> Option<super::GpuInfo> {
    gpu.map(|g| super::GpuInfo {
        adapter: g.description(),
        fallback,
    })
}

#[cfg(not(feature = "gpu"))]
fn gpu_info(_: GpuRef<'_>, _: Option<String>) -> Option<super::GpuInfo> {
    None
}

impl PartSearch<'_> {
    /// The instances on scene part `index`: on its own grid, or window by
    /// window when it is too large for one.
    async fn part(
        &self,
        index: usize,
        part: &ScenePart,
        found: &mut Found,
        runner: &mut Runner<'_>,
    ) -> Result<Vec<Instance>> {
        let (scene, template) = (self.scene, self.template);
        let backend = self.options.backend;
        let voxel = self.lattice.spec.voxel_size;
        let reach = template.radius() / voxel;
        let mesh = scene.mesh();
        let near = NearVertices::new(
            mesh,
            part.triangles(),
            part.bounds(),
            self.vertex_reach,
            backend,
        );
        let Some(windows) = part_windows(scene, part, self.lattice, reach) else {
            let fresh;
            let voxels = match template.voxels_of_part(index) {
                Some(voxels) => voxels,
                None => {
                    fresh = scene.voxelize_part(part, self.lattice, reach, &self.held)?;
                    found.timings.voxelize += fresh.voxelize_ms();
                    &fresh
                }
            };
            return self
                .grid(part, voxels, None, near.as_ref(), found, runner)
                .await;
        };
        let windowed = WindowedMesh::new(mesh.subset(part.triangles()), backend);
        let mut held = self.held.clone();
        held.add("a large part's mesh for its windows", windowed.bytes());
        let mut instances: Vec<Instance> = Vec::new();
        for window in &windows {
            let core = window.core_bounds();
            // No copy can be anchored here.
            if near.as_ref().is_some_and(|n| !n.any_in(&core)) {
                continue;
            }
            // A candidate the vertex test passes lies within its farthest
            // distance of a vertex, so of a triangle that meets the core
            // grown by it: the core is cut down to those triangles' box,
            // grown by it (a window over a terrain or a scan is mostly empty
            // space above and below the sheet).
            let fitted;
            let window = match near.as_ref() {
                Some(near) => {
                    let far = Vec3::splat(near.farthest());
                    let grown = Aabb {
                        min: core.min - far,
                        max: core.max + far,
                    };
                    let Some(content) = windowed.content_in(&grown) else {
                        continue;
                    };
                    let Some(fit) = window.fitted(&Aabb {
                        min: content.min - far,
                        max: content.max + far,
                    }) else {
                        continue;
                    };
                    fitted = fit;
                    &fitted
                }
                None => window,
            };
            let mut estimate = held.clone();
            estimate.add(
                "a window's voxel grids and count pyramid",
                voxel_bytes(&window.spec),
            );
            estimate.check(scene.memory_budget(), || {
                "a large part's window does not fit beside the search: raise the memory budget"
                    .into()
            })?;
            let voxels = PartVoxels::build_window(&windowed, &window.spec, backend);
            found.windows += 1;
            found.timings.voxelize += voxels.voxelize_ms();
            instances.extend(
                self.grid(part, &voxels, Some(window), near.as_ref(), found, runner)
                    .await?,
            );
        }
        // A copy whose points fall in two cores is found from both.
        Ok(merge_duplicates(
            instances,
            self.options.group_radius * template.radius(),
        ))
    }

    /// The instances on `voxels`, one grid of `part` (its whole, or a
    /// window whose core holds the candidates).
    async fn grid(
        &self,
        part: &ScenePart,
        voxels: &PartVoxels,
        window: Option<&Window>,
        near: Option<&NearVertices>,
        found: &mut Found,
        runner: &mut Runner<'_>,
    ) -> Result<Vec<Instance>> {
        let (template, options) = (self.template, self.options);
        let backend = options.backend;
        let radii = template.radii();
        let voxel = voxels.grid().spec().voxel_size;
        let t1 = now_ms();
        let mut candidates = spaced(voxels.skin(), template.candidate_spacing() as u16);
        if let Some(window) = window {
            candidates.retain(|&c| window.holds(voxels.skin()[c as usize]));
        }
        if let Some(near) = near {
            candidates.retain(|&c| near.near(voxels.position(c)));
        }
        found.skin_voxels += match window {
            Some(window) => voxels.skin().iter().filter(|&&v| window.holds(v)).count(),
            None => voxels.skin().len(),
        };
        if candidates.is_empty() {
            // No copy can be anchored here (a slab's plain faces).
            found.timings.match_ += now_ms() - t1;
            return Ok(Vec::new());
        }
        let mut estimate = self.held.clone();
        estimate.add("candidate state", candidate_bytes(candidates.len()));
        if let Some(near) = near {
            estimate.add("cells near vertices", near.bytes());
        }
        estimate.check(self.scene.memory_budget(), || {
            format!(
                "a part has {} candidate points at resolution {}: lower the resolution (they fall with its square), raise the candidate spacing, or raise the memory budget",
                candidates.len(),
                self.lattice.resolution
            )
        })?;
        // The solid on the GPU, uploaded as its layers need it.
        #[cfg(feature = "gpu")]
        let on_gpu = runner
            .gpu
            .map(|g| crate::gpu::GpuSolid::new(g, voxels.solid()));
        let volume = VolumeDescriptor::with_balls(
            voxels.solid(),
            voxels.skin(),
            radii,
            self.balls
                .iter()
                .map(|b| b.clone().bind(voxels.solid(), backend))
                .collect(),
            self.template_volume.clone(),
            options.volume_threshold,
        )
        .with_clutter(options.clutter);
        let harmonics = self.template_harmonics.as_ref().map(|signatures| {
            HarmonicsDescriptor::new(
                voxels.solid(),
                voxels.skin(),
                &self.transform,
                radii,
                signatures.clone(),
                options.harmonics_threshold,
                backend,
            )
            .with_clutter(ClutterGuard {
                policy: options.clutter,
                balls: volume.balls(),
                templates: volume.templates(),
            })
        });
        let mut stages: Vec<&dyn Stage> = Vec::new();
        if options.descriptor != DescriptorKind::Harmonics {
            stages.push(&volume);
        }
        if let Some(h) = &harmonics {
            stages.push(h);
        }
        #[cfg(feature = "gpu")]
        let batch = on_gpu.as_ref().map(|s| s as &dyn LayerBatch);
        #[cfg(not(feature = "gpu"))]
        let batch: Option<&dyn LayerBatch> = runner.gpu.map(|never| match *never {});
        let (survivors, stats) = run_cascade(
            &stages,
            candidates,
            all_anchors(self.verifiers.len()),
            backend,
            batch,
            runner.observer,
        )
        .await?;
        if let Some(reason) = stages.iter().find_map(|s| s.batch_failure()) {
            found.gpu_fallback.get_or_insert(reason);
        }
        let t2 = now_ms();
        let position = |p| voxels.position(p);
        let mut verified: Vec<Verified> = Vec::new();
        for (a, verifier) in self.verifiers.iter().enumerate() {
            let of_anchor: Vec<Survivor> = survivors
                .iter()
                .filter(|s| s.anchors & (1 << a) != 0)
                .copied()
                .collect();
            // A blob where a copy already placed puts this anchor is that
            // copy, seen from another anchor.
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
            let checked = backend.map_each(bests.len(), |b| {
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
        let mut instances = group(
            &verified,
            &survivors,
            position,
            options.group_radius * template.radius(),
        );
        align_instances(
            &mut instances,
            self.scene,
            part,
            voxels,
            &self.samples,
            template,
            self.max_hidden,
            options.surface_tolerance,
            backend,
        );
        // The meshes' verdict at the exact pose.
        instances.retain(|i| i.score.is_none_or(|s| s >= options.verify_threshold));
        found.add_stats(stats);
        found.timings.match_ += t2 - t1;
        found.timings.group += now_ms() - t2;
        Ok(instances)
    }
}

/// Surface samples the template's pose is refined with: a model's whole
/// surface, or the selected part's within the sphere.
fn template_samples(
    source: &TemplateSource,
    scene: &Scene,
    template: &VoxelTemplate,
) -> SurfaceSamples {
    let (c, r) = (template.center(), template.radius());
    let triangles: Vec<[Vec3; 3]> = match source {
        TemplateSource::Model(model) => (0..model.triangles().len())
            .map(|t| model.corners(t))
            .collect(),
        TemplateSource::Selection { .. } => {
            let part = template
                .scene_part()
                .expect("a selection lies on a scene part");
            scene.parts(Parts::Components)[part]
                .triangles()
                .iter()
                .map(|&t| scene.mesh().corners(t as usize))
                .filter(|t| Aabb::around(t.iter().copied()).is_some_and(|b| b.distance_to(c) <= r))
                .collect()
        }
    };
    SurfaceSamples::new(&triangles, ALIGN_SAMPLES, |p| p.distance(c) <= r)
}

/// Template surface samples for the pose refinement.
const ALIGN_SAMPLES: usize = 1024;

/// Refines each instance's pose on the meshes ([`crate::align`]): the
/// template's samples onto `part`'s triangles around the instance. The
/// instance's position follows its pose, and its score falls to the share
/// of the template's surface within `surface_tolerance` of r_k of the
/// scene's there (what lands inside `voxels`' solid is hidden, up to
/// `max_hidden`).
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
    backend: crate::exec::Backend,
) {
    if samples.is_empty() {
        return;
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
        let agreement = surface_agreement(samples, &index, pose, tolerance, hidden, max_hidden);
        Some((pose, agreement))
    });
    for (instance, refined) in instances.iter_mut().zip(refined) {
        if let Some((pose, agreement)) = refined {
            instance.pose = Some(pose.to_rows());
            instance.position = pose.apply(template.center()).to_array();
            instance.score = Some(agreement);
        }
    }
}

/// `instance`, found on a part, on that part's copy `motion` away.
fn moved_instance(instance: &Instance, motion: &Rigid) -> Instance {
    Instance {
        position: motion.apply(Vec3::from_array(instance.position)).to_array(),
        pose: instance
            .pose
            .map(|pose| motion.after(&Rigid::from_rows(&pose)).to_rows()),
        ..instance.clone()
    }
}

/// Where a search reports its layers, and what computes them besides the
/// CPU.
struct Runner<'r> {
    observer: &'r mut dyn Observer,
    gpu: GpuRef<'r>,
}

/// What the parts searched so far have found.
#[derive(Default)]
struct Found {
    instances: Vec<Instance>,
    stages: Vec<LayerStats>,
    skin_voxels: usize,
    windows: usize,
    timings: Timings,
    /// Why harmonics layers went back to the CPU, the first time one did.
    gpu_fallback: Option<String>,
}

impl Found {
    /// Adds a part's layer statistics to those of the same stage and layer.
    fn add_stats(&mut self, stats: Vec<LayerStats>) {
        for s in stats {
            match self
                .stages
                .iter_mut()
                .find(|t| t.descriptor == s.descriptor && t.layer == s.layer)
            {
                Some(t) => {
                    t.candidates += s.candidates;
                    t.survivors += s.survivors;
                    t.ms += s.ms;
                }
                None => self.stages.push(s),
            }
        }
    }
}

/// What a voxel search holds besides the part it searches: the scene's
/// mesh, the template's voxels and the run tables of the volume and
/// verification balls.
fn search_estimate(scene: &Scene, template: &VoxelTemplate, radii: &[f64]) -> MemoryEstimate {
    let mut estimate = scene.mesh_estimate();
    estimate.add(
        "the template's voxel grids",
        voxel_bytes(template.voxels().grid().spec()),
    );
    add_ball_tables(&mut estimate, radii);
    estimate
}

/// The parts' grids may hold this many times the voxels of the whole
/// scene's: apart, parts fill less than their common box, and padding and
/// nesting add some; a soup of large crossing triangles, each a part,
/// would take thousands of times as long as the scene.
const MAX_PART_VOLUME_FACTOR: u32 = 8;

/// Fails when voxelizing `parts` one by one would fill far more voxels than
/// the whole scene holds.
fn check_part_volume(
    scene: &Scene,
    lattice: &Lattice,
    parts: &[(usize, &ScenePart)],
    reach: f64,
) -> Result<()> {
    // Counted in f64 from the boxes: a part past a grid's side is searched
    // in windows, and still counts whole here.
    let voxel = lattice.spec.voxel_size;
    let voxels: f64 = parts
        .iter()
        .map(|(_, part)| match scene.part_spec(part, lattice, reach) {
            Ok(spec) => spec.voxel_count() as f64,
            Err(_) => {
                let e = part.bounds().extent();
                [e.x, e.y, e.z].iter().map(|e| e / voxel + 3.0).product()
            }
        })
        .sum();
    let limit = f64::from(MAX_PART_VOLUME_FACTOR) * lattice.spec.voxel_count() as f64;
    if voxels <= limit {
        return Ok(());
    }
    Err(Error::PartsOverlap {
        voxels,
        limit,
        factor: MAX_PART_VOLUME_FACTOR,
        resolution: lattice.resolution,
        advice: "weld the mesh so that a part's triangles share vertices, or search a region of the scene".into(),
    })
}

/// The advice when the template's own structures pass the budget.
fn too_much_for_template(radii: &[f64], lattice: &Lattice) -> String {
    let outer = radii.last().copied().unwrap_or_default();
    format!(
        "the template's outer radius is {outer:.0} voxels at resolution {}: lower the resolution, pick a smaller template, or raise the memory budget",
        lattice.resolution
    )
}
