//! The volume kernel's host side: ball counts dispatched in chunks and
//! read back.

use super::solid::{Cells, GpuSolid};
use super::{Dispatch, storage};
use crate::voxel::Ball;

/// The kernel's WGSL source.
pub(super) const SHADER: &str = include_str!("volume.wgsl");

/// Candidates per dispatch (one invocation each).
const CHUNK: usize = 1 << 20;

/// Invocations per workgroup, and workgroups along x.
const WORKGROUP: u32 = 64;
const GROUPS_X: u32 = 65535;

/// Matches the kernel's `Params`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    dims: [u32; 4],
    row_stride: u32,
    level: u32,
    count: u32,
    threads_x: u32,
}

impl GpuSolid<'_> {
    /// The solid voxels in `ball` around each of `voxels`.
    pub(super) async fn counts(
        &self,
        ball: &Ball,
        voxels: &[[u16; 3]],
    ) -> Result<Vec<u64>, String> {
        // Counts are u32 on the device.
        if ball.covered([0; 3]) >= u64::from(u32::MAX) {
            return Err(format!(
                "a ball of {:.0} voxels is too large for the GPU's 32-bit counts",
                ball.radius()
            ));
        }
        let gpu = self.gpu;
        let level = ball.level();
        let cells = self.cells(match level {
            0 => Cells::Bits,
            l => Cells::RunningSums(l),
        })?;
        let (runs, starts) = ball.run_tables();
        let runs = storage(&gpu.device, "runs", bytemuck::cast_slice(&runs));
        let starts = storage(&gpu.device, "phase starts", bytemuck::cast_slice(&starts));
        let d = cells.dims;
        let mut out = Vec::with_capacity(voxels.len());
        for chunk in voxels.chunks(CHUNK) {
            let count = chunk.len() as u32;
            let groups = count.div_ceil(WORKGROUP);
            let params = Params {
                dims: [d[0] as u32, d[1] as u32, d[2] as u32, 0],
                row_stride: cells.row_stride as u32,
                level,
                count,
                threads_x: GROUPS_X * WORKGROUP,
            };
            let at: Vec<[i32; 4]> = chunk
                .iter()
                .map(|v| [v[0].into(), v[1].into(), v[2].into(), 0])
                .collect();
            let at = storage(&gpu.device, "voxels", bytemuck::cast_slice(&at));
            let bytes = gpu
                .run_kernel(Dispatch {
                    pipeline: &gpu.balls,
                    params: bytemuck::bytes_of(&params),
                    inputs: &[&cells.buffer, &at, &runs, &starts],
                    output_bytes: u64::from(count) * 4,
                    workgroups: [groups.min(GROUPS_X), groups.div_ceil(GROUPS_X)],
                })
                .await?;
            let counts: &[u32] = bytemuck::cast_slice(&bytes);
            out.extend(counts.iter().map(|&n| u64::from(n)));
        }
        Ok(out)
    }
}
