//! A device that computes layers in batches (a GPU), as the search sees
//! it: a [`LayerBatch`] per grid, and a [`WaveQueue`] that holds the
//! kernels of a wave of grids until all of them wait, then submits them
//! together. The search names no device; the entry points hand one in.

use std::future::poll_fn;
use std::task::Poll;

use super::{LayerBatch, LocalFuture};
use crate::voxel::Solid;

/// Where the volume and harmonics layers run besides the CPU.
pub trait LayerDevice {
    /// The device, as the report names it.
    fn description(&self) -> String;

    /// How many grids a wave holds: their kernels go in one submission
    /// per layer.
    fn wave_grids(&self) -> usize;

    /// The layers of `solid`, searched alone: each kernel is submitted as
    /// it is asked for.
    fn batch<'a>(&'a self, solid: &'a Solid) -> Box<dyn LayerBatch + 'a>;

    /// An empty queue for a wave of grids.
    fn wave(&self) -> Box<dyn WaveQueue + '_>;
}

/// Kernels of several grids waiting for one submission.
pub trait WaveQueue {
    /// The layers of `solid`, its kernels held in this queue.
    fn batch<'a>(&'a self, solid: &'a Solid) -> Box<dyn LayerBatch + 'a>;

    /// Submits the kernels waiting, together, and hands each its output
    /// (or why the submission failed); `false` when none waited.
    fn submit_waiting(&self) -> LocalFuture<'_, bool>;

    /// Drops the kernels waiting, unsubmitted.
    fn discard_waiting(&self);
}

/// Runs `tasks` side by side and returns their outputs in order: each is
/// polled until it waits, and whenever all wait, the kernels they queued
/// in `queue` go in one submission. Stops at the first task that fails
/// (the others are dropped, and what they queued with them).
pub async fn run_together<'a, T, E>(
    queue: &dyn WaveQueue,
    tasks: Vec<LocalFuture<'a, Result<T, E>>>,
) -> Result<Vec<T>, E> {
    let mut live: Vec<Option<LocalFuture<'a, Result<T, E>>>> =
        tasks.into_iter().map(Some).collect();
    let mut outputs: Vec<Option<T>> = live.iter().map(|_| None).collect();
    loop {
        // Every live task once: each runs until it waits or ends.
        let failed = poll_fn(|cx| {
            for (task, output) in live.iter_mut().zip(outputs.iter_mut()) {
                let Some(future) = task else { continue };
                if let Poll::Ready(result) = future.as_mut().poll(cx) {
                    *task = None;
                    match result {
                        Ok(value) => *output = Some(value),
                        Err(e) => return Poll::Ready(Some(e)),
                    }
                }
            }
            Poll::Ready(None)
        })
        .await;
        if let Some(e) = failed {
            queue.discard_waiting();
            return Err(e);
        }
        if live.iter().all(Option::is_none) {
            return Ok(outputs.into_iter().flatten().collect());
        }
        if !queue.submit_waiting().await {
            // They wait on something else: the caller's event loop wakes
            // them.
            let mut yielded = false;
            poll_fn(|_| match std::mem::replace(&mut yielded, true) {
                false => Poll::Pending,
                true => Poll::Ready(()),
            })
            .await;
        }
    }
}
