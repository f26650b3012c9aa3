//! How much work a search of many distinct parts is, judged before most
//! of it is done. Every distinct part that can hold a copy is voxelized,
//! run through the layers, and its survivors verified and aligned: a few
//! milliseconds each, so tens of thousands of near twins (jittered
//! tetrahedra, a hundred thousand bolts each a little different) take
//! minutes. A sample of the parts, spread over the list, is searched
//! first; its work, projected over every part, is refused past
//! [`crate::MatchOptions::max_part_work`]. The work searched so far is
//! checked between waves too, where the sample misjudged.
//!
//! Within a part, the work is checked as it goes too: after each layer,
//! and before verifying the placements that passed every layer, so that
//! thresholds that let every candidate through (one large part, a slab
//! with bumps) stop at the limit rather than run for minutes.
//!
//! Work is counted from what the search did, not from a clock, so whether
//! a search stops depends on the input only: layer candidates, verified
//! placements and aligned instances, each weighted by what it costs one
//! core (in nanoseconds, from the stage timings of 2 000 jittered
//! tetrahedra and a 3 000-part building: `docs/CHANGELOG.md`, 2026-11-29).

use std::ops::ControlFlow;
use std::sync::atomic::Ordering;

use super::prepare::PartSearch;
use super::waves::Found;
use crate::cascade::{LayerStats, Observer, Progress};
use crate::error::Error;

/// Parts searched first to judge the rest by, at most.
pub(super) const PROBE_PARTS: usize = 32;

/// Fewer distinct parts than this are not probed: their work is judged as
/// it is done.
pub(super) const PROBE_FROM: usize = 4 * PROBE_PARTS;

/// A candidate through one volume layer (a few reads of the pyramid).
const VOLUME_CANDIDATE: f64 = 250.0;

/// A candidate through one harmonics layer (a sphere sampled and
/// transformed).
const HARMONICS_CANDIDATE: f64 = 16_000.0;

/// A skin voxel of a part's grid (filled, skinned, its pyramid built).
const SKIN_VOXEL: f64 = 300.0;

/// A placement verified (poses counted, the best refined).
pub(super) const CHECK: f64 = 2.0e6;

/// An instance aligned on the meshes (ICP and the fit).
const ALIGNMENT: f64 = 7.0e6;

/// The work of one layer over its candidates.
fn layer_work(stats: &LayerStats) -> f64 {
    let each = match stats.descriptor {
        "harmonics" => HARMONICS_CANDIDATE,
        _ => VOLUME_CANDIDATE,
    };
    stats.candidates as f64 * each
}

/// The work `found` took, in about nanoseconds of one core.
pub(super) fn work(found: &Found) -> f64 {
    let layers: f64 = found.stages.iter().map(layer_work).sum();
    layers
        + found.skin_voxels as f64 * SKIN_VOXEL
        + found.checks as f64 * CHECK
        + found.aligned as f64 * ALIGNMENT
}

/// Skin voxels of a part per voxel face of its area projected on the
/// three axis planes (`voxel::part_voxel_work`), at the least: 0.42-0.96
/// per part over the shared scenes and generated buildings, 0.57 for most
/// closed solids (a face square to an axis gives 1, one at an angle less).
const SKIN_PER_PROJECTED_FACE: f64 = 0.5;

/// The least work a part of `projected_faces` (see
/// [`SKIN_PER_PROJECTED_FACE`]) takes: its skin voxels built. Parts unlike
/// the template add little to it; parts like it pass many candidates
/// through the harmonics layers and verification, 1.3-8 times this over
/// the shared scenes.
pub(super) fn least_work(projected_faces: f64) -> (f64, f64) {
    let skin = projected_faces * SKIN_PER_PROJECTED_FACE;
    (skin, skin * SKIN_VOXEL)
}

/// Up to [`PROBE_PARTS`] of `originals`, spread evenly over them.
pub(super) fn probe(originals: &[usize]) -> Vec<usize> {
    let n = originals.len();
    let take = n.min(PROBE_PARTS);
    (0..take).map(|i| originals[i * n / take]).collect()
}

/// The error for `work` projected over `parts` distinct parts.
pub(super) fn too_much_work(parts: usize, work: f64, limit: f64) -> Error {
    Error::PartsTooMuchWork {
        parts,
        work,
        limit,
        advice: "search a region of the scene (select it with a sphere, or crop the file), \
                 split the scene into smaller files, or raise the limit (--max-part-work on \
                 the CLI, maxPartWork in JavaScript): every distinct part that could hold a \
                 copy is searched on its own"
            .into(),
    }
}

impl PartSearch<'_> {
    /// Notes the work of the parts searched so far.
    pub(super) fn set_work_done(&self, work: f64) {
        self.work_done.store(work.to_bits(), Ordering::Relaxed);
    }

    /// The work a part may still take, having taken `found`'s.
    pub(super) fn work_left(&self, found: &Found) -> f64 {
        let done = f64::from_bits(self.work_done.load(Ordering::Relaxed));
        self.options.max_part_work - done - work(found)
    }
}

/// An observer that counts each layer's work against what is left of
/// the limit, and stops the cascade past it.
pub(super) struct LayerWork<'o> {
    pub(super) inner: &'o mut dyn Observer,
    pub(super) left: f64,
    pub(super) limit: f64,
    /// The refusal, once the limit is passed.
    pub(super) passed: Option<Error>,
}

impl Observer for LayerWork<'_> {
    fn on_layer(&mut self, stats: &LayerStats) -> ControlFlow<()> {
        self.left -= layer_work(stats);
        // The next layer takes the survivors, at least as dear: refused
        // before it runs, not after.
        let next = LayerStats {
            candidates: stats.survivors,
            ..*stats
        };
        if self.left < layer_work(&next) {
            self.passed = Some(loose_thresholds(
                self.limit,
                format!(
                    "{} candidates entered {} layer {}",
                    stats.candidates, stats.descriptor, stats.layer
                ),
            ));
            return ControlFlow::Break(());
        }
        self.inner.on_layer(stats)
    }

    fn on_progress(&mut self, progress: &Progress) -> ControlFlow<()> {
        self.inner.on_progress(progress)
    }
}

/// The error for a part whose own work passes the limit: most candidates
/// pass the layers, so each is checked at length.
pub(super) fn loose_thresholds(limit: f64, what: String) -> Error {
    Error::WorkLimit {
        limit,
        doing: what,
        advice: "the layers let through far more candidates than copies can account for: \
                 tighten the thresholds (--volume-threshold, --harmonics-threshold; \
                 volumeThreshold, harmonicsThreshold in JavaScript), search a region of \
                 the scene, or raise the limit (--max-part-work, maxPartWork)"
            .into(),
    }
}
