//! Clutter: material in the scene that the template does not have.
//!
//! In a real scene an occurrence is part of a larger whole: a figure stands
//! sunk into the ground, objects touch or interpenetrate. Inside the
//! template's outer ball the scene then holds extra material the template's
//! descriptor never saw, and every layer from that radius outwards drifts
//! far from the template's, however good the match. Material can only be
//! added by other objects, never taken away: so when a layer's ball (or
//! sphere) holds clearly more material than the template's at that radius,
//! that layer and the larger ones stop being compared at that point. The
//! point keeps the distance of its clean layers, and the placement test
//! (verification), which is built to ignore added material, decides.
//!
//! The same holds for the placement test: template surface that lands inside
//! the scene's solid is hidden by other material and counts neither way, up
//! to [`crate::MatchOptions::hidden_surface`] of it (a figure sunk into the ground
//! hides its feet; a template pushed into a solid hides most of itself).
//!
//! Three limits keep the descriptors from excusing everything:
//! - the inner layers always count: a point must match the template's own
//!   shape over a neighbourhood big enough to say something, so a flat slab
//!   or a wall with "extra" material everywhere is still rejected there.
//!   That neighbourhood is the inner third of the onion (two of six layers
//!   by default), and never less than [`ClutterPolicy::clean_voxels`]: a ball
//!   a few voxels across matches any smooth surface, so a small template
//!   (a selection, a detail) must be compared over a minimum number of
//!   voxels before clutter can excuse anything;
//! - only *extra* material excuses a layer; missing material (a smaller
//!   decoy, a different shape) counts as always;
//! - a point compared over fewer layers must match as well per layer as one
//!   compared over all: its distance is checked against the share of the
//!   budget that the counted layers carry for clean matches. Rejection
//!   stays exact: until a layer is excused, the usual bound applies (the
//!   final distance can only be larger), and the stricter check is made
//!   once, when the counted layers are known.

/// When extra material stops layers from being compared.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClutterPolicy {
    /// Layers out to this share of r_k always count, clutter or not.
    pub clean_fraction: f64,
    /// Layers out to this radius in voxels always count, clutter or not.
    pub clean_voxels: f64,
    /// A ball whose solid fraction exceeds the template's by more than this
    /// is cluttered.
    pub volume_tolerance: f64,
    /// A sphere whose mean occupancy (its degree-0 energy) exceeds the
    /// template's by more than this is cluttered.
    pub sphere_tolerance: f64,
}

impl ClutterPolicy {
    /// The defaults: layers out to r_k / 3 and at least 16 voxels always
    /// count; 3% of a ball or 1% of a sphere beyond the template's marks
    /// clutter (above the discretization noise of clean matches at those
    /// radii, measured on the shared scenes).
    pub const DEFAULT: ClutterPolicy = ClutterPolicy {
        clean_fraction: 1.0 / 3.0,
        clean_voxels: 16.0,
        volume_tolerance: 0.03,
        sphere_tolerance: 0.01,
    };

    /// Every layer always counts (the plain cascade of the paper).
    pub const OFF: ClutterPolicy = ClutterPolicy {
        clean_fraction: f64::INFINITY,
        clean_voxels: f64::INFINITY,
        volume_tolerance: f64::INFINITY,
        sphere_tolerance: f64::INFINITY,
    };

    /// The share of the surface a clean, well placed template may still
    /// find inside the solid: where the one-voxel surface band of a curved
    /// or thin part is missed by a sample (measured: at most 5% on the
    /// shared selection scenes).
    pub const DISCRETIZATION_HIDDEN: f64 = 0.1;

    /// The share of a stage's budget that `counted` of `layers` layers may
    /// use when the rest are excused, for errors that fall as 1/R with the
    /// radius (the volume fractions of clean matches): H(counted) /
    /// H(layers), with H the harmonic numbers.
    pub fn volume_share(counted: usize, layers: usize) -> f64 {
        let h = |n: usize| (1..=n).map(|i| 1.0 / i as f64).sum::<f64>();
        h(counted) / h(layers)
    }

    /// The orders in which the harmonics stage may compute its `layers`
    /// spheres, the first `clean` of which always count, with the same
    /// survivors and distances as innermost first. Every sphere costs the
    /// same (the pyramid keeps the samples per block constant), so only
    /// selectivity matters, and small spheres reject least: at that size
    /// every smooth surface looks alike (on the shared scenes the first
    /// sphere, r_k / 6, rejects under 5% of the points it is given). So:
    /// - first the largest always-counted sphere (it rejects on its own at
    ///   once) or, with `excusable_first`, the smallest excusable one (it
    ///   counts at once unless clutter excuses it);
    /// - the excusable spheres outward: one counts only once every
    ///   excusable sphere inside it is known to be clean;
    /// - the other always-counted spheres last, inward.
    ///
    /// Which of the two leads is better depends on the scene (where objects
    /// touch, the excusable sphere is often excused); the stage picks it on
    /// a sample. (The volume stage keeps the paper's order: its inner balls
    /// do reject, and on the shared scenes it costs a quarter of the
    /// harmonics stage or less.)
    pub fn selective_order(clean: usize, layers: usize, excusable_first: bool) -> Vec<usize> {
        let clean = clean.min(layers);
        let lead = if excusable_first && clean < layers {
            None
        } else {
            clean.checked_sub(1)
        };
        let rest_inward = (0..clean).rev().filter(move |&l| Some(l) != lead);
        lead.into_iter()
            .chain(clean..layers)
            .chain(rest_inward)
            .collect()
    }

    /// How many leading layers of radii `radii_voxels` (increasing, in
    /// voxels) always count: at least the first, so that a point is never
    /// passed without being compared at all (one or two large layers).
    pub fn clean_layers(&self, radii_voxels: &[f64]) -> usize {
        let outer = radii_voxels.last().copied().unwrap_or(0.0);
        // Radii are multiples of r_k / k: a little slack keeps r_k / 3 in.
        let clean = (self.clean_fraction * outer).max(self.clean_voxels) * (1.0 + 1e-9);
        let within = radii_voxels.iter().take_while(|&&r| r <= clean).count();
        within.max(1).min(radii_voxels.len())
    }
}

impl Default for ClutterPolicy {
    fn default() -> Self {
        Self::DEFAULT
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inner_third_always_counts_for_a_large_template() {
        // r_k = 96 voxels: r_k / 3 = 32 beats 16, so layers 16 and 32.
        let radii: Vec<f64> = (1..=6).map(|i| 16.0 * i as f64).collect();
        assert_eq!(ClutterPolicy::DEFAULT.clean_layers(&radii), 2);
    }

    #[test]
    fn a_small_template_counts_at_least_sixteen_voxels() {
        // r_k = 30 voxels: r_k / 3 = 10 is too small to say anything.
        let radii: Vec<f64> = (1..=6).map(|i| 5.0 * i as f64).collect();
        assert_eq!(ClutterPolicy::DEFAULT.clean_layers(&radii), 3);
    }

    #[test]
    fn selective_order_visits_every_layer_once_with_excusable_ones_outward() {
        let order = ClutterPolicy::selective_order;
        assert_eq!(order(2, 6, false), [1, 2, 3, 4, 5, 0]);
        assert_eq!(order(2, 6, true), [2, 3, 4, 5, 1, 0]);
        assert_eq!(order(4, 6, false), [3, 4, 5, 2, 1, 0]);
        assert_eq!(order(4, 6, true), [4, 5, 3, 2, 1, 0]);
        // Nothing excusable: largest first, either way.
        assert_eq!(order(usize::MAX, 3, false), [2, 1, 0]);
        assert_eq!(order(usize::MAX, 3, true), [2, 1, 0]);
        // Everything excusable: outward.
        assert_eq!(order(0, 3, false), [0, 1, 2]);
        assert_eq!(order(0, 3, true), [0, 1, 2]);
        assert_eq!(order(1, 1, true), [0]);
    }

    #[test]
    fn the_first_layer_always_counts() {
        // r_1 = r_k / 2 = 40 voxels is beyond both r_k / 3 and 16 voxels.
        assert_eq!(ClutterPolicy::DEFAULT.clean_layers(&[40.0, 80.0]), 1);
        assert_eq!(ClutterPolicy::DEFAULT.clean_layers(&[80.0]), 1);
        assert_eq!(ClutterPolicy::DEFAULT.clean_layers(&[]), 0);
    }

    #[test]
    fn off_counts_every_layer() {
        let radii = [4.0, 8.0, 12.0];
        assert_eq!(ClutterPolicy::OFF.clean_layers(&radii), 3);
    }

    #[test]
    fn volume_share_grows_to_the_whole_budget() {
        let shares: Vec<f64> = (1..=6).map(|n| ClutterPolicy::volume_share(n, 6)).collect();
        assert!(shares.windows(2).all(|w| w[0] < w[1]));
        assert!((shares[5] - 1.0).abs() < 1e-12);
        // H(2) / H(6) = 1.5 / 2.45.
        assert!((shares[1] - 1.5 / 2.45).abs() < 1e-12);
    }
}
