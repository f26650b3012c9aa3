//! The volume kernel's host side: ball counts dispatched in chunks and
//! read back, with as many lanes per candidate as keep the GPU busy.

use super::solid::{Cells, GpuSolid};
use super::{Dispatch, Gpu, kept_tables, storage};
use crate::voxel::Ball;

/// The kernel's WGSL source.
pub(super) const SHADER: &str = include_str!("volume.wgsl");

/// Candidates per dispatch (one invocation each).
const CHUNK: usize = 1 << 20;

/// Invocations per workgroup, and workgroups along x.
const WORKGROUP: u32 = 64;
const GROUPS_X: u32 = 65535;

/// Invocations a dispatch may reach by giving candidates more lanes: about
/// what a large GPU runs at once (an H100: 132 multiprocessors of 2 048).
/// Measured on one: a late volume layer of a few hundred candidates took
/// 0.5 ms per dispatch with one lane each, every lane walking hundreds of
/// runs while the chip stood nearly idle.
const FILL: usize = 1 << 18;

/// Lanes per candidate (a power of two up to the workgroup): more while
/// the dispatch stays within [`FILL`] and each lane keeps two runs or more.
fn lanes_for(candidates: usize, runs_per_ball: usize) -> u32 {
    let mut lanes = 1;
    while lanes < WORKGROUP
        && candidates * 2 * lanes as usize <= FILL
        && 2 * 2 * lanes as usize <= runs_per_ball
    {
        lanes *= 2;
    }
    lanes
}

/// Bytes of run tables kept on the device between layers: a search's
/// balls (one per layer) several times over.
const TABLES_KEPT: u64 = 64 << 20;

/// A ball's run tables on the device. They depend on the ball alone
/// (radius and level), not on the solid, so every part of a search reads
/// the same ones; built and uploaded per part and layer, they cost more
/// than the dispatch on a real GPU (273 840 runs, 6 ms, for a level-4 ball
/// of zoo-bunny's), so they are kept.
#[derive(Clone)]
pub(super) struct BallTables {
    /// The ball's radius (as bits) and level.
    pub ball: (u64, u32),
    runs: wgpu::Buffer,
    starts: wgpu::Buffer,
    runs_per_ball: usize,
}

impl BallTables {
    fn bytes(&self) -> u64 {
        self.runs.size() + self.starts.size()
    }
}

impl Gpu {
    /// `ball`'s run tables on the device, uploaded unless kept from an
    /// earlier part or search.
    pub(super) fn ball_tables(&self, ball: &Ball) -> BallTables {
        let key = (ball.radius().to_bits(), ball.level());
        kept_tables(
            &self.ball_tables,
            |t| t.ball == key,
            || {
                let (runs, starts) = ball.run_tables();
                BallTables {
                    ball: key,
                    runs_per_ball: runs.len() / (starts.len() - 1).max(1),
                    runs: storage(&self.device, "runs", bytemuck::cast_slice(&runs)),
                    starts: storage(&self.device, "phase starts", bytemuck::cast_slice(&starts)),
                }
            },
            BallTables::bytes,
            TABLES_KEPT,
        )
    }
}

/// Matches the kernel's `Params`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    dims: [u32; 4],
    row_stride: u32,
    level: u32,
    count: u32,
    groups_x: u32,
    lanes: u32,
    pad: [u32; 3],
}

impl GpuSolid<'_> {
    /// The solid voxels in `ball` around each of `voxels`.
    pub(super) async fn counts(
        &self,
        ball: &Ball,
        voxels: &[[u16; 3]],
    ) -> Result<Vec<u64>, String> {
        self.counts_with(ball, voxels, None).await
    }

    /// [`GpuSolid::counts`] with `lanes` per candidate, or the default
    /// for each chunk's size.
    pub(super) async fn counts_with(
        &self,
        ball: &Ball,
        voxels: &[[u16; 3]],
        lanes: Option<u32>,
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
        let tables = gpu.ball_tables(ball);
        let d = cells.dims;
        // Every chunk is started before the first is awaited, so that a
        // queue submits them together.
        let mut started = Vec::new();
        for chunk in voxels.chunks(CHUNK) {
            let count = chunk.len() as u32;
            // A software adapter runs a few invocations at a time on the
            // CPU's cores: more lanes would only add barriers there.
            let lanes = lanes.unwrap_or_else(|| match gpu.is_software() {
                true => 1,
                false => lanes_for(chunk.len(), tables.runs_per_ball),
            });
            let groups = count.div_ceil(WORKGROUP / lanes);
            let params = Params {
                dims: [d[0] as u32, d[1] as u32, d[2] as u32, 0],
                row_stride: cells.row_stride as u32,
                level,
                count,
                groups_x: GROUPS_X,
                lanes,
                pad: [0; 3],
            };
            let at: Vec<[i32; 4]> = chunk
                .iter()
                .map(|v| [v[0].into(), v[1].into(), v[2].into(), 0])
                .collect();
            let at = storage(&gpu.device, "voxels", bytemuck::cast_slice(&at));
            started.push(gpu.start_kernel(
                Dispatch {
                    pipeline: &gpu.balls,
                    params: bytemuck::bytes_of(&params),
                    inputs: &[&cells.buffer, &at, &tables.runs, &tables.starts],
                    output_bytes: u64::from(count) * 4,
                    workgroups: [groups.min(GROUPS_X), groups.div_ceil(GROUPS_X)],
                },
                self.queue,
            ));
        }
        let mut out = Vec::with_capacity(voxels.len());
        for chunk in started {
            let bytes = chunk.await?;
            let counts: &[u32] = bytemuck::cast_slice(&bytes);
            out.extend(counts.iter().map(|&n| u64::from(n)));
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn few_candidates_get_more_lanes_and_short_balls_fewer() {
        // Many candidates fill the GPU one lane each.
        assert_eq!(lanes_for(1 << 20, 500), 1);
        assert_eq!(lanes_for(FILL, 500), 1);
        // A late layer's few hundred share the runs a whole workgroup wide.
        assert_eq!(lanes_for(300, 500), 64);
        // In between, as many as keep the dispatch within FILL.
        assert_eq!(lanes_for(FILL / 8, 500), 8);
        assert_eq!(lanes_for(FILL / 8 + 1, 500), 4);
        // No lane is left with fewer than two runs.
        assert_eq!(lanes_for(10, 9), 4);
        assert_eq!(lanes_for(10, 7), 2);
        assert_eq!(lanes_for(10, 3), 1);
    }
}
