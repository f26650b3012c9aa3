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
//! ([`crate::verify`]), which is built to ignore added material, decides.
//!
//! Two limits keep this from excusing everything:
//! - the innermost layers always count: a point must match the template's
//!   own shape over the inner part of the onion, so a flat slab or a wall
//!   with "extra" material everywhere is still rejected there. By default the
//!   volume must match over the inner half (three of six layers) and the
//!   harmonics over the inner third (two spheres): a sliver of other material
//!   crossing a sphere moves its signature far more than it moves the
//!   ball's solid fraction, so the coarse volume can be asked to stay clean
//!   further out;
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
    /// Leading volume layers that always count, clutter or not.
    pub volume_always_counted: usize,
    /// Leading spheres that always count, clutter or not.
    pub sphere_always_counted: usize,
    /// A ball whose solid fraction exceeds the template's by more than this
    /// is cluttered.
    pub volume_tolerance: f64,
    /// A sphere whose mean occupancy (its degree-0 energy) exceeds the
    /// template's by more than this is cluttered.
    pub sphere_tolerance: f64,
}

impl ClutterPolicy {
    /// The defaults: three volume layers and two spheres always count; 3% of
    /// a ball or 1% of a sphere beyond the template's marks clutter (above
    /// the discretization noise of clean matches at those radii, measured on
    /// the shared scenes).
    pub const DEFAULT: ClutterPolicy = ClutterPolicy {
        volume_always_counted: 2,
        sphere_always_counted: 2,
        volume_tolerance: 0.03,
        sphere_tolerance: 0.01,
    };

    /// Every layer always counts (the plain cascade of the paper).
    pub const OFF: ClutterPolicy = ClutterPolicy {
        volume_always_counted: usize::MAX,
        sphere_always_counted: usize::MAX,
        volume_tolerance: f64::INFINITY,
        sphere_tolerance: f64::INFINITY,
    };

    /// The share of a stage's budget that `counted` of `layers` layers may
    /// use when the rest are excused, for errors that fall as 1/R with the
    /// radius (the volume fractions of clean matches): H(counted) /
    /// H(layers), with H the harmonic numbers.
    pub fn volume_share(counted: usize, layers: usize) -> f64 {
        let h = |n: usize| (1..=n).map(|i| 1.0 / i as f64).sum::<f64>();
        h(counted) / h(layers)
    }

    /// Whether volume layer `layer` (0-based) may be excused.
    pub fn may_excuse_ball(&self, layer: usize) -> bool {
        layer >= self.volume_always_counted
    }

    /// Whether sphere `layer` (0-based) may be excused.
    pub fn may_excuse_sphere(&self, layer: usize) -> bool {
        layer >= self.sphere_always_counted
    }
}

impl Default for ClutterPolicy {
    fn default() -> Self {
        Self::DEFAULT
    }
}
