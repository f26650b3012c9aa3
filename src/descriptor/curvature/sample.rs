//! A surface's vertices binned in a uniform grid: one vertex per occupied
//! cell samples the surface at the cell's spacing, and the bins find the
//! vertices near a few points without a scan.
//!
//! The curvature search uses both: a first pass over the sample, then every
//! vertex near what survived it.

use super::surface::Surface;
use crate::math::{Aabb, Vec3};

/// Cells along each axis are numbered in 21 bits, packed into one key.
const AXIS_BITS: u32 = 21;

/// The used vertices of a surface, sorted by grid cell.
pub struct VertexGrid {
    cell: f64,
    origin: Vec3,
    /// (cell key, vertex), sorted: a cell's vertices are one run.
    entries: Vec<(u64, u32)>,
}

impl VertexGrid {
    /// Bins the used vertices of `surface` in cells of side `cell`; None
    /// when `cell` is not a positive number or the surface spans more than
    /// 2^21 cells along an axis.
    pub fn new(surface: &Surface, cell: f64) -> Option<VertexGrid> {
        if !(cell.is_finite() && cell > 0.0) {
            return None;
        }
        let used: Vec<u32> = surface.used_vertices().collect();
        let bounds = Aabb::around(used.iter().map(|&v| surface.position(v)))?;
        let span = bounds.extent() * (1.0 / cell);
        if span.max_element() >= f64::from(1u32 << AXIS_BITS) - 2.0 {
            return None;
        }
        let mut grid = VertexGrid {
            cell,
            origin: bounds.min,
            entries: Vec::new(),
        };
        grid.entries = used
            .iter()
            .map(|&v| (grid.key(grid.cell_of(surface.position(v))), v))
            .collect();
        grid.entries.sort_unstable();
        Some(grid)
    }

    /// How many vertices are binned: the surface's used vertices.
    pub fn vertex_count(&self) -> usize {
        self.entries.len()
    }

    /// One vertex per occupied cell, the one nearest the cell's centre
    /// (the lower index on a tie), in increasing order.
    pub fn sample(&self, surface: &Surface) -> Vec<u32> {
        let mut sample: Vec<u32> = self
            .entries
            .chunk_by(|a, b| a.0 == b.0)
            .map(|run| {
                let centre = self.centre(run[0].0);
                run.iter()
                    .map(|&(_, v)| v)
                    .min_by(|&a, &b| {
                        (surface.position(a) - centre)
                            .length_squared()
                            .total_cmp(&(surface.position(b) - centre).length_squared())
                            .then(a.cmp(&b))
                    })
                    .expect("a run is never empty")
            })
            .collect();
        sample.sort_unstable();
        sample
    }

    /// Every used vertex within `reach` of one of `points`, in increasing
    /// order.
    pub fn within(&self, surface: &Surface, points: &[Vec3], reach: f64) -> Vec<u32> {
        let steps = (reach / self.cell).ceil().max(0.0) as i64;
        let reach2 = reach * reach;
        let mut found = Vec::new();
        for &p in points {
            let [x, y, z] = self.cell_of(p);
            for dz in -steps..=steps {
                for dy in -steps..=steps {
                    for dx in -steps..=steps {
                        let Some(key) = self.checked_key([x + dx, y + dy, z + dz]) else {
                            continue;
                        };
                        let start = self.entries.partition_point(|e| e.0 < key);
                        found.extend(
                            self.entries[start..]
                                .iter()
                                .take_while(|e| e.0 == key)
                                .map(|e| e.1)
                                .filter(|&v| (surface.position(v) - p).length_squared() <= reach2),
                        );
                    }
                }
            }
        }
        found.sort_unstable();
        found.dedup();
        found
    }

    fn cell_of(&self, p: Vec3) -> [i64; 3] {
        let q = (p - self.origin) * (1.0 / self.cell);
        // Clamped so that a far point cannot overflow; out-of-range cells
        // hold nothing (`checked_key`).
        [q.x, q.y, q.z].map(|c| c.floor().clamp(-1.0, f64::from(1u32 << AXIS_BITS)) as i64)
    }

    fn checked_key(&self, c: [i64; 3]) -> Option<u64> {
        let fits = |x: i64| (0..1i64 << AXIS_BITS).contains(&x);
        c.iter().all(|&x| fits(x)).then(|| self.key(c))
    }

    fn key(&self, [x, y, z]: [i64; 3]) -> u64 {
        ((z as u64) << (2 * AXIS_BITS)) | ((y as u64) << AXIS_BITS) | x as u64
    }

    fn centre(&self, key: u64) -> Vec3 {
        let mask = (1u64 << AXIS_BITS) - 1;
        let axis = |shift: u32| ((key >> shift) & mask) as f64 + 0.5;
        self.origin + Vec3::new(axis(0), axis(AXIS_BITS), axis(2 * AXIS_BITS)) * self.cell
    }
}

/// How much looser the sample pass's threshold is than the final pass's. A
/// sample vertex lies up to a cell's diagonal from the best point of an
/// occurrence, and the distance rises steeply away from it. At spacing 0.5,
/// over 48 turnings of remeshed-cow and twisted-homer and 16 of
/// fused-homer, the best sample vertex within reach of
/// an occurrence needed up to 3.8 times the threshold on twisted-homer, 2.6
/// on fused-homer and 7.2 on remeshed-cow (where the best point itself is
/// at 0.8 of it); 10 would cover them all but keeps so much of zoo-bunny
/// that the final pass sees 109k of its 168k vertices. No slack serves CAD
/// meshes: on real-saw-roller the nearest sample vertices of a copy are
/// 100 to 8000 thresholds away (experiments/sample_turnings.rs).
pub const SAMPLE_SLACK: f64 = 5.0;

/// The final pass's candidates: every vertex within this many cells of a
/// sample survivor (the best point of an occurrence is within a cell's
/// diagonal, 1.7 cells, of its cell's sample vertex).
pub const SAMPLE_REACH: f64 = 2.0;

/// The first pass's candidates: one vertex per grid cell.
pub struct VertexSample {
    /// The cells.
    pub grid: VertexGrid,
    /// One vertex per cell.
    pub vertices: Vec<u32>,
}

impl VertexSample {
    /// None where sampling is off (`spacing` 0), impossible (a surface
    /// spanning more cells than a key holds) or would save little (the
    /// sample keeps more than half the vertices: a coarse mesh).
    pub fn of(surface: &Surface, spacing: f64) -> Option<VertexSample> {
        let grid = VertexGrid::new(surface, spacing)?;
        let vertices = grid.sample(surface);
        (vertices.len() * 2 <= grid.vertex_count()).then_some(VertexSample { grid, vertices })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exec::Threads;
    use crate::mesh::shapes::uv_sphere;

    fn sphere() -> Surface {
        Surface::new(&uv_sphere(Vec3::ZERO, 1.0, 48, 96), Threads::Parallel)
    }

    #[test]
    fn the_sample_has_one_vertex_per_occupied_cell() {
        let s = sphere();
        let grid = VertexGrid::new(&s, 0.25).unwrap();
        let sample = grid.sample(&s);
        let cells: std::collections::BTreeSet<[i64; 3]> = sample
            .iter()
            .map(|&v| grid.cell_of(s.position(v)))
            .collect();
        assert_eq!(cells.len(), sample.len(), "two samples share a cell");
        let every: std::collections::BTreeSet<[i64; 3]> = s
            .used_vertices()
            .map(|v| grid.cell_of(s.position(v)))
            .collect();
        assert_eq!(cells, every, "an occupied cell has no sample");
        assert!(sample.len() * 10 < s.used_vertices().count());
        // Every vertex has a sample within a cell's diagonal.
        let diagonal = 0.25 * 3f64.sqrt();
        for v in s.used_vertices() {
            let p = s.position(v);
            assert!(
                sample
                    .iter()
                    .any(|&u| (s.position(u) - p).length() <= diagonal)
            );
        }
    }

    #[test]
    fn within_finds_exactly_the_vertices_in_reach() {
        let s = sphere();
        let grid = VertexGrid::new(&s, 0.1).unwrap();
        let points = [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, -0.6, 0.8),
            Vec3::new(5.0, 5.0, 5.0),
        ];
        for reach in [0.05, 0.23, 0.5] {
            let brute: Vec<u32> = s
                .used_vertices()
                .filter(|&v| {
                    points
                        .iter()
                        .any(|&p| (s.position(v) - p).length() <= reach)
                })
                .collect();
            assert!(!brute.is_empty());
            assert_eq!(grid.within(&s, &points, reach), brute, "reach {reach}");
        }
    }

    #[test]
    fn a_cell_too_small_for_the_surface_is_refused() {
        let s = sphere();
        assert!(VertexGrid::new(&s, 1e-9).is_none());
        assert!(VertexGrid::new(&s, 0.0).is_none());
        assert!(VertexGrid::new(&s, f64::NAN).is_none());
    }
}
