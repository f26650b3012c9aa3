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

use super::{Gpu, GpuSolid, Slot};
use crate::descriptor::{LayerBatch, LocalFuture, WaveQueue};
use crate::voxel::Solid;

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
    /// [`WaveQueue::submit_waiting`] has submitted it.
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
}

impl WaveQueue for KernelQueue<'_> {
    fn batch<'a>(&'a self, solid: &'a Solid) -> Box<dyn LayerBatch + 'a> {
        Box::new(GpuSolid::queued(self, solid))
    }

    fn submit_waiting(&self) -> LocalFuture<'_, bool> {
        Box::pin(async move {
            let queued = std::mem::take(&mut *self.waiting.borrow_mut());
            if queued.is_empty() {
                return false;
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
            true
        })
    }

    fn discard_waiting(&self) {
        self.waiting.borrow_mut().clear();
    }
}
