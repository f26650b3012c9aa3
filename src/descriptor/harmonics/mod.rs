//! The rotation-invariant spherical harmonics descriptor (paper, sec. 4.1,
//! after Kazhdan, Funkhouser and Rusinkiewicz 2003).
//!
//! Layer i samples the solid on the sphere of radius r_i around the point,
//! expands that function in spherical harmonics and keeps the energy of each
//! degree l < L: rotating the shape mixes the coefficients within a degree but
//! keeps each degree's norm, so the descriptor ignores orientation.
//!
//! - Sampling: 2B x 2B points on the Driscoll-Healy grid (theta_j =
//!   pi (2j + 1) / 4B, phi_k = pi k / B), the solid read with trilinear
//!   interpolation of the voxel occupancy so that a one-voxel shift does not
//!   flip samples.
//! - Transform: a DFT per ring for orders m < L, then Fejer's quadrature
//!   (exact for polynomials of degree < 2B in cos theta) against fully
//!   normalized associated Legendre functions.
//! - Signature normalization: `s_l = ||f_l|| / sqrt(4 pi)`. By Parseval,
//!   `sum_l s_l^2` is the mean of f^2 over the sphere, at most 1 (a sphere
//!   wholly inside the solid gives s_0 = 1 and nothing else), whatever the
//!   radius, voxel size or scene.
//! - Distance normalization: what separates a true occurrence from the
//!   template is discretization, not shape: the centre lands up to a voxel
//!   away, the rotated copy aliases differently, a remeshed surface moves by
//!   a fraction of a voxel. A deviation of delta voxels changes the
//!   signature of a sphere of R voxels by about delta / R, so small spheres
//!   are noisy and large ones are not (measured on the shared scenes: the
//!   error of true matches falls as 1/R while false matches differ most on
//!   the large spheres). Each sphere's L2 difference is therefore scaled by
//!   its radius in voxels, and the running distance is the root mean square
//!   of these over the k spheres:
//!   `D_i = sqrt(sum_{j <= i} (R_j / voxel)^2 ||s_j - t_j||^2 / k)`.
//!   D reads as "the template deviates like a shift of D voxels", the same
//!   scale for every sphere, template size and scene, which is what lets one
//!   threshold serve them all; it only grows with i (monotonic).
//! - Order: every sphere costs the same, so the stage computes them in the
//!   order that rejects soonest rather than innermost first, with the same
//!   survivors and distances ([`ClutterPolicy::selective_order`]).

use super::{ClutterPolicy, OnionDescriptor};
mod sampler;
mod transform;

#[cfg(feature = "internals")]
pub use sampler::BLOCKS_PER_RADIUS;
pub use sampler::SphereSampler;
pub use transform::SphericalTransform;
#[cfg(any(feature = "gpu", feature = "internals"))]
pub use transform::unfolded_tables;

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock};

use super::batch::BatchFailure;
use super::{LayerBatch, LocalFuture};

use super::volume::closest;
use super::{Anchors, MAX_ANCHORS, all_anchors};
use crate::exec::{Threads, made_once};
use crate::voxel::{Ball, Solid};

/// Bandwidth: 2B x 2B samples per sphere.
pub const BANDWIDTH: usize = 32;
/// Degrees kept: l < L.
pub const DEGREES: usize = 16;

pub(super) const RINGS: usize = 2 * BANDWIDTH;
pub(super) const HALF_RINGS: usize = BANDWIDTH;
pub(super) const SECTORS: usize = 2 * BANDWIDTH;
pub(super) const HALF_SECTORS: usize = BANDWIDTH;
pub(super) const QUARTER_SECTORS: usize = BANDWIDTH / 2;
// A sampling chunk is one ring (one z): the samplers rely on it.
const _: () = assert!(sampler::CHUNK == SECTORS);

/// The per-degree energies of one sphere.
pub type Signature = [f32; DEGREES];

/// Orders with even and odd m: the phi + pi fold treats them apart.
pub(super) const HALF_ORDERS: usize = DEGREES / 2;

/// (-1)^i for i < HALF_ORDERS.
pub(super) const ALTERNATING: [f32; HALF_ORDERS] = {
    let mut a = [1.0f32; HALF_ORDERS];
    let mut i = 1;
    while i < HALF_ORDERS {
        a[i] = -a[i - 1];
        i += 1;
    }
    a
};

/// Degrees of one parity for one order: at most DEGREES / 2.
pub(super) const PARITY_LANES: usize = DEGREES / 2;

/// The signature of one voxel on one sphere (`sampler` made for `solid`).
pub fn describe_sphere(
    solid: &Solid,
    v: [u16; 3],
    sampler: &SphereSampler,
    transform: &SphericalTransform,
) -> Signature {
    let mut samples = [0.0f32; RINGS * SECTORS];
    sampler.sample(solid, v, &mut samples);
    transform.signature(&samples)
}

// A batch's signatures ([`super::LayerBatch`]) are taken as a filter with a
// guard band: the stage carries, per anchor, how far the exact running
// distance can lie from the one it sums (the errors add as a norm: each
// sphere's term moves by at most sqrt(w) times 4 max_error, the 4 being
// sqrt(DEGREES)), and a point whose decision (dropped, kept, a sphere
// excused as cluttered) could differ within that distance is recomputed on
// the CPU, every sphere so far. So the stage keeps and drops exactly the
// points the CPU does; survivors' final distances may differ in the sixth
// digit.

/// A decision a batch's signature leaves open: the point is recomputed
/// exactly.
struct Ambiguous;

/// Candidates sampled to choose the order of the spheres.
pub const ORDER_SAMPLE: usize = 64;

/// Shorter lists keep the default lead: the sample's two spheres per point
/// would cost more than the better lead can save on so few (a scene part
/// often has only a few hundred candidates left).
pub const ORDER_MIN_CANDIDATES: usize = 16 * ORDER_SAMPLE;

/// The harmonics stage of the cascade: rejects a point once the L2 distance
/// between its signatures and the template's, over the spheres so far, passes
/// the threshold.
pub struct HarmonicsDescriptor<'a> {
    solid: &'a Solid,
    points: &'a [[u16; 3]],
    transform: &'a SphericalTransform,
    /// One per layer, made when the first point reaches the layer (see
    /// [`OnionDescriptor::ready_layer`]): making one builds the pyramid
    /// level and occupancy it reads, which most parts of a building of
    /// distinct parts never need.
    spheres: Vec<OnceLock<SphereSampler>>,
    backend: Threads,
    radii: Vec<f64>,
    /// (R_j / voxel)^2 / k: see the module doc.
    weights: Vec<f64>,
    clutter: Option<ClutterGuard<'a>>,
    /// Leading spheres that always count (see [`super::clutter`]).
    clean_layers: usize,
    /// The template's signatures, one list per anchor.
    templates: Vec<Vec<Signature>>,
    threshold: f64,
    /// Where a batch computes the layers: why it failed, if it did.
    batch: BatchFailure,
    /// The batch's error bound per degree (f64 bits: read by every
    /// point's `extend_given`, on any thread).
    batch_error: AtomicU64,
    /// The layers computed so far, in order: what a point recomputed
    /// exactly replays.
    done: Mutex<Vec<usize>>,
}

impl<'a> HarmonicsDescriptor<'a> {
    /// A stage over candidate voxels `points` of the scene `solid`, with the
    /// template's signatures at the same radii (world units), one list per
    /// anchor.
    pub fn new(
        solid: &'a Solid,
        points: &'a [[u16; 3]],
        transform: &'a SphericalTransform,
        radii: &[f64],
        templates: Vec<Vec<Signature>>,
        threshold: f64,
        backend: Threads,
    ) -> Self {
        assert!((1..=MAX_ANCHORS).contains(&templates.len()));
        let voxel = solid.bits().spec().voxel_size;
        HarmonicsDescriptor {
            solid,
            points,
            transform,
            spheres: radii.iter().map(|_| OnceLock::new()).collect(),
            backend,
            radii: radii.to_vec(),
            weights: layer_weights(radii, voxel),
            clutter: None,
            clean_layers: usize::MAX,
            templates,
            threshold,
            batch: BatchFailure::new(),
            batch_error: AtomicU64::new(0),
            done: Mutex::new(Vec::new()),
        }
    }

    /// The sphere sampler of `layer`, made on first use (see
    /// [`made_once`]).
    fn sphere(&self, layer: usize) -> &SphereSampler {
        made_once(&self.spheres[layer], || {
            let voxel = self.solid.bits().spec().voxel_size;
            SphereSampler::new(self.radii[layer] / voxel, self.solid, self.backend)
        })
    }

    /// Adds sphere `layer` at voxel `v` to `state`, from the batch's
    /// signature `given` (with its guard band) or computed here; fails
    /// when a decision is too close to call with `given`.
    fn update(
        &self,
        v: [u16; 3],
        layer: usize,
        state: &mut HarmonicsState,
        given: Option<Signature>,
    ) -> Result<(), Ambiguous> {
        let error = match given {
            Some(_) => f64::from_bits(self.batch_error.load(Ordering::Relaxed)),
            None => 0.0,
        };
        let excusable = layer >= self.clean_layers;
        let guard = self.clutter.as_ref().filter(|_| excusable);
        // The scene's side is read once, and only if some anchor compares
        // it: excusable spheres come outward, so one beyond an anchor's
        // first cluttered sphere is not compared for it.
        let compared =
            |a: usize| state.alive & (1 << a) != 0 && !(excusable && state.excused_at[a].is_some());
        let compares: Vec<usize> = (0..self.templates.len()).filter(|&a| compared(a)).collect();
        let fraction = guard.map(|g| g.balls[layer].fraction(self.solid, v));
        let ball_clean = |a: usize| match (guard, fraction) {
            (Some(g), Some(f)) => f - g.templates[a][layer] <= g.policy.volume_tolerance,
            _ => true,
        };
        let mut sig = given;
        for a in compares {
            // Degree 0 of the signature is the sphere's mean occupancy.
            let clean = ball_clean(a) && {
                let s = sig.get_or_insert_with(|| {
                    describe_sphere(self.solid, v, self.sphere(layer), self.transform)
                });
                match guard {
                    None => true,
                    Some(g) => {
                        let over = ((s[0] - self.templates[a][layer][0]) as f64)
                            - g.policy.sphere_tolerance;
                        if error > 0.0 && over.abs() <= error {
                            return Err(Ambiguous);
                        }
                        over <= 0.0
                    }
                }
            };
            if clean {
                let s = sig.as_ref().expect("read for a clean sphere");
                state.sum2[a] +=
                    self.weights[layer] * signature_distance2(s, &self.templates[a][layer]);
                state.slack2[a] += self.weights[layer] * (4.0 * error).powi(2);
            } else {
                state.excused_at[a] = Some(layer.min(usize::from(u16::MAX)) as u16);
            }
            // Compared over the `e` spheres inside the first cluttered one
            // only: their root mean square must meet the threshold (the
            // weights carry 1 / k). The spheres inside it still to come
            // only add to the sum.
            let budget = match state.excused_at[a] {
                Some(e) => self.threshold.powi(2) * f64::from(e) / self.radii.len() as f64,
                None => self.threshold.powi(2),
            };
            let slack = state.slack2[a].sqrt();
            if slack > 0.0 && (state.sum2[a].sqrt() - budget.sqrt()).abs() <= slack {
                return Err(Ambiguous);
            }
            if state.sum2[a] > budget {
                state.alive &= !(1 << a);
            }
        }
        Ok(())
    }

    /// The state of `point`, which entered the stage matching `entered`,
    /// over the layers computed so far, every sphere on the CPU.
    fn replay(&self, point: u32, entered: Anchors) -> HarmonicsState {
        let v = self.points[point as usize];
        let mut state = self.start(point, entered);
        let done = self.done.lock().unwrap_or_else(|p| p.into_inner()).clone();
        for layer in done {
            if state.alive == 0 {
                break;
            }
            // Exact: nothing is ambiguous.
            let _ = self.update(v, layer, &mut state, None);
        }
        state
    }

    /// Excuses cluttered spheres (see [`super::clutter`]); without a guard
    /// every sphere counts.
    pub fn with_clutter(mut self, guard: ClutterGuard<'a>) -> Self {
        let voxel = self.solid.bits().spec().voxel_size;
        let radii_voxels: Vec<f64> = self.radii.iter().map(|r| r / voxel).collect();
        self.clean_layers = guard.policy.clean_layers(&radii_voxels);
        self.clutter = Some(guard);
        self
    }

    /// The signatures of one voxel of any solid at `radii` (world units):
    /// what the template side computes.
    pub fn describe(
        solid: &Solid,
        v: [u16; 3],
        radii: &[f64],
        transform: &SphericalTransform,
        backend: Threads,
    ) -> Vec<Signature> {
        let voxel = solid.bits().spec().voxel_size;
        radii
            .iter()
            .map(|r| {
                describe_sphere(
                    solid,
                    v,
                    &SphereSampler::new(r / voxel, solid, backend),
                    transform,
                )
            })
            .collect()
    }
}

/// What the harmonics stage needs to recognize clutter: the volume balls at
/// its radii with the template's fractions, and the
/// policy.
pub struct ClutterGuard<'a> {
    /// The policy.
    pub policy: ClutterPolicy,
    /// Balls at the stage's radii, made for the scene's solid.
    pub balls: &'a [Ball],
    /// The template's solid fraction at each radius, per anchor.
    pub templates: &'a [Vec<f64>],
}

/// The running state of a point in the harmonics stage, per anchor.
#[derive(Clone, Copy, Debug, Default)]
pub struct HarmonicsState {
    /// Weighted squared differences of the spheres compared so far.
    sum2: [f64; MAX_ANCHORS],
    /// The first cluttered sphere met: it and the larger ones are not
    /// compared, and the point is judged over the spheres inside it.
    /// (Layer numbers above u16 are refused by the memory budget long
    /// before: every layer has its own ball tables.)
    excused_at: [Option<u16>; MAX_ANCHORS],
    /// Anchors still matched, and those the point entered the stage with.
    alive: Anchors,
    entered: Anchors,
    /// How far, squared, the exact sum's root can lie from `sum2`'s where
    /// a batch's signatures were summed (0 when every sphere was computed
    /// here).
    slack2: [f64; MAX_ANCHORS],
}

impl OnionDescriptor for HarmonicsDescriptor<'_> {
    type State = HarmonicsState;
    type Value = Signature;

    fn name(&self) -> &'static str {
        "harmonics"
    }

    fn layers(&self) -> usize {
        self.radii.len()
    }

    fn radius(&self, layer: usize) -> f64 {
        self.radii[layer]
    }

    fn threshold(&self) -> f64 {
        self.threshold
    }

    fn ready_layer(&self, layer: usize) {
        self.sphere(layer);
    }

    /// The selective order ([`ClutterPolicy::selective_order`]) with the
    /// lead that passes fewer of [`ORDER_SAMPLE`] candidates spread over the
    /// list (an excused sphere passes): about 130 spheres to save thousands
    /// where the scene favours the other lead. Only speed depends on it.
    fn order(&self, candidates: &[u32], backend: Threads) -> Vec<usize> {
        let (clean, k) = (self.clean_layers.min(self.radii.len()), self.radii.len());
        let excusable_first =
            (1..k).contains(&clean) && candidates.len() >= ORDER_MIN_CANDIDATES && {
                // Made here, before the sample is shared out to threads.
                self.ready_layer(clean - 1);
                self.ready_layer(clean);
                let sample: Vec<u32> = candidates
                    .iter()
                    .step_by((candidates.len() / ORDER_SAMPLE).max(1))
                    .copied()
                    .collect();
                let passes = backend.map(sample.len(), |i| {
                    let p = sample[i];
                    let pass = |layer| {
                        self.extend(p, layer, &mut self.start(p, Anchors::MAX)) <= self.threshold
                    };
                    [pass(clean - 1), pass(clean)]
                });
                let count = |lead: usize| passes.iter().filter(|p| p[lead]).count();
                count(1) < count(0)
            };
        ClutterPolicy::selective_order(clean, k, excusable_first)
    }

    fn start(&self, _point: u32, anchors: Anchors) -> HarmonicsState {
        HarmonicsState {
            alive: anchors & all_anchors(self.templates.len()),
            entered: anchors,
            ..HarmonicsState::default()
        }
    }

    fn anchors(&self, state: &HarmonicsState) -> Anchors {
        state.alive
    }

    fn prepare<'b>(
        &'b self,
        layer: usize,
        points: &'b [u32],
        batch: &'b dyn LayerBatch,
    ) -> LocalFuture<'b, Option<Vec<Signature>>> {
        Box::pin(async move {
            self.done
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .push(layer);
            self.batch_error.store(
                f64::from(batch.max_sphere_error()).to_bits(),
                Ordering::Relaxed,
            );
            let voxels = self.batch.voxels_to_compute(points, self.points)?;
            let signatures = batch.sphere_signatures(self.sphere(layer), &voxels).await;
            self.batch.accept(signatures, points.len())
        })
    }

    fn batch_failure(&self) -> Option<String> {
        self.batch.reason()
    }

    fn extend(&self, point: u32, layer: usize, state: &mut HarmonicsState) -> f64 {
        // Exact: nothing is ambiguous.
        let _ = self.update(self.points[point as usize], layer, state, None);
        closest(&state.sum2, state.alive).sqrt()
    }

    fn extend_given(
        &self,
        point: u32,
        layer: usize,
        state: &mut HarmonicsState,
        given: Signature,
    ) -> f64 {
        let mut trial = *state;
        match self.update(self.points[point as usize], layer, &mut trial, Some(given)) {
            Ok(()) => *state = trial,
            Err(Ambiguous) => *state = self.replay(point, state.entered),
        }
        closest(&state.sum2, state.alive).sqrt()
    }
}

/// Each sphere's weight in the stage's distance: (R_j / voxel)^2 / k (see
/// the module doc).
fn layer_weights(radii: &[f64], voxel: f64) -> Vec<f64> {
    radii
        .iter()
        .map(|r| (r / voxel).powi(2) / radii.len() as f64)
        .collect()
}

/// The stage's distance between two points' signatures at `radii` (world
/// units, voxels of `voxel`) when every sphere counts: what the threshold
/// is compared with.
pub fn harmonics_distance(a: &[Signature], b: &[Signature], radii: &[f64], voxel: f64) -> f64 {
    layer_weights(radii, voxel)
        .iter()
        .zip(a.iter().zip(b))
        .map(|(w, (x, y))| w * signature_distance2(x, y))
        .sum::<f64>()
        .sqrt()
}

/// Squared L2 distance between two signatures.
pub fn signature_distance2(a: &Signature, b: &Signature) -> f64 {
    a.iter().zip(b).map(|(x, y)| ((x - y) as f64).powi(2)).sum()
}

#[cfg(test)]
mod tests;
