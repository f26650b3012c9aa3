//! Kernels of several searches submitted together.
//!
//! A search over many parts ran each part's cascade in turn, one
//! submission and one wait per layer and part: on a real GPU a submission
//! costs 0.1-0.25 ms however small its kernel, and a scene of 13 parts made
//! 156 of them. A [`KernelQueue`] runs the parts' cascades side by side on
//! one thread instead: each kernel a part asks for waits in the queue
//! until every part is waiting, then all of them go in one submission, so a
//! layer costs one wait for all parts. Each kernel still computes exactly
//! what it computed alone.

use std::cell::RefCell;
use std::future::poll_fn;
use std::task::Poll;

use super::{Gpu, Slot};
use crate::descriptor::LocalFuture;

/// One kernel run with its buffers and bindings made, not yet encoded.
pub(super) struct Prepared {
    pub pipeline: wgpu::ComputePipeline,
    pub group: wgpu::BindGroup,
    pub workgroups: [u32; 2],
    pub output: wgpu::Buffer,
    pub readback: wgpu::Buffer,
}

/// What a kernel's waiter receives: its output's bytes, or why the
/// submission failed.
type Delivery = Box<dyn FnOnce(Result<Vec<u8>, String>)>;

/// Kernels waiting for the next submission, and the searches that wait on
/// them (see the module's doc).
pub struct KernelQueue<'g> {
    gpu: &'g Gpu,
    /// Used on the search's thread only, like every GPU handle.
    waiting: RefCell<Vec<(Prepared, Delivery)>>,
}

impl<'g> KernelQueue<'g> {
    /// An empty queue on `gpu`.
    pub fn new(gpu: &'g Gpu) -> KernelQueue<'g> {
        KernelQueue {
            gpu,
            waiting: RefCell::default(),
        }
    }

    /// The GPU the queue submits to.
    pub fn gpu(&self) -> &'g Gpu {
        self.gpu
    }

    /// Queues `kernel` now; the future returns its output once
    /// [`KernelQueue::run_together`] has submitted it.
    pub(super) fn enqueue(
        &self,
        kernel: Prepared,
    ) -> impl Future<Output = Result<Vec<u8>, String>> + use<> {
        let slot = Slot::new();
        self.waiting
            .borrow_mut()
            .push((kernel, Box::new(slot.setter())));
        slot
    }

    /// Runs `tasks` side by side and returns their outputs in order: each
    /// is polled until it waits, and whenever all wait, the kernels they
    /// queued go in one submission. Stops at the first task that fails
    /// (the others are dropped).
    pub async fn run_together<'a, T, E>(
        &self,
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
                // Kernels queued by the dropped tasks are never submitted.
                self.waiting.borrow_mut().clear();
                return Err(e);
            }
            if live.iter().all(Option::is_none) {
                return Ok(outputs.into_iter().flatten().collect());
            }
            let queued = std::mem::take(&mut *self.waiting.borrow_mut());
            if queued.is_empty() {
                // They wait on something else: the caller's event loop
                // wakes them.
                let mut yielded = false;
                poll_fn(|_| match std::mem::replace(&mut yielded, true) {
                    false => Poll::Pending,
                    true => Poll::Ready(()),
                })
                .await;
                continue;
            }
            let (kernels, deliveries): (Vec<Prepared>, Vec<Delivery>) = queued.into_iter().unzip();
            match self.gpu.submit(&kernels).await {
                Ok(bytes) => {
                    for (deliver, bytes) in deliveries.into_iter().zip(bytes) {
                        deliver(Ok(bytes));
                    }
                }
                Err(reason) => {
                    for deliver in deliveries {
                        deliver(Err(reason.clone()));
                    }
                }
            }
        }
    }
}
