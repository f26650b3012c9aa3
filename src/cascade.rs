//! The Fast Reject loop (paper, Listing 1) over a chain of stages.
//!
//! Every scene point starts as a candidate. Each stage (a descriptor) runs its
//! layers in its order (growing radius unless the descriptor says otherwise,
//! see [`OnionDescriptor::order`]); at each layer it computes that layer for
//! the surviving points only and drops those whose running distance to the
//! template passes the stage's threshold. The next stage starts from the
//! previous one's survivors. Per-layer statistics go to an [`Observer`], which
//! may also stop the search.

use std::ops::ControlFlow;

use crate::clock::now_ms;
use crate::descriptor::OnionDescriptor;
use crate::error::{Error, Result};
use crate::exec::Backend;

/// What one layer of one stage did.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LayerStats {
    /// The stage's descriptor ("volume", "harmonics", ...).
    pub descriptor: &'static str,
    /// Layer number, from 1 (innermost); layers are reported in the order
    /// they were computed.
    pub layer: usize,
    /// The layer's radius in world units.
    pub radius: f64,
    /// Points that entered the layer.
    pub candidates: usize,
    /// Points that passed it.
    pub survivors: usize,
    /// Wall time of the layer in milliseconds.
    pub ms: f64,
}

/// A point that passed every layer, with its final distance in the last stage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Survivor {
    /// Index into the scene's candidate points.
    pub point: u32,
    /// Final running distance of the last stage.
    pub distance: f64,
}

/// Receives per-layer statistics as the search runs (progress bars, logs);
/// returning `Break` cancels the search.
pub trait Observer {
    /// Called after every layer.
    fn on_layer(&mut self, stats: &LayerStats) -> ControlFlow<()>;
}

impl Observer for () {
    fn on_layer(&mut self, _: &LayerStats) -> ControlFlow<()> {
        ControlFlow::Continue(())
    }
}

impl<F: FnMut(&LayerStats) -> ControlFlow<()>> Observer for F {
    fn on_layer(&mut self, stats: &LayerStats) -> ControlFlow<()> {
        self(stats)
    }
}

/// A descriptor with its state type erased, so that stages of different
/// descriptors form one chain.
pub trait Stage: Sync {
    /// Runs all layers over `candidates`; `report` sees every layer.
    fn run(
        &self,
        candidates: Vec<u32>,
        backend: Backend,
        report: &mut dyn FnMut(LayerStats) -> Result<()>,
    ) -> Result<Vec<Survivor>>;
}

impl<D: OnionDescriptor> Stage for D {
    fn run(
        &self,
        candidates: Vec<u32>,
        backend: Backend,
        report: &mut dyn FnMut(LayerStats) -> Result<()>,
    ) -> Result<Vec<Survivor>> {
        let threshold = self.threshold();
        // Choosing the order is part of the first layer's time.
        let mut begun = now_ms();
        let order = self.order(&candidates, backend);
        let mut live: Vec<(u32, D::State, f64)> = candidates
            .into_iter()
            .map(|p| (p, self.start(p), 0.0))
            .collect();
        for layer in order {
            let start = begun;
            let entered = live.len();
            live = backend.filter_map_owned(live, |(p, mut state, _)| {
                let d = self.extend(p, layer, &mut state);
                (d <= threshold).then_some((p, state, d))
            });
            report(LayerStats {
                descriptor: self.name(),
                layer: layer + 1,
                radius: self.radius(layer),
                candidates: entered,
                survivors: live.len(),
                ms: now_ms() - start,
            })?;
            begun = now_ms();
        }
        Ok(live
            .into_iter()
            .map(|(point, _, distance)| Survivor { point, distance })
            .collect())
    }
}

/// Runs the stages in order from `candidates`; returns the survivors of the
/// last stage and the statistics of every layer.
pub fn run_cascade(
    stages: &[&dyn Stage],
    candidates: Vec<u32>,
    backend: Backend,
    observer: &mut dyn Observer,
) -> Result<(Vec<Survivor>, Vec<LayerStats>)> {
    let mut stats = Vec::new();
    let mut report = |s: LayerStats| {
        let flow = observer.on_layer(&s);
        stats.push(s);
        match flow {
            ControlFlow::Continue(()) => Ok(()),
            ControlFlow::Break(()) => Err(Error::Cancelled),
        }
    };
    let mut survivors: Vec<Survivor> = candidates
        .iter()
        .map(|&point| Survivor {
            point,
            distance: 0.0,
        })
        .collect();
    let mut points = candidates;
    for stage in stages {
        survivors = stage.run(points, backend, &mut report)?;
        points = survivors.iter().map(|s| s.point).collect();
    }
    Ok((survivors, stats))
}
