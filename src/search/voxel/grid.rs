//! One grid's search (a part's, or a window's of a large part): its
//! candidate points, the cascade of volume and harmonics layers over them,
//! then the survivors verified and placed (`place.rs`).

use super::near_vertices::NearVertices;
use super::parts::Runner;
use super::prepare::PartSearch;
use super::waves::Found;
use super::windows::Window;
use super::work::LayerWork;
use crate::budget::Item;
use crate::cascade::candidate_bytes;
use crate::cascade::{LayerStats, Observer, Progress, Stage, Survivor, run_cascade};
use crate::clock::now_ms;
use crate::descriptor::harmonics::ClutterGuard;
use crate::descriptor::{
    Anchors, CentroidDescriptor, HarmonicsDescriptor, LayerBatch, VolumeDescriptor,
};
use crate::error::Result;
use crate::instances::Instance;
use crate::math::Vec3;
use crate::options::DescriptorKind;
use crate::scene::{PartVoxels, ScenePart};
use crate::voxel::spaced;

impl PartSearch<'_> {
    /// The instances on `voxels`, one grid of `part` (its whole, or a
    /// window whose core holds the candidates).
    pub(super) async fn grid(
        &self,
        part: &ScenePart,
        voxels: &PartVoxels,
        window: Option<&Window>,
        near: Option<&NearVertices>,
        found: &mut Found,
        runner: &mut Runner<'_, '_>,
    ) -> Result<Vec<Instance>> {
        let candidates = self.candidates(voxels, window, near, found);
        if candidates.is_empty() {
            // No copy can be anchored here (a slab's plain faces).
            return Ok(Vec::new());
        }
        // A part joined from several components may hold a neighbour
        // against a copy's c_T: its candidates are kept for the further
        // anchors. One of fewer components than the template's shells
        // holds no copy whose shells stand apart (a wheel pair without its
        // hub), nor one buried by a neighbour.
        let fallback = match part.components() {
            1 => 0,
            n if n < self.template.shells() => 0,
            _ => self.template.fallback_anchors(),
        };
        let resolution = self.lattice.resolution;
        let mut held = runner.held.clone();
        held.reserve(
            Item::Candidates {
                candidates: candidates.len(),
                resolution,
                kept: false,
            },
            candidate_bytes(candidates.len()),
        )?;
        if fallback != 0 {
            let item = Item::Candidates {
                candidates: candidates.len(),
                resolution,
                kept: true,
            };
            held.reserve(item, 4 * candidates.len() as u64)?;
        }
        if let Some(near) = near {
            held.reserve(Item::NearCells { resolution }, near.bytes())?;
        }
        let kept = match fallback {
            0 => Vec::new(),
            _ => candidates.clone(),
        };
        let first = self.template.first_anchors();
        let mut instances = self
            .read_and_place(part, voxels, candidates, first, found, runner)
            .await?;
        if fallback != 0 {
            let more = self
                .read_again(part, voxels, kept, &instances, fallback, found, runner)
                .await?;
            instances.extend(more);
        }
        Ok(instances)
    }

    /// A copy whose primary anchor is buried (a neighbour gathered with its
    /// shells, against it): `candidates` that none of `instances` explains
    /// (none lies within the group radius) read at the `further` anchors,
    /// and the new copies this finds.
    #[allow(clippy::too_many_arguments)]
    async fn read_again(
        &self,
        part: &ScenePart,
        voxels: &PartVoxels,
        candidates: Vec<u32>,
        instances: &[Instance],
        further: Anchors,
        found: &mut Found,
        runner: &mut Runner<'_, '_>,
    ) -> Result<Vec<Instance>> {
        let reach = self.options.group_radius * self.template.radius();
        let unexplained = |p: Vec3| {
            instances
                .iter()
                .all(|i| Vec3::from_array(i.position).distance(p) > reach)
        };
        let candidates: Vec<u32> = candidates
            .into_iter()
            .filter(|&c| unexplained(voxels.position(c)))
            .collect();
        if candidates.is_empty() {
            return Ok(Vec::new());
        }
        let mut more = self
            .read_and_place(part, voxels, candidates, further, found, runner)
            .await?;
        // A copy found at c_T, seen again from an anchor beyond the reach.
        more.retain(|i| unexplained(Vec3::from_array(i.position)));
        Ok(more)
    }

    /// The cascade over `candidates` at `anchors`, its survivors verified
    /// and placed.
    async fn read_and_place(
        &self,
        part: &ScenePart,
        voxels: &PartVoxels,
        candidates: Vec<u32>,
        anchors: Anchors,
        found: &mut Found,
        runner: &mut Runner<'_, '_>,
    ) -> Result<Vec<Instance>> {
        let (survivors, stats) = self
            .cascade(voxels, candidates, anchors, found, runner)
            .await?;
        found.add_stats(stats);
        let started = now_ms();
        let (verified, checks) = self.verify(voxels, &survivors, self.work_left(found))?;
        let (instances, aligned) = self.place(part, voxels, &verified, &survivors);
        found.checks += checks;
        found.aligned += aligned;
        found.timings.group += now_ms() - started;
        Ok(instances)
    }

    /// The skin voxels a copy's anchor may lie at: one per cube of the
    /// candidate spacing, in the window's core, near a vertex. Counts the
    /// grid's skin voxels into `found`.
    fn candidates(
        &self,
        voxels: &PartVoxels,
        window: Option<&Window>,
        near: Option<&NearVertices>,
        found: &mut Found,
    ) -> Vec<u32> {
        let mut candidates = spaced(voxels.skin(), self.template.candidate_spacing() as u16);
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
        candidates
    }

    /// The volume stage over `voxels`, with the pyramid levels its balls
    /// read.
    fn volume_stage<'v>(&'v self, voxels: &'v PartVoxels) -> VolumeDescriptor<'v> {
        let backend = self.options.backend;
        VolumeDescriptor::with_balls(
            voxels.solid(),
            voxels.skin(),
            self.template.radii(),
            self.balls
                .iter()
                .map(|b| b.clone().for_solid(voxels.solid(), backend))
                .collect(),
            self.template_volume.clone(),
            self.options.volume_threshold,
        )
        .with_clutter(self.options.clutter)
    }

    /// The volume, centroid and harmonics layers over `candidates`, on the device
    /// where the runner has one: the survivors and each layer's figures. A layer
    /// the device gave back to the CPU is noted in `found`.
    async fn cascade(
        &self,
        voxels: &PartVoxels,
        candidates: Vec<u32>,
        anchors: Anchors,
        found: &mut Found,
        runner: &mut Runner<'_, '_>,
    ) -> Result<(Vec<Survivor>, Vec<LayerStats>)> {
        let (options, backend) = (self.options, self.options.backend);
        let radii = self.template.radii();
        // The solid on the device, uploaded as its layers need it.
        let batch: Option<Box<dyn LayerBatch + '_>> = match (runner.wave, runner.device) {
            (Some(wave), _) => Some(wave.batch(voxels.solid())),
            (None, Some(device)) => Some(device.batch(voxels.solid())),
            (None, None) => None,
        };
        let volume = self.volume_stage(voxels);
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
        // Between the two, when both run.
        let centroid = self.template_centroid.as_ref().map(|templates| {
            CentroidDescriptor::new(
                voxels.solid(),
                voxels.skin(),
                radii,
                self.centroid_balls.clone(),
                templates.clone(),
                backend,
            )
            .with_clutter(options.clutter)
        });
        let mut stages: Vec<&dyn Stage> = Vec::new();
        if options.descriptor != DescriptorKind::Harmonics {
            stages.push(&volume);
        }
        if let Some(c) = &centroid {
            stages.push(c);
        }
        if let Some(h) = &harmonics {
            stages.push(h);
        }
        let mut watch = LayerWork {
            inner: &mut SharedObserver(runner.observer),
            left: self.work_left(found),
            limit: options.max_part_work,
            passed: None,
        };
        let outcome = run_cascade(
            &stages,
            candidates,
            anchors,
            backend,
            batch.as_deref(),
            &mut watch,
        )
        .await;
        if let Some(refusal) = watch.passed {
            return Err(refusal);
        }
        let outcome = outcome?;
        if let Some(reason) = stages.iter().find_map(|s| s.batch_failure()) {
            found.gpu_fallback.get_or_insert(reason);
        }
        Ok(outcome)
    }
}

/// One observer for parts searched side by side: each layer's report
/// borrows it in turn.
struct SharedObserver<'r, 'o>(&'r std::cell::RefCell<&'o mut dyn Observer>);

impl Observer for SharedObserver<'_, '_> {
    fn on_layer(&mut self, stats: &LayerStats) -> std::ops::ControlFlow<()> {
        self.0.borrow_mut().on_layer(stats)
    }

    fn on_progress(&mut self, progress: &Progress) -> std::ops::ControlFlow<()> {
        self.0.borrow_mut().on_progress(progress)
    }
}
