//! The harmonics kernel's host side: one solid's cells uploaded once per
//! level read, spheres dispatched in chunks, signatures read back.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use super::{Gpu, storage};
use crate::descriptor::harmonics::{DEGREES, Signature, SphereBatch, SphereSampler};
use crate::exec::Backend;
use crate::voxel::Solid;

/// The kernel's WGSL source.
pub(super) const SHADER: &str = include_str!("harmonics.wgsl");

/// Candidates per dispatch: a dispatch stays far below the seconds after
/// which a desktop's watchdog kills it, and its buffers stay small.
const CHUNK: usize = 16384;

/// Workgroups along x (the kernel reads the candidate as y * this + x).
const GROUPS_X: u32 = 65535;

/// The per-degree error bound the stage's guard band assumes: about 40
/// times the largest difference measured against the CPU (2.6e-7), and
/// checked by the tests.
const MAX_ERROR: f32 = 1e-5;

/// Matches the kernel's `Params`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    dims: [u32; 4],
    row_words: u32,
    level: u32,
    count: u32,
    groups_x: u32,
}

/// One solid's spheres on a GPU: the cells of each level read, uploaded on
/// first use.
pub struct GpuSpheres<'a> {
    gpu: &'a Gpu,
    solid: &'a Solid,
    /// Level -> its cells.
    cells: Mutex<HashMap<u32, Arc<wgpu::Buffer>>>,
}

impl<'a> GpuSpheres<'a> {
    /// Spheres on `solid`, computed by `gpu`.
    pub fn new(gpu: &'a Gpu, solid: &'a Solid) -> GpuSpheres<'a> {
        GpuSpheres {
            gpu,
            solid,
            cells: Mutex::default(),
        }
    }

    /// The cells a sampler of `level` reads, with their dimensions and row
    /// stride in u32 words.
    fn cells(&self, level: u32) -> Result<(Arc<wgpu::Buffer>, [usize; 3], usize), String> {
        let grid = self.solid.bits();
        let (dims, row_words) = if level == 0 {
            (grid.dims(), 2 * grid.words_per_row())
        } else {
            (self.solid.level(level, Backend::Serial).dims(), 0)
        };
        let mut cached = self.cells.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(buffer) = cached.get(&level) {
            return Ok((buffer.clone(), dims, row_words));
        }
        let bytes: Vec<u8> = if level == 0 {
            bytemuck::cast_slice(grid.words()).to_vec()
        } else {
            let mut bytes = self
                .solid
                .level(level, Backend::Serial)
                .occupancy()
                .to_vec();
            bytes.resize(bytes.len().next_multiple_of(4), 0);
            bytes
        };
        let limit = self.gpu.limits().max_storage_buffer_binding_size;
        if bytes.len() as u64 > limit {
            return Err(format!(
                "a grid of {} MiB passes the GPU's {} MiB binding limit",
                bytes.len() >> 20,
                limit >> 20
            ));
        }
        let buffer = Arc::new(storage(&self.gpu.device, "cells", &bytes));
        cached.insert(level, buffer.clone());
        Ok((buffer, dims, row_words))
    }

    fn chunk(
        &self,
        sampler: &SphereSampler,
        tables: &(wgpu::Buffer, wgpu::Buffer),
        voxels: &[[u16; 3]],
    ) -> Result<Vec<Signature>, String> {
        let gpu = self.gpu;
        let device = &gpu.device;
        let (cells, dims, row_words) = self.cells(sampler.level())?;
        let origins: Vec<[i32; 4]> = voxels
            .iter()
            .map(|&v| {
                let o = sampler.origin(v);
                [o[0], o[1], o[2], 0]
            })
            .collect();
        let count = voxels.len() as u32;
        let params = Params {
            dims: [dims[0] as u32, dims[1] as u32, dims[2] as u32, 0],
            row_words: row_words as u32,
            level: sampler.level(),
            count,
            groups_x: GROUPS_X,
        };
        let uniform = {
            use wgpu::util::DeviceExt;
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("params"),
                contents: bytemuck::bytes_of(&params),
                usage: wgpu::BufferUsages::UNIFORM,
            })
        };
        let origins = storage(device, "origins", bytemuck::cast_slice(&origins));
        let size = (voxels.len() * DEGREES * 4) as u64;
        let output = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("signatures"),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("signatures read back"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let layout = gpu.spheres.get_bind_group_layout(0);
        let entries = [
            uniform.as_entire_binding(),
            cells.as_entire_binding(),
            origins.as_entire_binding(),
            tables.0.as_entire_binding(),
            tables.1.as_entire_binding(),
            gpu.fourier.as_entire_binding(),
            output.as_entire_binding(),
            gpu.legendre.as_entire_binding(),
        ];
        let entries: Vec<wgpu::BindGroupEntry> = entries
            .into_iter()
            .enumerate()
            .map(|(i, resource)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource,
            })
            .collect();
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("harmonics"),
            layout: &layout,
            entries: &entries,
        });
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&gpu.spheres);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups(count.min(GROUPS_X), count.div_ceil(GROUPS_X), 1);
        }
        encoder.copy_buffer_to_buffer(&output, 0, &readback, 0, size);
        gpu.queue.submit([encoder.finish()]);
        let mapped: Arc<Mutex<Option<Result<(), wgpu::BufferAsyncError>>>> = Arc::default();
        let slot = mapped.clone();
        readback.map_async(wgpu::MapMode::Read, .., move |r| {
            *slot.lock().unwrap_or_else(|p| p.into_inner()) = Some(r);
        });
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| e.to_string())?;
        gpu.check("computing spheres on the GPU")
            .map_err(|e| e.to_string())?;
        match mapped.lock().unwrap_or_else(|p| p.into_inner()).take() {
            Some(Ok(())) => {}
            Some(Err(e)) => return Err(format!("reading the signatures back: {e}")),
            None => return Err("the GPU never finished the signatures".into()),
        }
        let view = readback.get_mapped_range(..).map_err(|e| e.to_string())?;
        let values: &[f32] = bytemuck::cast_slice(&view);
        Ok(values
            .chunks_exact(DEGREES)
            .map(|s| std::array::from_fn(|l| s[l]))
            .collect())
    }
}

impl SphereBatch for GpuSpheres<'_> {
    fn signatures(
        &self,
        sampler: &SphereSampler,
        voxels: &[[u16; 3]],
    ) -> Result<Vec<Signature>, String> {
        let (offsets, fractions) = sampler.sample_tables();
        let tables = (
            storage(&self.gpu.device, "offsets", bytemuck::cast_slice(&offsets)),
            storage(
                &self.gpu.device,
                "fractions",
                bytemuck::cast_slice(&fractions),
            ),
        );
        let mut out = Vec::with_capacity(voxels.len());
        for chunk in voxels.chunks(CHUNK) {
            out.extend(self.chunk(sampler, &tables, chunk)?);
        }
        Ok(out)
    }

    fn max_error(&self) -> f32 {
        MAX_ERROR
    }
}
