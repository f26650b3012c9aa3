//! What voxelizing and the digital balls will need, estimated before
//! anything is built, so that the memory budget and the work limit can
//! refuse a grid first (see `crate::budget`). Estimates are upper bounds,
//! not measurements.

use crate::exec::Threads;
use crate::mesh::TriMesh;
use crate::voxel::{GridSpec, MAX_LEVEL};

/// Bit grids alive at once while voxelizing (surface, interior, solid,
/// skin, near surface).
const GRIDS_IN_FLIGHT: u64 = 5;

/// Bytes of a skin voxel in a candidate list ([u16; 3]).
const BYTES_PER_SKIN_VOXEL: u64 = 6;

/// Bytes of voxelizing on `spec`: the bit grids alive at once, every level
/// of the count pyramid (u32 running sums and u8 occupancy per block, each
/// level an eighth of the one below), and at most one skin voxel per voxel
/// of the solid's surface layer.
pub(crate) fn voxel_bytes(spec: &GridSpec) -> u64 {
    let grids = spec.grid_bytes().saturating_mul(GRIDS_IN_FLIGHT);
    let [nx, ny, nz] = spec.dims.map(|d| d as u64);
    let mut pyramid = 0u64;
    for level in 1..=MAX_LEVEL {
        let blocks = [nx, ny, nz].map(|d| d.div_ceil(1 << level) + 1);
        pyramid = pyramid.saturating_add(5 * blocks[0] * blocks[1] * blocks[2]);
    }
    // The skin is a shell: about the bounding box's faces, twice.
    let faces = 2 * (nx * ny + ny * nz + nz * nx);
    grids
        .saturating_add(pyramid)
        .saturating_add(2 * faces * BYTES_PER_SKIN_VOXEL)
}

/// The voxelizer's work for `mesh` on voxels of `voxel_size`: the
/// triangles' area projected on the three axis planes, in voxel faces.
/// It bounds the surface pass (a triangle is swept along its dominant axis,
/// one column per face) and the fill's column crossings, and it is known in
/// O(triangles) before anything is built.
pub(crate) fn voxel_work(mesh: &TriMesh, voxel_size: f64, backend: Threads) -> f64 {
    // Summed in fixed chunks, so that every backend adds in one order.
    const CHUNK: usize = 1 << 14;
    let triangles = mesh.triangles().len();
    let chunks = backend.map_each(triangles.div_ceil(CHUNK), |c| {
        (c * CHUNK..((c + 1) * CHUNK).min(triangles))
            .map(|t| projected_area(mesh, t))
            .sum::<f64>()
    });
    chunks.iter().sum::<f64>() / (voxel_size * voxel_size)
}

/// [`voxel_work`] of the triangles `part` of `mesh`, serially: a part's
/// share of the work, as the search plans it.
pub(crate) fn part_voxel_work(mesh: &TriMesh, part: &[u32], voxel_size: f64) -> f64 {
    let area: f64 = part.iter().map(|&t| projected_area(mesh, t as usize)).sum();
    area / (voxel_size * voxel_size)
}

/// Triangle `t`'s area projected on the three axis planes, summed.
fn projected_area(mesh: &TriMesh, t: usize) -> f64 {
    let [a, b, c] = mesh.corners(t);
    let n = (b - a).cross(c - a);
    (n.x.abs() + n.y.abs() + n.z.abs()) / 2.0
}

/// Bytes of the run tables of one digital ball of `radius` voxels read at
/// pyramid `level`: a table per position of the centre in its block (8^level
/// of them, an eighth more while the mirrored ones are derived), each with
/// about pi (r/s + 1.5)^2 runs of 8 bytes plus 16 bytes of bound offsets,
/// and a slab of 12 bytes per row of them.
pub(crate) fn ball_bytes(radius: f64, level: u32) -> u64 {
    let s = f64::from(1u32 << level);
    let runs = std::f64::consts::PI * (radius / s + 1.5).powi(2);
    let phases = s * s * s * 1.125;
    let slabs = 2.0 * radius / s + 3.0;
    let bytes = phases * (24.0 * runs + 12.0 * slabs + 128.0);
    if bytes.is_finite() && bytes < u64::MAX as f64 {
        bytes as u64
    } else {
        u64::MAX
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::voxel::Ball;

    #[test]
    fn ball_estimates_bound_the_real_tables() {
        for (radius, level) in [(3.0, 0), (20.0, 1), (40.0, 2), (80.0, 3), (300.0, 3)] {
            let ball = Ball::at_level(radius, level);
            let real = ball.table_bytes();
            let estimate = ball_bytes(radius, level);
            assert!(
                estimate >= real,
                "r {radius} level {level}: {estimate} < {real}"
            );
            assert!(
                estimate <= 4 * real + 4096,
                "r {radius} level {level}: {estimate} >> {real}"
            );
        }
        assert_eq!(ball_bytes(f64::INFINITY, 5), u64::MAX);
    }

    #[test]
    fn voxel_work_is_the_projected_area_in_voxel_faces() {
        // A unit square in the xy plane, and the same square tilted 45
        // degrees about x: its projections cover 1/sqrt(2) on two planes.
        let flat = TriMesh::new(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        )
        .unwrap();
        assert!((voxel_work(&flat, 0.1, Threads::Serial) - 100.0).abs() < 1e-9);
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let tilted = TriMesh::new(
            vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, h, h], [0.0, h, h]],
            vec![[0, 1, 2], [0, 2, 3]],
        )
        .unwrap();
        let expected = 2.0 * f64::from(h) * 100.0;
        assert!((voxel_work(&tilted, 0.1, Threads::Serial) - expected).abs() < 1e-4);
    }

    #[test]
    fn voxel_work_adds_alike_on_every_backend() {
        // Several chunks' worth of triangles: a sphere's projections on
        // the three planes are three discs, each covered twice.
        let sphere = crate::mesh::shapes::uv_sphere(crate::math::Vec3::ZERO, 1.0, 180, 240);
        assert!(sphere.triangles().len() > 4 << 14);
        let serial = voxel_work(&sphere, 0.1, Threads::Serial);
        assert_eq!(serial, voxel_work(&sphere, 0.1, Threads::Parallel));
        let discs = 3.0 * 2.0 * std::f64::consts::PI * 100.0;
        assert!((serial - discs).abs() < 0.01 * discs, "{serial} {discs}");
    }

    #[test]
    fn voxel_bytes_grow_with_the_grid() {
        let spec = |n| GridSpec {
            origin: Vec3::ZERO,
            voxel_size: 1.0,
            dims: [n, n, n],
        };
        let (small, large) = (voxel_bytes(&spec(64)), voxel_bytes(&spec(512)));
        assert!(
            large > 250 * small && large < 520 * small,
            "{small} {large}"
        );
        // 5 bit grids at 1/8 byte a voxel and a pyramid of about 5/7.
        let per_voxel = large as f64 / 512f64.powi(3);
        assert!((1.3..1.5).contains(&per_voxel), "{per_voxel}");
    }
}
