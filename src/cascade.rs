//! The Fast Reject loop (paper, Listing 1) over a chain of stages.
//!
//! Every scene point starts as a candidate. Each stage (a descriptor) runs its
//! layers in its order (growing radius unless the descriptor says otherwise,
//! see [`OnionDescriptor::order`]); at each layer it computes that layer for
//! the surviving points only and drops those whose running distance to the
//! template passes the stage's threshold. The next stage starts from the
//! previous one's survivors. Per-layer statistics go to an [`Observer`], which
//! may also stop the search.
//!
//! A template may be read at several anchors (points of its surface), so
//! that a copy cluttered at one is found at another. A point's descriptor is
//! computed once per layer and compared with every anchor's: a point stays
//! a candidate while any anchor still matches it, and [`Anchors`] says
//! which. The cost is that of the union of the anchors' survivors, not of
//! a cascade per anchor.

use std::ops::ControlFlow;

use crate::clock::now_ms;
use crate::descriptor::{Anchors, LayerBatch, LocalFuture, OnionDescriptor};
use crate::error::{Error, Result};
use crate::exec::Threads;

/// What one layer of one stage did.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
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
    /// Final running distance of the last stage: the smallest of its
    /// anchors'.
    pub distance: f64,
    /// The anchors it matched through every stage.
    pub anchors: Anchors,
}

/// How far a long step of the search has come: between layers, a search
/// of many parts or many windows would otherwise be silent for minutes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Progress {
    /// What is being worked through: [`Progress::PARTS`],
    /// [`Progress::WINDOWS`], [`Progress::CANDIDATES`],
    /// [`Progress::SURFACE`], [`Progress::REPEATS`] or [`Progress::SCENE`].
    pub step: &'static str,
    /// How many of them are done.
    pub done: usize,
    /// How many there are.
    pub total: usize,
}

impl Progress {
    /// The scene's parts that can hold a copy, each searched on its grid.
    pub const PARTS: &'static str = "parts";
    /// The windows of a part too large for one grid.
    pub const WINDOWS: &'static str = "windows";
    /// The mesh's vertices, for the curvature descriptor.
    pub const CANDIDATES: &'static str = "candidates";
    /// The steps of welding the mesh and building its adjacency, before
    /// the curvature descriptor's first layer.
    pub const SURFACE: &'static str = "surface steps";
    /// The steps of finding a scene's repeated parts, and of reading and
    /// writing it around them.
    pub const REPEATS: &'static str = "repeat steps";
    /// The steps of preparing a scene: its voxel work checked, its
    /// connected parts, their shapes, its memory checked.
    pub const SCENE: &'static str = "scene steps";

    /// The share done, 0 to 1 (1 when there is nothing to do).
    pub fn share(&self) -> f64 {
        if self.total == 0 {
            1.0
        } else {
            self.done.min(self.total) as f64 / self.total as f64
        }
    }
}

/// Receives per-layer statistics and progress as the search runs (progress
/// bars, logs); returning `Break` from either cancels the search.
pub trait Observer {
    /// Called after every layer.
    fn on_layer(&mut self, stats: &LayerStats) -> ControlFlow<()>;

    /// Called as a long step advances; ignored unless overridden.
    fn on_progress(&mut self, _progress: &Progress) -> ControlFlow<()> {
        ControlFlow::Continue(())
    }
}

/// A fixed number of steps, told to an observer as each ends: one count,
/// so that every step-wise job reports and stops alike.
pub(crate) struct Steps<'a> {
    observer: &'a mut dyn Observer,
    step: &'static str,
    total: usize,
    done: usize,
}

impl<'a> Steps<'a> {
    /// `total` steps of kind `step` ([`Progress::SCENE`], ...), none done.
    pub(crate) fn new(observer: &'a mut dyn Observer, step: &'static str, total: usize) -> Self {
        Steps {
            observer,
            step,
            total,
            done: 0,
        }
    }

    /// One more step is done; [`Error::Cancelled`] when the observer says
    /// stop.
    pub(crate) fn done(&mut self) -> Result<()> {
        self.done += 1;
        let progress = Progress {
            step: self.step,
            done: self.done,
            total: self.total,
        };
        go_on(self.observer.on_progress(&progress))
    }
}

/// An observer's answer as the search's: a `Break` is [`Error::Cancelled`].
pub(crate) fn go_on(flow: ControlFlow<()>) -> Result<()> {
    match flow {
        ControlFlow::Continue(()) => Ok(()),
        ControlFlow::Break(()) => Err(Error::Cancelled),
    }
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
    /// Runs all layers over `candidates` (points with the anchors they
    /// still match), each computed first in `batch` where one is given;
    /// `report` sees every layer.
    fn run<'a>(
        &'a self,
        candidates: Vec<(u32, Anchors)>,
        backend: Threads,
        batch: Option<&'a dyn LayerBatch>,
        report: &'a mut dyn FnMut(LayerStats) -> Result<()>,
    ) -> LocalFuture<'a, Result<Vec<Survivor>>>;

    /// Why its batch failed, if it did.
    fn batch_failure(&self) -> Option<String>;
}

impl<D: OnionDescriptor> Stage for D {
    fn run<'a>(
        &'a self,
        candidates: Vec<(u32, Anchors)>,
        backend: Threads,
        batch: Option<&'a dyn LayerBatch>,
        report: &'a mut dyn FnMut(LayerStats) -> Result<()>,
    ) -> LocalFuture<'a, Result<Vec<Survivor>>> {
        Box::pin(async move {
            let threshold = self.threshold();
            // Choosing the order is part of the first layer's time.
            let mut begun = now_ms();
            let points: Vec<u32> = candidates.iter().map(|&(p, _)| p).collect();
            let order = self.order(&points, backend);
            drop(points);
            let mut live: Vec<(u32, D::State, f64)> = candidates
                .into_iter()
                .map(|(p, anchors)| (p, self.start(p, anchors), 0.0))
                .collect();
            for layer in order {
                let start = begun;
                let entered = live.len();
                if entered > 0 {
                    self.ready_layer(layer);
                }
                let given = match batch {
                    Some(batch) => {
                        let points: Vec<u32> = live.iter().map(|&(p, ..)| p).collect();
                        self.prepare(layer, &points, batch).await
                    }
                    None => None,
                };
                live = match given {
                    Some(values) => {
                        backend.filter_map_zipped(live, values, |(p, mut state, _), value| {
                            let d = self.extend_given(p, layer, &mut state, value);
                            (d <= threshold).then_some((p, state, d))
                        })
                    }
                    None => backend.filter_map_owned(live, |(p, mut state, _)| {
                        let d = self.extend(p, layer, &mut state);
                        (d <= threshold).then_some((p, state, d))
                    }),
                };
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
                .map(|(point, state, distance)| Survivor {
                    point,
                    distance,
                    anchors: self.anchors(&state),
                })
                .collect())
        })
    }

    fn batch_failure(&self) -> Option<String> {
        OnionDescriptor::batch_failure(self)
    }
}

/// Runs the stages in order from `candidates`, each matching the anchors
/// `anchors`, computing layers first in `batch` where one is given;
/// returns the survivors of the last stage and the statistics of every
/// layer.
pub async fn run_cascade(
    stages: &[&dyn Stage],
    candidates: Vec<u32>,
    anchors: Anchors,
    backend: Threads,
    batch: Option<&dyn LayerBatch>,
    observer: &mut dyn Observer,
) -> Result<(Vec<Survivor>, Vec<LayerStats>)> {
    let mut stats = Vec::new();
    let mut report = |s: LayerStats| {
        let flow = observer.on_layer(&s);
        stats.push(s);
        go_on(flow)
    };
    let mut survivors: Vec<Survivor> = candidates
        .iter()
        .map(|&point| Survivor {
            point,
            distance: 0.0,
            anchors,
        })
        .collect();
    let mut points: Vec<(u32, Anchors)> = candidates.into_iter().map(|p| (p, anchors)).collect();
    for stage in stages {
        survivors = stage.run(points, backend, batch, &mut report).await?;
        points = survivors.iter().map(|s| (s.point, s.anchors)).collect();
    }
    Ok((survivors, stats))
}

/// Runs the stages over `candidates` with no batch, each thread taking a
/// chunk of `chunk` points through every layer at a time: the survivors of
/// one run, but only one chunk's states per thread alive at once. A
/// descriptor whose state grows with the ball (the curvature's
/// neighbourhood) would otherwise hold every candidate's: gigabytes on a
/// finely fanned mesh. The observer sees the layers of a round of chunks at
/// a time, their times shared out of the round's wall time.
pub fn run_cascade_in_chunks(
    stages: &[&dyn Stage],
    candidates: Vec<u32>,
    chunk: usize,
    anchors: Anchors,
    backend: Threads,
    observer: &mut dyn Observer,
) -> Result<(Vec<Survivor>, Vec<LayerStats>)> {
    if candidates.is_empty() {
        // The layers are still reported, each empty.
        return finished(run_cascade(
            stages, candidates, anchors, backend, None, observer,
        ));
    }
    let chunk = chunk.max(1);
    let mut survivors = Vec::new();
    let mut stats = Vec::new();
    let mut done = 0;
    for round in candidates.chunks(chunk * ROUND_CHUNKS) {
        let began = now_ms();
        let pieces: Vec<&[u32]> = round.chunks(chunk).collect();
        let runs = backend.map_each(pieces.len(), |i| {
            let quiet = &mut ();
            finished(run_cascade(
                stages,
                pieces[i].to_vec(),
                anchors,
                Threads::Serial,
                None,
                quiet,
            ))
        });
        let wall = now_ms() - began;
        let mut round_stats = Vec::new();
        for run in runs {
            let (some, more) = run?;
            survivors.extend(some);
            add_layer_stats(&mut round_stats, more);
        }
        let busy: f64 = round_stats.iter().map(|s| s.ms).sum();
        for s in &mut round_stats {
            s.ms = if busy > 0.0 { s.ms * wall / busy } else { 0.0 };
            if observer.on_layer(s).is_break() {
                return Err(Error::Cancelled);
            }
        }
        add_layer_stats(&mut stats, round_stats);
        done += round.len();
        let progress = Progress {
            step: Progress::CANDIDATES,
            done,
            total: candidates.len(),
        };
        if observer.on_progress(&progress).is_break() {
            return Err(Error::Cancelled);
        }
    }
    Ok((survivors, stats))
}

/// Chunks per round of [`run_cascade_in_chunks`]: enough for the threads to
/// share evenly, few enough that a cancel is heard within a second or so.
const ROUND_CHUNKS: usize = 32;

/// Adds `more` to the statistics of the same stage and layer in `stats`
/// (appended where there are none yet): the layers of several runs (parts,
/// chunks) as one.
pub fn add_layer_stats(stats: &mut Vec<LayerStats>, more: Vec<LayerStats>) {
    for s in more {
        match stats
            .iter_mut()
            .find(|t| t.descriptor == s.descriptor && t.layer == s.layer)
        {
            Some(t) => {
                t.candidates += s.candidates;
                t.survivors += s.survivors;
                t.ms += s.ms;
            }
            None => stats.push(s),
        }
    }
}

/// The output of a future that never waits: a search with no batch (its
/// stages compute every layer themselves). Polled once; one that would
/// wait is a bug.
pub fn finished<T>(future: impl std::future::Future<Output = T>) -> T {
    let mut future = std::pin::pin!(future);
    let mut context = std::task::Context::from_waker(std::task::Waker::noop());
    match future.as_mut().poll(&mut context) {
        std::task::Poll::Ready(value) => value,
        std::task::Poll::Pending => unreachable!("a search with no batch never waits"),
    }
}

/// Bytes each candidate point holds at most while the cascade runs: its
/// index, a descriptor state and its running distance, in the list being
/// filtered and the one being built.
const BYTES_PER_CANDIDATE: u64 = 128;

/// Bytes of the cascade's state for `candidates` points.
pub(crate) fn candidate_bytes(candidates: usize) -> u64 {
    BYTES_PER_CANDIDATE.saturating_mul(candidates as u64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    /// A descriptor read from a table: layer `l` adds `steps[p][l]` to
    /// point `p`'s running distance. It records every (point, layer) it
    /// computes, and checks that each point gets its layers in `order`.
    struct Table {
        name: &'static str,
        steps: Vec<Vec<f64>>,
        order: Vec<usize>,
        threshold: f64,
        computed: Mutex<Vec<(u32, usize)>>,
    }

    impl Table {
        fn new(
            name: &'static str,
            steps: Vec<Vec<f64>>,
            order: Vec<usize>,
            threshold: f64,
        ) -> Self {
            Table {
                name,
                steps,
                order,
                threshold,
                computed: Mutex::new(Vec::new()),
            }
        }

        fn computed(&self) -> Vec<(u32, usize)> {
            self.computed.lock().unwrap().clone()
        }
    }

    impl OnionDescriptor for Table {
        /// The layers computed so far and the running distance.
        type State = (Vec<usize>, f64);
        type Value = ();

        fn name(&self) -> &'static str {
            self.name
        }

        fn layers(&self) -> usize {
            self.order.len()
        }

        fn radius(&self, layer: usize) -> f64 {
            0.5 * (layer + 1) as f64
        }

        fn threshold(&self) -> f64 {
            self.threshold
        }

        fn order(&self, _: &[u32], _: Threads) -> Vec<usize> {
            self.order.clone()
        }

        fn start(&self, _: u32, _: Anchors) -> Self::State {
            (Vec::new(), 0.0)
        }

        fn extend(&self, point: u32, layer: usize, state: &mut Self::State) -> f64 {
            assert_eq!(
                layer,
                self.order[state.0.len()],
                "point {point}: layer {layer} after {:?}",
                state.0
            );
            self.computed.lock().unwrap().push((point, layer));
            state.0.push(layer);
            state.1 += self.steps[point as usize][layer];
            state.1
        }
    }

    /// Six points, three layers computed in the order 2, 0, 1, threshold 1.
    fn six_points() -> Table {
        Table::new(
            "table",
            vec![
                vec![0.1, 0.1, 0.1],  // passes every layer: 0.3
                vec![0.0, 0.0, 1.5],  // fails the first layer computed (2)
                vec![0.9, 0.0, 0.2],  // fails the second (layer 0): 1.1
                vec![0.2, 0.75, 0.1], // passes two, fails the last (1): 1.05
                vec![0.5, 0.0, 0.5],  // ends exactly at the threshold: passes
                vec![0.0, 0.0, 0.0],  // passes at 0
            ],
            vec![2, 0, 1],
            1.0,
        )
    }

    fn run(
        stages: &[&dyn Stage],
        candidates: Vec<u32>,
        backend: Threads,
    ) -> (Vec<Survivor>, Vec<LayerStats>) {
        finished(run_cascade(stages, candidates, 1, backend, None, &mut ())).unwrap()
    }

    /// The statistics without the times.
    fn counts(stats: &[LayerStats]) -> Vec<(&'static str, usize, f64, usize, usize)> {
        stats
            .iter()
            .map(|s| (s.descriptor, s.layer, s.radius, s.candidates, s.survivors))
            .collect()
    }

    #[test]
    fn layers_run_in_order_each_on_the_survivors_of_the_one_before() {
        let t = six_points();
        let (survivors, _) = run(&[&t], (0..6).collect(), Threads::Serial);
        // Serially the cascade computes one whole layer, in candidate
        // order, before the next: layer 2 for all six, layer 0 for the five
        // left, layer 1 for the four left.
        let expected: Vec<(u32, usize)> = [0, 1, 2, 3, 4, 5]
            .map(|p| (p, 2))
            .into_iter()
            .chain([0, 2, 3, 4, 5].map(|p| (p, 0)))
            .chain([0, 3, 4, 5].map(|p| (p, 1)))
            .collect();
        assert_eq!(t.computed(), expected);
        let points: Vec<u32> = survivors.iter().map(|s| s.point).collect();
        assert_eq!(points, [0, 4, 5]);
        let distances: Vec<f64> = survivors.iter().map(|s| s.distance).collect();
        assert_eq!(distances, [0.1 + 0.1 + 0.1, 0.5 + 0.5, 0.0]);
    }

    #[test]
    fn layer_statistics_count_each_layers_candidates_and_survivors() {
        let first = six_points();
        // A second stage, innermost first, that drops point 0 at its
        // second layer.
        let mut steps = vec![vec![0.0; 2]; 6];
        steps[0][1] = 3.0;
        let second = Table::new("second", steps, vec![0, 1], 2.0);
        let (survivors, stats) = run(&[&first, &second], (0..6).collect(), Threads::Serial);
        assert_eq!(
            counts(&stats),
            [
                ("table", 3, 1.5, 6, 5),
                ("table", 1, 0.5, 5, 4),
                ("table", 2, 1.0, 4, 3),
                ("second", 1, 0.5, 3, 3),
                ("second", 2, 1.0, 3, 2),
            ]
        );
        // Each layer starts from the survivors of the one before, across
        // stages too, and the last survivors are what the cascade returns.
        for pair in stats.windows(2) {
            assert_eq!(pair[1].candidates, pair[0].survivors, "{pair:?}");
        }
        assert_eq!(stats.last().unwrap().survivors, survivors.len());
        assert!(stats.iter().all(|s| s.ms >= 0.0 && s.ms.is_finite()));
        // The second stage saw only the first one's survivors, and its
        // distances are the ones returned.
        let seen: Vec<u32> = second.computed().iter().map(|&(p, _)| p).collect();
        assert_eq!(seen, [0, 4, 5, 0, 4, 5]);
        assert_eq!(
            survivors,
            [4, 5].map(|point| Survivor {
                point,
                distance: 0.0,
                anchors: 1,
            })
        );
    }

    #[test]
    fn without_stages_every_candidate_survives_at_distance_zero() {
        let (survivors, stats) = run(&[], vec![4, 2, 9], Threads::Parallel);
        assert!(stats.is_empty());
        assert_eq!(
            survivors,
            [4, 2, 9].map(|point| Survivor {
                point,
                distance: 0.0,
                anchors: 1,
            })
        );
    }

    #[test]
    fn an_observer_that_breaks_cancels_with_the_typed_error() {
        for backend in [Threads::Serial, Threads::Parallel] {
            let first = six_points();
            let second = Table::new("second", vec![vec![0.0; 2]; 6], vec![0, 1], 2.0);
            // Break at the second layer of the first stage, then at the
            // first layer of the second stage.
            for stop_at in [2, 4] {
                let mut seen = Vec::new();
                let mut observer = |s: &LayerStats| {
                    seen.push((s.descriptor, s.layer));
                    if seen.len() == stop_at {
                        ControlFlow::Break(())
                    } else {
                        ControlFlow::Continue(())
                    }
                };
                let computed_before = first.computed().len() + second.computed().len();
                let r = finished(run_cascade(
                    &[&first, &second],
                    (0..6).collect(),
                    1,
                    backend,
                    None,
                    &mut observer,
                ));
                assert!(matches!(r, Err(Error::Cancelled)), "{r:?}");
                assert_eq!(seen.len(), stop_at, "{backend:?}: {seen:?}");
                // Nothing is computed after the layer that broke.
                let computed = first.computed().len() + second.computed().len() - computed_before;
                let expected = if stop_at == 2 { 6 + 5 } else { 6 + 5 + 4 + 3 };
                assert_eq!(computed, expected, "{backend:?}, stop at {stop_at}");
            }
        }
    }

    /// A larger table, from a fixed pseudo-random sequence.
    fn random_table(points: usize, layers: usize, seed: u64) -> Table {
        let mut state = seed;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let steps = (0..points)
            .map(|_| (0..layers).map(|_| 0.3 * next()).collect())
            .collect();
        Table::new(
            "random",
            steps,
            (0..layers).rev().collect(),
            0.5 * layers as f64 * 0.3,
        )
    }

    #[test]
    fn serial_and_parallel_backends_give_the_same_result() {
        let runs = [Threads::Serial, Threads::Parallel].map(|backend| {
            let a = random_table(5000, 6, 0x9e37_79b9_7f4a_7c15);
            let b = random_table(5000, 4, 0x2545_f491_4f6c_dd1d);
            let (survivors, stats) = run(&[&a, &b], (0..5000).rev().collect(), backend);
            let mut computed = a.computed();
            computed.extend(b.computed());
            computed.sort_unstable();
            (survivors, counts(&stats), computed)
        });
        let [serial, parallel] = &runs;
        assert!(
            !serial.0.is_empty() && serial.0.len() < 5000,
            "{}",
            serial.0.len()
        );
        assert_eq!(serial, parallel);
    }

    #[test]
    fn chunks_give_the_survivors_and_counts_of_one_run() {
        let whole = {
            let a = random_table(3000, 6, 0x1234_5678_9abc_def1);
            let b = Table {
                name: "other",
                ..random_table(3000, 4, 0x0fed_cba9_8765_4321)
            };
            let (survivors, stats) = run(&[&a, &b], (0..3000).rev().collect(), Threads::Serial);
            (survivors, counts(&stats))
        };
        // Chunks that divide the candidates unevenly, rounds of several, a
        // chunk of one, and a chunk larger than them all.
        for chunk in [1, 7, 64, 5000] {
            for backend in [Threads::Serial, Threads::Parallel] {
                let a = random_table(3000, 6, 0x1234_5678_9abc_def1);
                let b = Table {
                    name: "other",
                    ..random_table(3000, 4, 0x0fed_cba9_8765_4321)
                };
                let mut layers_seen = 0;
                let mut observer = |_: &LayerStats| {
                    layers_seen += 1;
                    ControlFlow::Continue(())
                };
                let (survivors, stats) = run_cascade_in_chunks(
                    &[&a, &b],
                    (0..3000).rev().collect(),
                    chunk,
                    1,
                    backend,
                    &mut observer,
                )
                .unwrap();
                assert!(
                    (&survivors, counts(&stats)) == (&whole.0, whole.1.clone()),
                    "chunk {chunk}"
                );
                let rounds = 3000usize.div_ceil(chunk * ROUND_CHUNKS);
                assert_eq!(layers_seen, rounds * 10, "chunk {chunk}");
                assert!(stats.iter().all(|s| s.ms >= 0.0 && s.ms.is_finite()));
            }
        }
        // No candidate: every layer reported empty, as by one run.
        let t = six_points();
        let (survivors, stats) =
            run_cascade_in_chunks(&[&t], Vec::new(), 8, 1, Threads::Parallel, &mut ()).unwrap();
        assert!(survivors.is_empty());
        assert_eq!(
            counts(&stats),
            [
                ("table", 3, 1.5, 0, 0),
                ("table", 1, 0.5, 0, 0),
                ("table", 2, 1.0, 0, 0)
            ]
        );
    }

    #[test]
    fn an_observer_that_breaks_stops_the_chunks_with_the_typed_error() {
        let t = random_table(4000, 3, 7);
        let mut seen = 0;
        let mut observer = |_: &LayerStats| {
            seen += 1;
            ControlFlow::Break(())
        };
        let r = run_cascade_in_chunks(
            &[&t],
            (0..4000).collect(),
            16,
            1,
            Threads::Parallel,
            &mut observer,
        );
        assert!(matches!(r, Err(Error::Cancelled)), "{r:?}");
        assert_eq!(seen, 1);
        // Only the first round of chunks was computed.
        let points: std::collections::BTreeSet<u32> =
            t.computed().iter().map(|&(p, _)| p).collect();
        assert_eq!(points.len(), 16 * ROUND_CHUNKS);
    }
}
