//! The harmonics kernel's host side: spheres dispatched in chunks,
//! signatures read back.

use super::solid::{Cells, GpuSolid};
use super::{Dispatch, Gpu, kept_tables, storage};
use crate::descriptor::LocalFuture;
use crate::descriptor::harmonics::{DEGREES, Signature, SphereSampler};

/// The kernel's WGSL source.
pub(super) const SHADER: &str = include_str!("harmonics.wgsl");

/// Candidates per dispatch: a dispatch stays far below the seconds after
/// which a desktop's watchdog kills it, and its buffers stay small.
const CHUNK: usize = 16384;

/// Workgroups along x (the kernel reads the candidate as y * this + x).
const GROUPS_X: u32 = 65535;

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

/// A sphere's sample tables on the device ([`SphereSampler::sample_tables`]).
/// They depend on its radius and level alone, so every part of a search,
/// and every search on the device, reads the same ones: kept, not built and
/// uploaded per part and layer.
#[derive(Clone)]
pub(super) struct SampleTables {
    /// The sphere's radius (as bits) and level.
    pub sphere: (u64, u32),
    offsets: wgpu::Buffer,
    fractions: wgpu::Buffer,
}

impl SampleTables {
    fn bytes(&self) -> u64 {
        self.offsets.size() + self.fractions.size()
    }
}

/// Bytes of sample tables kept on the device: a search reads a few
/// spheres (a layer each), 128 KiB a sphere.
const TABLES_KEPT: u64 = 4 << 20;

impl Gpu {
    /// `sampler`'s tables on the device, uploaded unless kept from an
    /// earlier part or search.
    pub(super) fn sample_tables(&self, sampler: &SphereSampler) -> SampleTables {
        let key = (sampler.radius().to_bits(), sampler.level());
        kept_tables(
            &self.sample_tables,
            |t| t.sphere == key,
            || {
                let (offsets, fractions) = sampler.sample_tables();
                SampleTables {
                    sphere: key,
                    offsets: storage(&self.device, "offsets", bytemuck::cast_slice(&offsets)),
                    fractions: storage(&self.device, "fractions", bytemuck::cast_slice(&fractions)),
                }
            },
            SampleTables::bytes,
            TABLES_KEPT,
        )
    }
}

impl GpuSolid<'_> {
    /// Starts one chunk of candidates: the future returns its kernel's
    /// output.
    fn start_chunk(
        &self,
        sampler: &SphereSampler,
        tables: &SampleTables,
        voxels: &[[u16; 3]],
    ) -> Result<LocalFuture<'_, Result<Vec<u8>, String>>, String> {
        let gpu = self.gpu;
        let level = sampler.level();
        let cells = self.cells(match level {
            0 => Cells::Bits,
            l => Cells::Occupancy(l),
        })?;
        let origins: Vec<[i32; 4]> = voxels
            .iter()
            .map(|&v| {
                let o = sampler.origin(v);
                [o[0], o[1], o[2], 0]
            })
            .collect();
        let count = voxels.len() as u32;
        let d = cells.dims;
        let params = Params {
            dims: [d[0] as u32, d[1] as u32, d[2] as u32, 0],
            row_words: cells.row_stride as u32,
            level,
            count,
            groups_x: GROUPS_X,
        };
        let origins = storage(&gpu.device, "origins", bytemuck::cast_slice(&origins));
        Ok(gpu.start_kernel(
            Dispatch {
                pipeline: &gpu.spheres,
                params: bytemuck::bytes_of(&params),
                inputs: &[
                    &cells.buffer,
                    &origins,
                    &tables.offsets,
                    &tables.fractions,
                    &gpu.fourier,
                    &gpu.legendre,
                ],
                output_bytes: (voxels.len() * DEGREES * 4) as u64,
                workgroups: [count.min(GROUPS_X), count.div_ceil(GROUPS_X)],
            },
            self.queue,
        ))
    }

    /// The signatures of the sphere `sampler` around each of `voxels`.
    /// Every chunk is started before the first is awaited, so that a
    /// queue submits them together.
    pub(super) async fn signatures(
        &self,
        sampler: &SphereSampler,
        voxels: &[[u16; 3]],
    ) -> Result<Vec<Signature>, String> {
        let tables = self.gpu.sample_tables(sampler);
        let started = voxels
            .chunks(CHUNK)
            .map(|chunk| self.start_chunk(sampler, &tables, chunk))
            .collect::<Result<Vec<_>, String>>()?;
        let mut out = Vec::with_capacity(voxels.len());
        for chunk in started {
            let bytes = chunk.await?;
            let values: &[f32] = bytemuck::cast_slice(&bytes);
            out.extend(
                values
                    .chunks_exact(DEGREES)
                    .map(|s| -> Signature { std::array::from_fn(|l| s[l]) }),
            );
        }
        Ok(out)
    }
}
