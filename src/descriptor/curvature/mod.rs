//! Gaussian curvature onion descriptor (paper, sec. 4.3).
//!
//! At a mesh vertex v and radius r, the curvature tensor of the surface in
//! the ball B(v, r) is (Cohen-Steiner and Morvan's normal cycle estimate)
//!
//!   T = 1/|B| * sum over edges e of beta(e) |e ∩ B| e e^T
//!
//! with beta(e) the signed dihedral angle, |e ∩ B| the exact length of the
//! edge inside the ball, e the unit edge direction and |B| the exact area of
//! the surface inside the ball. Only the part of the surface connected to v
//! inside the ball counts: a nearby but separate sheet (the other side of a
//! thin part, a neighbouring object) is not this point's neighbourhood.
//! The layer's value is the Gaussian curvature: the product of the two
//! eigenvalues of T of largest magnitude (the third belongs to the normal
//! and is near zero). A product of two angles, it does not depend on which
//! side the winding calls outside.
//!
//! Layers are incremental: the connected neighbourhood gathered for r_i is
//! grown for r_{i+1}, never gathered again, and triangles wholly inside a
//! ball are summed once (they stay inside the larger ones); only those cut
//! by the sphere are clipped again. Values are compared after
//! scaling by r_k^2, which makes them independent of the scene's units.

mod ball_clip;
mod bounds;
#[cfg(any(test, feature = "internals"))]
mod kernel;
mod mirror;
mod neighbourhood;
mod sample;
mod surface;

#[cfg(any(test, feature = "internals"))]
pub use ball_clip::clip_triangle_to_ball;
#[cfg(feature = "internals")]
pub use ball_clip::{ClippedTriangle, segment_in_ball};
#[cfg(feature = "internals")]
pub use kernel::{KernelNorm, KernelShape, kernel_layers_at};
pub(crate) use mirror::MirrorTest;
#[cfg(any(test, feature = "internals"))]
pub use mirror::handedness;
pub use neighbourhood::CurvatureState;
#[cfg(feature = "internals")]
pub use sample::VertexGrid;
pub(crate) use sample::{SAMPLE_REACH, SAMPLE_SLACK, VertexSample};
pub use surface::Surface;
pub(crate) use surface::surface_bytes;
#[cfg(feature = "internals")]
pub use surface::{CurvedEdge, Edge};

use super::OnionDescriptor;
use crate::descriptor::Anchors;
use crate::math::Vec3;
use bounds::{BOUND_MARGIN, gaussian_bounds};
use neighbourhood::{add_cut_areas, add_cut_edges, gather, grow_layer};
use std::sync::atomic::{AtomicU64, Ordering};

/// The curvature descriptor of a scene's surface against a template's.
pub struct CurvatureDescriptor<'a> {
    name: &'static str,
    surface: &'a Surface,
    radii: Vec<f64>,
    /// The template's layers, scaled.
    template: Vec<f64>,
    /// r_k^2: the scale of every value.
    scale: f64,
    threshold: f64,
    /// Triangles the layers have measured so far (gathered into a
    /// neighbourhood or clipped by a sphere): what the search's time
    /// follows, counted so that it can be bounded.
    work: AtomicU64,
}

/// One layer of the neighbourhood of a vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layer {
    /// Gaussian curvature (unscaled).
    pub gaussian: f64,
    /// Centre of the area of the neighbourhood, relative to the vertex:
    /// which way the surface around it extends (see [`handedness`]).
    pub centroid: Vec3,
}

impl<'a> CurvatureDescriptor<'a> {
    /// Compares `surface` against the template layers `template` (unscaled
    /// Gaussian curvatures at `radii`); rejects past `threshold`.
    pub fn new(
        surface: &'a Surface,
        radii: &[f64],
        template: &[f64],
        threshold: f64,
    ) -> CurvatureDescriptor<'a> {
        let outer = radii.last().copied().unwrap_or(1.0);
        let scale = outer * outer;
        CurvatureDescriptor {
            name: "curvature",
            surface,
            radii: radii.to_vec(),
            template: template.iter().map(|g| g * scale).collect(),
            scale,
            threshold,
            work: AtomicU64::new(0),
        }
    }

    /// Triangles measured by every layer computed so far: those a
    /// neighbourhood gathered, and those a sphere cut, once per layer.
    pub fn work(&self) -> u64 {
        self.work.load(Ordering::Relaxed)
    }

    /// The same descriptor reported under another stage name (a pass over
    /// a sample of the vertices, say).
    pub fn named(self, name: &'static str) -> CurvatureDescriptor<'a> {
        CurvatureDescriptor { name, ..self }
    }

    /// The same descriptor with nothing measured yet: a probe whose work
    /// is counted apart.
    pub fn fresh(&self) -> CurvatureDescriptor<'a> {
        CurvatureDescriptor {
            radii: self.radii.clone(),
            template: self.template.clone(),
            work: AtomicU64::new(0),
            ..*self
        }
    }

    /// The Gaussian curvature of `surface` at vertex `v` for every radius:
    /// the template's descriptor, computed the same way as the scene's.
    #[cfg(any(test, feature = "internals"))]
    pub fn describe(surface: &Surface, v: u32, radii: &[f64]) -> Vec<f64> {
        Self::layers_at(surface, v, radii)
            .iter()
            .map(|l| l.gaussian)
            .collect()
    }

    /// Every layer at vertex `v`, with the centroids.
    pub fn layers_at(surface: &Surface, v: u32, radii: &[f64]) -> Vec<Layer> {
        let mut state = CurvatureState::at(surface, v);
        radii
            .iter()
            .map(|&r| grow_layer(surface, v, r, &mut state))
            .collect()
    }
}

impl OnionDescriptor for CurvatureDescriptor<'_> {
    type State = CurvatureState;
    type Value = ();

    fn name(&self) -> &'static str {
        self.name
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

    fn start(&self, point: u32, _anchors: Anchors) -> CurvatureState {
        CurvatureState::at(self.surface, point)
    }

    fn extend(&self, point: u32, layer: usize, state: &mut CurvatureState) -> f64 {
        let gathered = state.region.len();
        let ball = gather(self.surface, point, self.radii[layer], state);
        let measured = state.region.len() - gathered + state.cut.len();
        self.work.fetch_add(measured as u64, Ordering::Relaxed);
        let (sums, cut_area) = add_cut_edges(self.surface, &ball, state);
        // Most points are rejected here, before the cut triangles' areas
        // are clipped.
        let (low, high) = gaussian_bounds(sums.tensor, sums.area, sums.area + cut_area);
        let t = self.template[layer];
        let gap = (low * self.scale - t).max(t - high * self.scale).max(0.0);
        let lower = state.distance + gap * gap;
        if lower > self.threshold * (1.0 + BOUND_MARGIN) {
            return lower;
        }
        let g = add_cut_areas(self.surface, &ball, state, sums).gaussian * self.scale;
        let d = g - self.template[layer];
        state.distance += d * d;
        state.distance
    }
}

#[cfg(test)]
mod tests;
