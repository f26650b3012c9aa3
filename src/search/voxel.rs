//! The voxel pipeline, part by part: each scene part's solid and skin
//! voxels, a template with its own grid or a selection of a part's, the
//! volume and harmonics stages, then verification by placement and
//! grouping.

use std::cell::RefCell;

use super::GpuRef;
use super::congruent_parts::congruent_parts;
use super::near_vertices::{self, NearVertices, template_gap};
use super::options::{DescriptorKind, MatchOptions};
use super::place::{align_instances, moved_instance, template_samples};
use super::report::{GridInfo, MatchReport, TemplateInfo, Timings};
use super::waves::{CPU_WAVE_PARTS, Found, plan_waves, share_cpu_wave_time};
#[cfg(feature = "gpu")]
use super::waves::{WAVE_PARTS, share_wave_time};
use super::windows::{Window, part_windows};
use crate::align::{Rigid, SurfaceSamples};
use crate::budget::{add_ball_tables, candidate_bytes, voxel_bytes};
use crate::cascade::{LayerStats, Observer, Stage, Survivor, finished, run_cascade};
use crate::clock::now_ms;
use crate::descriptor::harmonics::ClutterGuard;
use crate::descriptor::harmonics::Signature as HarmonicsSignature;
use crate::descriptor::{
    HarmonicsDescriptor, LayerBatch, SphericalTransform, VolumeDescriptor, all_anchors,
};
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
    // What a part's copies take from it, moved.
    let lists: Vec<&[u32]> = parts.iter().map(|(_, p)| p.triangles()).collect();
    let copies_from = now_ms();
    let copies = congruent_parts(mesh, &lists, options.backend);
    let copies_ms = now_ms() - copies_from;
    let originals: Vec<usize> = (0..parts.len()).filter(|&k| copies[k].is_none()).collect();
    let observer = RefCell::new(observer);
    let searched = searcher
        .search_parts(&parts, &originals, &observer, gpu)
        .await?;
    // In the parts' order, whether searched one by one or side by side.
    let mut found = Found::default();
    for (k, copy) in copies.iter().enumerate() {
        match (copy, &searched[k]) {
            (Some((original, motion)), _) => {
                let moved = searched[*original]
                    .iter()
                    .flat_map(|f| &f.instances)
                    .map(|instance| moved_instance(instance, motion));
                found.instances.extend(moved);
            }
            (None, Some(part)) => found.merge(part),
            (None, None) => {}
        }
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
            // Finding which parts copy others is part of matching: their
            // instances come from it.
            match_: found.timings.match_ + copies_ms,
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
    /// What each part of `originals` (indices into `parts`) found, by
    /// index: side by side, in waves that fit the memory budget together.
    /// On the CPU a wave's parts share the threads; on a GPU a layer is one
    /// submission for all parts of a wave ([`crate::gpu::KernelQueue`]).
    async fn search_parts(
        &self,
        parts: &[(usize, &ScenePart)],
        originals: &[usize],
        observer: &RefCell<&mut dyn Observer>,
        gpu: GpuRef<'_>,
    ) -> Result<Vec<Option<Found>>> {
        let mut searched: Vec<Option<Found>> = parts.iter().map(|_| None).collect();
        #[cfg(feature = "gpu")]
        if let Some(gpu) = gpu {
            let queue = crate::gpu::KernelQueue::new(gpu);
            for wave in self.waves(parts, originals, WAVE_PARTS) {
                let started = now_ms();
                let tasks: Vec<crate::descriptor::LocalFuture<'_, Result<Found>>> = wave
                    .iter()
                    .map(|(k, held)| {
                        let (index, part) = parts[*k];
                        let mut runner = Runner {
                            observer,
                            gpu: Some(gpu),
                            queue: Some(&queue),
                            held: held.clone(),
                        };
                        Box::pin(async move { self.part(index, part, &mut runner).await })
                            as crate::descriptor::LocalFuture<'_, Result<Found>>
                    })
                    .collect();
                let founds = match queue.run_together(tasks).await {
                    Ok(mut founds) => {
                        share_wave_time(&mut founds, now_ms() - started);
                        founds
                    }
                    // Together past the budget: one by one, as they would
                    // have run without the GPU.
                    Err(Error::OverBudget { .. }) if wave.len() > 1 => {
                        let mut founds = Vec::with_capacity(wave.len());
                        for (k, _) in &wave {
                            let (index, part) = parts[*k];
                            let mut runner = Runner {
                                observer,
                                gpu: Some(gpu),
                                queue: None,
                                held: self.held.clone(),
                            };
                            founds.push(self.part(index, part, &mut runner).await?);
                        }
                        founds
                    }
                    Err(e) => return Err(e),
                };
                for ((k, _), found) in wave.iter().zip(founds) {
                    searched[*k] = Some(found);
                }
            }
            return Ok(searched);
        }
        for wave in self.waves(parts, originals, CPU_WAVE_PARTS) {
            if let [(k, _)] = wave[..] {
                let (index, part) = parts[k];
                let mut runner = Runner {
                    observer,
                    gpu,
                    #[cfg(feature = "gpu")]
                    queue: None,
                    held: self.held.clone(),
                };
                searched[k] = Some(self.part(index, part, &mut runner).await?);
                continue;
            }
            for ((k, _), found) in wave.iter().zip(self.cpu_wave(parts, &wave, observer)?) {
                searched[*k] = Some(found);
            }
        }
        Ok(searched)
    }

    /// The parts of `wave` searched side by side on the CPU's threads, each
    /// with its own threads inside as well: a small part keeps few threads
    /// busy alone (a handful of blobs to verify, one instance to align).
    /// Each part's layers are reported once the wave is done, in the
    /// parts' order, and its times are shares of the wave's wall time.
    fn cpu_wave(
        &self,
        parts: &[(usize, &ScenePart)],
        wave: &[(usize, MemoryEstimate)],
        observer: &RefCell<&mut dyn Observer>,
    ) -> Result<Vec<Found>> {
        let started = now_ms();
        let runs = self.options.backend.map_each(wave.len(), |i| {
            let (k, held) = &wave[i];
            let (index, part) = parts[*k];
            let mut layers = Vec::new();
            let found = {
                let mut collect = |s: &LayerStats| {
                    layers.push(s.clone());
                    std::ops::ControlFlow::Continue(())
                };
                let own: RefCell<&mut dyn Observer> = RefCell::new(&mut collect);
                let mut runner = Runner {
                    observer: &own,
                    gpu: None,
                    #[cfg(feature = "gpu")]
                    queue: None,
                    held: held.clone(),
                };
                finished(self.part(index, part, &mut runner))
            };
            found.map(|found| (found, layers))
        });
        let wall = now_ms() - started;
        let mut founds = Vec::with_capacity(runs.len());
        for run in runs {
            let (found, layers) = run?;
            for layer in &layers {
                if observer.borrow_mut().on_layer(layer).is_break() {
                    return Err(Error::Cancelled);
                }
            }
            founds.push(found);
        }
        share_cpu_wave_time(&mut founds, wall);
        Ok(founds)
    }

    /// `originals` in waves (see [`plan_waves`]), each part with what the
    /// search holds beside it: the template's side and the other parts of
    /// its wave.
    fn waves(
        &self,
        parts: &[(usize, &ScenePart)],
        originals: &[usize],
        max_parts: usize,
    ) -> Vec<Vec<(usize, MemoryEstimate)>> {
        let reach = self.template.radius() / self.lattice.spec.voxel_size;
        let grids: Vec<Option<u64>> = originals
            .iter()
            .map(|&k| {
                let (index, part) = parts[k];
                match self.template.voxels_of_part(index) {
                    // A selection's own part is voxelized already.
                    Some(_) => Some(0),
                    None if self.scene.fits_one_grid(part, self.lattice, reach) => self
                        .scene
                        .part_spec(part, self.lattice, reach)
                        .ok()
                        .map(|spec| voxel_bytes(&spec)),
                    None => None,
                }
            })
            .collect();
        let free = self.scene.memory_budget().saturating_sub(self.held.total());
        plan_waves(&grids, free, max_parts)
            .into_iter()
            .map(|wave| {
                wave.into_iter()
                    .map(|(n, others)| {
                        let mut held = self.held.clone();
                        if others > 0 {
                            held.add("the other parts searched beside it", others);
                        }
                        (originals[n], held)
                    })
                    .collect()
            })
            .collect()
    }

    /// The instances on scene part `index`: on its own grid, or window by
    /// window when it is too large for one.
    async fn part(
        &self,
        index: usize,
        part: &ScenePart,
        runner: &mut Runner<'_, '_>,
    ) -> Result<Found> {
        let started = now_ms();
        let mut found = Found::default();
        found.instances = self.part_instances(index, part, &mut found, runner).await?;
        // Matching is all of a part's search but voxelizing and verifying:
        // its cells near vertices and its mesh too, as a wave of parts on
        // the GPU (which can only time the whole) counts it.
        found.timings.match_ =
            (now_ms() - started - found.timings.voxelize - found.timings.group).max(0.0);
        Ok(found)
    }

    /// [`PartSearch::part`]'s instances; the rest of what it found goes
    /// to `found`.
    async fn part_instances(
        &self,
        index: usize,
        part: &ScenePart,
        found: &mut Found,
        runner: &mut Runner<'_, '_>,
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
        let Some(windows) = part_windows(scene, part, self.lattice, reach, near.as_ref())? else {
            let fresh;
            let voxels = match template.voxels_of_part(index) {
                Some(voxels) => voxels,
                None => {
                    fresh = scene.voxelize_part(part, self.lattice, reach, &runner.held)?;
                    found.timings.voxelize += fresh.voxelize_ms();
                    &fresh
                }
            };
            return self
                .grid(part, voxels, None, near.as_ref(), found, runner)
                .await;
        };
        let windowed = WindowedMesh::new(mesh.subset(part.triangles()), backend);
        let mut held = runner.held.clone();
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
        runner: &mut Runner<'_, '_>,
    ) -> Result<Vec<Instance>> {
        let (template, options) = (self.template, self.options);
        let backend = options.backend;
        let radii = template.radii();
        let voxel = voxels.grid().spec().voxel_size;
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
            return Ok(Vec::new());
        }
        let mut estimate = runner.held.clone();
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
        let on_gpu = match runner.queue {
            Some(queue) => Some(crate::gpu::GpuSolid::queued(queue, voxels.solid())),
            None => runner
                .gpu
                .map(|g| crate::gpu::GpuSolid::new(g, voxels.solid())),
        };
        #[cfg(feature = "gpu")]
        let on_device = on_gpu.is_some();
        #[cfg(not(feature = "gpu"))]
        let on_device = false;
        let volume = VolumeDescriptor::with_balls(
            voxels.solid(),
            voxels.skin(),
            radii,
            self.balls
                .iter()
                .map(|b| match on_device {
                    // The GPU counts from the runs alone, and a part of a
                    // wave would hold a copy of them for nothing.
                    true => b.clone().for_solid(voxels.solid(), backend),
                    false => b.clone().bind(voxels.solid(), backend),
                })
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
            &mut SharedObserver(runner.observer),
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
        found.timings.group += now_ms() - t2;
        Ok(instances)
    }
}

/// What one part's search runs with: where it reports its layers, what
/// computes them besides the CPU, and what the search holds beside it.
struct Runner<'r, 'o> {
    observer: &'r RefCell<&'o mut dyn Observer>,
    gpu: GpuRef<'r>,
    /// Where its kernels wait for the others of its wave.
    #[cfg(feature = "gpu")]
    queue: Option<&'r crate::gpu::KernelQueue<'r>>,
    held: MemoryEstimate,
}

/// One observer for parts searched side by side: each layer's report
/// borrows it in turn.
struct SharedObserver<'r, 'o>(&'r RefCell<&'o mut dyn Observer>);

impl Observer for SharedObserver<'_, '_> {
    fn on_layer(&mut self, stats: &LayerStats) -> std::ops::ControlFlow<()> {
        self.0.borrow_mut().on_layer(stats)
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
    // Against the scene's box padded as a part's is: a flat scene (tiles
    // on a floor) has a flat grid, and every part's padding alone passed
    // it many times over.
    let scene_extent = scene.mesh().bounds().extent();
    let padded_scene: f64 = [scene_extent.x, scene_extent.y, scene_extent.z]
        .iter()
        .map(|e| e / voxel + 2.0 * reach + 3.0)
        .product();
    let limit =
        f64::from(MAX_PART_VOLUME_FACTOR) * padded_scene.max(lattice.spec.voxel_count() as f64);
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
