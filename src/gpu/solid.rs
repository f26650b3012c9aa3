//! One solid on the device: what its kernels read, uploaded on first use
//! and kept while the solid is searched.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use super::{Gpu, storage};
use crate::exec::Backend;
use crate::voxel::Solid;

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
    pub buffer: Arc<wgpu::Buffer>,
    pub dims: [usize; 3],
    pub row_stride: usize,
}

/// A solid's cells on a GPU, for the volume and harmonics kernels.
pub struct GpuSolid<'a> {
    pub(super) gpu: &'a Gpu,
    solid: &'a Solid,
    uploaded: Mutex<HashMap<Cells, Uploaded>>,
}

impl<'a> GpuSolid<'a> {
    /// `solid` on `gpu`: nothing is uploaded until a kernel needs it.
    pub fn new(gpu: &'a Gpu, solid: &'a Solid) -> GpuSolid<'a> {
        GpuSolid {
            gpu,
            solid,
            uploaded: Mutex::default(),
        }
    }

    /// `cells` on the device, uploaded the first time.
    pub(super) fn cells(&self, cells: Cells) -> Result<Uploaded, String> {
        let mut uploaded = self.uploaded.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(u) = uploaded.get(&cells) {
            return Ok(u.clone());
        }
        let grid = self.solid.bits();
        let level = |l| self.solid.level(l, Backend::Serial);
        let (bytes, dims, row_stride): (Vec<u8>, _, _) = match cells {
            Cells::Bits => (
                bytemuck::cast_slice(grid.words()).to_vec(),
                grid.dims(),
                2 * grid.words_per_row(),
            ),
            Cells::Occupancy(l) => {
                let mut bytes = level(l).occupancy().to_vec();
                bytes.resize(bytes.len().next_multiple_of(4), 0);
                (bytes, level(l).dims(), level(l).dims()[0])
            }
            Cells::RunningSums(l) => (
                bytemuck::cast_slice(level(l).prefix()).to_vec(),
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
            buffer: Arc::new(storage(&self.gpu.device, "cells", &bytes)),
            dims,
            row_stride,
        };
        uploaded.insert(cells, u.clone());
        Ok(u)
    }
}
