//! One solid on the device: what its kernels read, uploaded on first use
//! and kept while the solid is searched.

use std::borrow::Cow;
use std::cell::RefCell;
use std::collections::HashMap;
use std::rc::Rc;

use super::{Gpu, KernelQueue, storage};
use crate::descriptor::harmonics::{Signature, SphereSampler};
use crate::descriptor::{LayerBatch, LocalFuture};
use crate::exec::Threads;
use crate::voxel::{Ball, Solid};

/// What a kernel reads of a solid.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) enum Cells {
    /// The bit grid's u64 words.
    Bits,
    /// A pyramid level's occupancy bytes, packed four to a u32.
    Occupancy(u32),
    /// A pyramid level's running sums along x.
    RunningSums(u32),
}

/// Cells on the device, with the dimensions and row stride (in u32
/// entries) they are read with.
#[derive(Clone)]
pub(super) struct Uploaded {
    pub buffer: Rc<wgpu::Buffer>,
    pub dims: [usize; 3],
    pub row_stride: usize,
}

/// A solid's cells on a GPU, for the volume and harmonics kernels.
pub struct GpuSolid<'a> {
    pub(super) gpu: &'a Gpu,
    /// Where its kernels wait to be submitted beside other solids', if
    /// anywhere.
    pub(super) queue: Option<&'a KernelQueue<'a>>,
    solid: &'a Solid,
    /// Used on the search's thread only (GPU handles are not `Send` in
    /// the threaded WebAssembly build).
    uploaded: RefCell<HashMap<Cells, Uploaded>>,
}

impl<'a> GpuSolid<'a> {
    /// `solid` on `gpu`: nothing is uploaded until a kernel needs it.
    pub fn new(gpu: &'a Gpu, solid: &'a Solid) -> GpuSolid<'a> {
        GpuSolid {
            gpu,
            queue: None,
            solid,
            uploaded: RefCell::default(),
        }
    }

    /// `solid` on `queue`'s GPU, its kernels submitted with the others
    /// `queue` holds.
    pub fn queued(queue: &'a KernelQueue<'a>, solid: &'a Solid) -> GpuSolid<'a> {
        GpuSolid {
            queue: Some(queue),
            ..GpuSolid::new(queue.gpu(), solid)
        }
    }

    /// `cells` on the device, uploaded the first time.
    pub(super) fn cells(&self, cells: Cells) -> Result<Uploaded, String> {
        if let Some(u) = self.uploaded.borrow().get(&cells) {
            return Ok(u.clone());
        }
        let grid = self.solid.bits();
        let level = |l| self.solid.level(l, Threads::Serial);
        // Borrowed where the layout already fits: the driver copies them
        // anyway, and a copy of our own held a large level twice.
        let (bytes, dims, row_stride): (Cow<[u8]>, _, _) = match cells {
            Cells::Bits => (
                Cow::Borrowed(bytemuck::cast_slice(grid.words())),
                grid.dims(),
                2 * grid.words_per_row(),
            ),
            Cells::Occupancy(l) => {
                let occupancy = level(l).occupancy();
                let bytes = match occupancy.len() % 4 {
                    0 => Cow::Borrowed(occupancy),
                    _ => {
                        let mut padded = occupancy.to_vec();
                        padded.resize(occupancy.len().next_multiple_of(4), 0);
                        Cow::Owned(padded)
                    }
                };
                (bytes, level(l).dims(), level(l).dims()[0])
            }
            Cells::RunningSums(l) => (
                Cow::Borrowed(bytemuck::cast_slice(level(l).prefix())),
                level(l).dims(),
                level(l).stride(),
            ),
        };
        let limit = self.gpu.limits().max_storage_buffer_binding_size;
        if bytes.len() as u64 > limit {
            return Err(format!(
                "a grid of {} MiB passes the GPU's {} MiB binding limit",
                bytes.len() >> 20,
                limit >> 20
            ));
        }
        let u = Uploaded {
            buffer: Rc::new(storage(&self.gpu.device, "cells", &bytes)),
            dims,
            row_stride,
        };
        self.uploaded.borrow_mut().insert(cells, u.clone());
        Ok(u)
    }
}

impl LayerBatch for GpuSolid<'_> {
    fn ball_counts<'a>(
        &'a self,
        ball: &'a Ball,
        voxels: &'a [[u16; 3]],
    ) -> LocalFuture<'a, Result<Vec<u64>, String>> {
        Box::pin(self.counts(ball, voxels))
    }

    fn sphere_signatures<'a>(
        &'a self,
        sampler: &'a SphereSampler,
        voxels: &'a [[u16; 3]],
    ) -> LocalFuture<'a, Result<Vec<Signature>, String>> {
        Box::pin(self.signatures(sampler, voxels))
    }

    fn max_sphere_error(&self) -> f32 {
        super::MAX_ERROR
    }
}
