//! Onion descriptors: layered shape descriptors computed at a point over
//! growing radii r_1 < ... < r_k (paper, sec. 3.2).
//!
//! The cascade only knows the [`OnionDescriptor`] trait: start a point, add
//! one layer at a time, read the running distance to the template, which
//! never decreases (the descriptors are monotonic), so a point whose distance
//! passes the threshold can be dropped at once. Each descriptor keeps what it
//! needs from one layer to the next in its own `State`: a running sum for the
//! voxel descriptors, a growing neighbourhood for the curvature one.

pub(crate) mod batch;
pub mod clutter;
pub mod curvature;
pub mod harmonics;
pub mod volume;

pub use clutter::ClutterPolicy;
pub use curvature::CurvatureDescriptor;
pub use harmonics::{HarmonicsDescriptor, SphericalTransform};
pub use volume::VolumeDescriptor;

use crate::cascade::Anchors;
use crate::exec::Backend;

/// A layered descriptor compared against a template's, point by point.
pub trait OnionDescriptor: Sync {
    /// Per-point data carried from one layer to the next.
    type State: Send;

    /// Short name, as reported in per-layer statistics ("volume", ...).
    fn name(&self) -> &'static str;

    /// Number of layers k.
    fn layers(&self) -> usize;

    /// Radius of layer `layer` (0-based) in world units.
    fn radius(&self, layer: usize) -> f64;

    /// The rejection threshold on the running distance.
    fn threshold(&self) -> f64;

    /// The order in which the cascade computes the layers for the candidates,
    /// each layer once. Innermost first by default, the paper's order: inner
    /// layers are the cheap ones when the cost grows with the radius, and an
    /// incremental descriptor needs it. A descriptor whose layers all cost
    /// the same may put the most selective first (and may look at a sample
    /// of the candidates to find it), as long as its distance stays a lower
    /// bound that the last layer makes exact.
    fn order(&self, _candidates: &[u32], _backend: Backend) -> Vec<usize> {
        (0..self.layers()).collect()
    }

    /// Fresh state for scene point `point`, which still matches the
    /// template's `anchors` (see [`crate::cascade`]).
    fn start(&self, point: u32, anchors: Anchors) -> Self::State;

    /// The anchors a point whose state is `state` still matches: the first
    /// only, for a descriptor read at one anchor.
    fn anchors(&self, _state: &Self::State) -> Anchors {
        1
    }

    /// Called once before layer `layer` is computed for the live `points`:
    /// a descriptor that computes a layer for many points at once (on a
    /// GPU) does it here. Nothing by default.
    fn prepare(&self, _layer: usize, _points: &[u32]) {}

    /// Computes layer `layer` at `point` (in [`Self::order`]) and returns
    /// the running distance over the layers computed so far: it never
    /// decreases, and after the last layer it is the point's distance. Where
    /// a cheaper lower bound of it already passes the threshold, the bound
    /// may be returned instead: the point is dropped either way.
    fn extend(&self, point: u32, layer: usize, state: &mut Self::State) -> f64;
}
