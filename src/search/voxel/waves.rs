//! Parts side by side: what each part found, how the parts are planned in
//! waves that fit the memory budget together, and how a wave's wall time
//! is shared out among its parts' timings.

use crate::cascade::{LayerStats, add_layer_stats};
use crate::instances::Instance;

use crate::search::report::Timings;

/// What the parts searched so far have found.
#[derive(Default)]
pub(super) struct Found {
    pub(super) instances: Vec<Instance>,
    pub(super) stages: Vec<LayerStats>,
    pub(super) skin_voxels: usize,
    pub(super) windows: usize,
    /// Placements verified, and instances aligned on the meshes: with the
    /// layers' candidates, what the search's work is judged by.
    pub(super) checks: usize,
    pub(super) aligned: usize,
    pub(super) timings: Timings,
    /// Why harmonics layers went back to the CPU, the first time one did.
    pub(super) gpu_fallback: Option<String>,
}

impl Found {
    /// Adds what a part found.
    pub(super) fn merge(&mut self, part: &Found) {
        self.instances.extend(part.instances.iter().cloned());
        self.add_stats(part.stages.clone());
        self.skin_voxels += part.skin_voxels;
        self.windows += part.windows;
        self.checks += part.checks;
        self.aligned += part.aligned;
        let (t, p) = (&mut self.timings, &part.timings);
        t.voxelize += p.voxelize;
        t.match_ += p.match_;
        t.group += p.group;
        if self.gpu_fallback.is_none() {
            self.gpu_fallback = part.gpu_fallback.clone();
        }
    }

    /// Adds a part's layer statistics to those of the same stage and layer.
    pub(super) fn add_stats(&mut self, stats: Vec<LayerStats>) {
        add_layer_stats(&mut self.stages, stats);
    }
}

/// Parts in waves searched side by side, in order: a wave takes up to
/// `max_parts` parts while what they hold (`grids[n]` bytes) fits `free`
/// bytes together; a part with no size (searched in windows) is a wave of
/// its own. Each part comes with the bytes of the others of its wave.
pub(super) fn plan_waves(
    grids: &[Option<u64>],
    free: u64,
    max_parts: usize,
) -> Vec<Vec<(usize, u64)>> {
    let mut waves: Vec<Vec<(usize, u64)>> = Vec::new();
    let mut wave: Vec<(usize, u64)> = Vec::new();
    let close = |wave: &mut Vec<(usize, u64)>, waves: &mut Vec<Vec<(usize, u64)>>| {
        let total: u64 = wave.iter().map(|&(_, b)| b).sum();
        waves.push(wave.drain(..).map(|(n, own)| (n, total - own)).collect());
    };
    for (n, grid) in grids.iter().enumerate() {
        let total: u64 = wave.iter().map(|&(_, b)| b).sum();
        let fits =
            grid.is_some_and(|own| total.saturating_add(own) <= free) && wave.len() < max_parts;
        if !wave.is_empty() && !fits {
            close(&mut wave, &mut waves);
        }
        wave.push((n, grid.unwrap_or(0)));
        if grid.is_none() {
            close(&mut wave, &mut waves);
        }
    }
    if !wave.is_empty() {
        close(&mut wave, &mut waves);
    }
    waves
}

/// Parts in a wave on the CPU at most: enough that the threads share them
/// evenly whatever their sizes, few enough that a cancel is heard within a
/// wave's time.
pub(super) const CPU_WAVE_PARTS: usize = 64;

/// The times of a wave's parts that ran side by side on the CPU: each of
/// their times scaled so that together they make the wave's wall time.
pub(super) fn share_cpu_wave_time(founds: &mut [Found], wall: f64) {
    let busy: f64 = founds
        .iter()
        .map(|f| f.timings.voxelize + f.timings.match_ + f.timings.group)
        .sum();
    let scale = if busy > 0.0 { wall / busy } else { 0.0 };
    for found in founds {
        let t = &mut found.timings;
        t.voxelize *= scale;
        t.match_ *= scale;
        t.group *= scale;
        for s in &mut found.stages {
            s.ms *= scale;
        }
    }
}

/// The times of a wave's parts, which ran side by side: the wave's match
/// time is its wall time less what each part spent alone voxelizing and
/// grouping, and a layer's time the longest any part spent in it (they
/// wait on the same submissions). Both go to the first part that has them.
pub(super) fn share_wave_time(founds: &mut [Found], wall: f64) {
    let alone: f64 = founds
        .iter()
        .map(|f| f.timings.voxelize + f.timings.group)
        .sum();
    for (n, found) in founds.iter_mut().enumerate() {
        found.timings.match_ = if n == 0 { (wall - alone).max(0.0) } else { 0.0 };
    }
    let mut longest: Vec<((&str, usize), f64)> = Vec::new();
    for s in founds.iter().flat_map(|f| &f.stages) {
        let key = (s.descriptor, s.layer);
        match longest.iter_mut().find(|(k, _)| *k == key) {
            Some((_, ms)) => *ms = ms.max(s.ms),
            None => longest.push((key, s.ms)),
        }
    }
    for s in founds.iter_mut().flat_map(|f| &mut f.stages) {
        let slot = longest
            .iter_mut()
            .find(|(k, _)| *k == (s.descriptor, s.layer));
        s.ms = slot.map_or(0.0, |(_, ms)| std::mem::take(ms));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_share_a_wave_while_their_grids_fit_together() {
        let waves =
            |grids: &[Option<u64>], free| -> Vec<Vec<(usize, u64)>> { plan_waves(grids, free, 3) };
        // All fit: one wave, each part held beside the others.
        assert_eq!(
            waves(&[Some(10), Some(20), Some(30)], 60),
            [vec![(0, 50), (1, 40), (2, 30)]]
        );
        // The third would pass the budget: it starts the next wave.
        assert_eq!(
            waves(&[Some(10), Some(20), Some(31)], 60),
            [vec![(0, 20), (1, 10)], vec![(2, 0)]]
        );
        // A part larger than the budget alone still gets a wave (its own
        // check refuses it, as without the GPU).
        assert_eq!(
            waves(&[Some(70), Some(5)], 60),
            [vec![(0, 0)], vec![(1, 0)]]
        );
        // A part searched in windows runs alone, between the others.
        assert_eq!(
            waves(&[Some(1), None, Some(1), Some(1)], 60),
            [vec![(0, 0)], vec![(1, 0)], vec![(2, 1), (3, 1)]]
        );
        // No more than the most parts a wave takes.
        assert_eq!(
            waves(&[Some(1); 5], 60),
            [vec![(0, 2), (1, 2), (2, 2)], vec![(3, 1), (4, 1)]]
        );
        assert!(waves(&[], 60).is_empty());
    }
}
