//! Onion descriptors: layered shape descriptors computed at a point over
//! growing radii r_1 < ... < r_k (paper, sec. 3.2).
//!
//! The cascade only knows the [`OnionDescriptor`] trait: start a point, add
//! one layer at a time, read the running distance to the template, which
//! never decreases (the descriptors are monotonic), so a point whose distance
//! passes the threshold can be dropped at once. Each descriptor keeps what it
//! needs from one layer to the next in its own `State`: a running sum for the
//! voxel descriptors, a growing neighbourhood for the curvature one.

mod anchors;
pub(crate) mod batch;
pub mod centroid;
pub mod clutter;
pub mod curvature;
mod device;
pub mod harmonics;
pub mod volume;

pub use anchors::{Anchors, MAX_ANCHORS, all_anchors};
pub use centroid::{CentroidDescriptor, CentroidTemplate};
pub use clutter::ClutterPolicy;
pub use curvature::CurvatureDescriptor;
pub use device::{LayerDevice, WaveQueue, run_together};
pub use harmonics::{HarmonicsDescriptor, SphericalTransform};
pub use volume::VolumeDescriptor;

use std::future::Future;
use std::pin::Pin;

use crate::exec::Threads;
use crate::voxel::Ball;
use harmonics::{Signature, SphereSampler};

/// A future that may borrow its inputs and need not be `Send`: GPU handles
/// are not, in the threaded WebAssembly build.
pub type LocalFuture<'a, T> = Pin<Box<dyn Future<Output = T> + 'a>>;

/// Computes one layer for many points at once (a GPU), on the thread that
/// runs the search, and lets the search wait for it without blocking (a
/// browser answers only on its event loop). Not `Sync`: the stages keep
/// its results, never the batch itself, so their per-point work can still
/// run on other threads.
pub trait LayerBatch {
    /// The solid voxels in `ball` around each of `voxels`: the same
    /// integers as the volume stage's own counts. `Err` says why not; the
    /// stage then counts on the CPU.
    fn ball_counts<'a>(
        &'a self,
        ball: &'a Ball,
        voxels: &'a [[u16; 3]],
    ) -> LocalFuture<'a, Result<Vec<u64>, String>>;

    /// The signatures of the sphere `sampler` around each of `voxels`,
    /// each degree within [`LayerBatch::max_sphere_error`] of the CPU's.
    fn sphere_signatures<'a>(
        &'a self,
        sampler: &'a SphereSampler,
        voxels: &'a [[u16; 3]],
    ) -> LocalFuture<'a, Result<Vec<Signature>, String>>;

    /// The largest difference per degree of a signature from the CPU's.
    fn max_sphere_error(&self) -> f32;
}

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
    /// each layer at most once. Innermost first by default, the paper's order: inner
    /// layers are the cheap ones when the cost grows with the radius, and an
    /// incremental descriptor needs it. A descriptor whose layers all cost
    /// the same may put the most selective first (and may look at a sample
    /// of the candidates to find it), as long as its distance stays a lower
    /// bound that the last layer makes exact. A descriptor that only
    /// filters for a later stage (the centroid) may leave layers out.
    fn order(&self, _candidates: &[u32], _backend: Threads) -> Vec<usize> {
        (0..self.layers()).collect()
    }

    /// Makes what layer `layer` reads and builds on first use (the
    /// harmonics' sphere sampler and the pyramid level under it). The
    /// cascade calls it before it shares the layer's points out to
    /// threads, and only when some point is left to it: on a building of
    /// distinct parts most parts reach few layers of the last stage.
    fn ready_layer(&self, _layer: usize) {}

    /// Fresh state for scene point `point`, which still matches the
    /// template's `anchors` (see [`crate::cascade`]).
    fn start(&self, point: u32, anchors: Anchors) -> Self::State;

    /// The anchors a point whose state is `state` still matches: the first
    /// only, for a descriptor read at one anchor.
    fn anchors(&self, _state: &Self::State) -> Anchors {
        1
    }

    /// What a batch computes for one point at one layer (a ball's count,
    /// a sphere's signature); `()` for a descriptor no batch computes.
    type Value: Copy + Send + Sync;

    /// Called once before layer `layer` is computed for the live `points`
    /// when the search has a `batch`: a descriptor that can computes the
    /// layer for all of them there and returns the values in `points`'
    /// order, which [`Self::extend_given`] then receives point by point
    /// (no lookup: a shared table read by every point cost the GPU path
    /// more than the CPU's own counting). `None`: [`Self::extend`]
    /// computes the layer.
    fn prepare<'a>(
        &'a self,
        _layer: usize,
        _points: &'a [u32],
        _batch: &'a dyn LayerBatch,
    ) -> LocalFuture<'a, Option<Vec<Self::Value>>> {
        Box::pin(std::future::ready(None))
    }

    /// Why a batch failed, if it did (the layers from then on ran on the
    /// CPU, with the same results).
    fn batch_failure(&self) -> Option<String> {
        None
    }

    /// Computes layer `layer` at `point` (in [`Self::order`]) and returns
    /// the running distance over the layers computed so far: it never
    /// decreases, and after the last layer it is the point's distance. Where
    /// a cheaper lower bound of it already passes the threshold, the bound
    /// may be returned instead: the point is dropped either way.
    fn extend(&self, point: u32, layer: usize, state: &mut Self::State) -> f64;

    /// [`Self::extend`] with the layer's value at `point` computed by a
    /// batch ([`Self::prepare`]).
    fn extend_given(
        &self,
        point: u32,
        layer: usize,
        state: &mut Self::State,
        given: Self::Value,
    ) -> f64 {
        let _ = given;
        self.extend(point, layer, state)
    }
}
