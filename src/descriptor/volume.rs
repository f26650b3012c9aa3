//! The coarse volumetric descriptor (paper, sec. 4.2, Eq. 3-4): the solid
//! fraction of the ball of radius r_i around a point, compared by the running
//! sum of absolute differences.
//!
//! It is cheap and rotation invariant, so it runs first and rejects most
//! candidates before the spherical harmonics see them. Counting is exact on
//! the voxel lattice: the ball is a list of row spans along x, and each span
//! is counted with a few popcounts on the bit-packed grid.

use super::OnionDescriptor;
use crate::voxel::Grid;

/// One row of a digital ball: lattice points `(dx, dy, dz)` with
/// `|dx| <= half`.
#[derive(Clone, Copy, Debug)]
struct Span {
    dy: i32,
    dz: i32,
    half: u32,
}

/// The lattice points within a radius (in voxels) of a voxel centre.
#[derive(Clone, Debug)]
pub struct Ball {
    radius: f64,
    extent: i64,
    spans: Vec<Span>,
    points: u64,
}

impl Ball {
    /// The ball of `radius` voxels.
    pub fn new(radius: f64) -> Ball {
        let r2 = radius * radius;
        let extent = radius.floor() as i64;
        let mut spans = Vec::new();
        let mut points = 0;
        for dz in -extent..=extent {
            for dy in -extent..=extent {
                let rest = r2 - (dy * dy + dz * dz) as f64;
                if rest < 0.0 {
                    continue;
                }
                let mut half = rest.sqrt().floor() as i64;
                // Guard the square root's rounding at exact squares.
                while (half + 1) * (half + 1) <= rest as i64 {
                    half += 1;
                }
                while half * half > rest as i64 && half > 0 {
                    half -= 1;
                }
                spans.push(Span {
                    dy: dy as i32,
                    dz: dz as i32,
                    half: half as u32,
                });
                points += 2 * half as u64 + 1;
            }
        }
        Ball {
            radius,
            extent,
            spans,
            points,
        }
    }

    /// The radius in voxels.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// How many lattice points the ball holds.
    pub fn points(&self) -> u64 {
        self.points
    }

    /// Set voxels of `grid` inside the ball centred on voxel `v` (voxels
    /// outside the grid count as empty).
    pub fn count(&self, grid: &Grid, v: [u16; 3]) -> u64 {
        let [nx, ny, nz] = grid.dims().map(|d| d as i64);
        let c = v.map(|x| x as i64);
        let words = grid.words();
        let wpr = grid.words_per_row() as i64;
        let e = self.extent;
        let x_inside = c[0] - e >= 0 && c[0] + e < nx;
        let rows_inside = c[1] - e >= 0 && c[2] - e >= 0 && c[1] + e < ny && c[2] + e < nz;
        let mut total = 0u64;
        for s in &self.spans {
            let (y, z) = (c[1] + s.dy as i64, c[2] + s.dz as i64);
            if !rows_inside && (y < 0 || z < 0 || y >= ny || z >= nz) {
                continue;
            }
            let row = ((z * ny + y) * wpr) as usize;
            let h = s.half as i64;
            total += if x_inside {
                count_span(words, row, (c[0] - h) as usize, (c[0] + h) as usize)
            } else {
                let (lo, hi) = ((c[0] - h).max(0), (c[0] + h).min(nx - 1));
                if lo > hi {
                    continue;
                }
                count_span(words, row, lo as usize, hi as usize)
            } as u64;
        }
        total
    }

    /// The solid fraction of the ball around voxel `v` (Eq. 3).
    pub fn fraction(&self, grid: &Grid, v: [u16; 3]) -> f64 {
        self.count(grid, v) as f64 / self.points as f64
    }
}

/// Set bits `lo..=hi` of the row starting at word `row`.
#[inline]
fn count_span(words: &[u64], row: usize, lo: usize, hi: usize) -> u32 {
    let (wl, wh) = (row + (lo >> 6), row + (hi >> 6));
    let lo_mask = !0u64 << (lo & 63);
    let hi_mask = !0u64 >> (63 - (hi & 63));
    if wl == wh {
        return (words[wl] & lo_mask & hi_mask).count_ones();
    }
    let mut n = (words[wl] & lo_mask).count_ones() + (words[wh] & hi_mask).count_ones();
    for w in &words[wl + 1..wh] {
        n += w.count_ones();
    }
    n
}

/// The volume stage of the cascade: rejects a point once
/// `sum_i |CF_T(r_i) - CF(v, r_i)|` passes the threshold (Eq. 4).
pub struct VolumeDescriptor<'a> {
    grid: &'a Grid,
    points: &'a [[u16; 3]],
    balls: Vec<Ball>,
    radii: Vec<f64>,
    template: Vec<f64>,
    threshold: f64,
}

impl<'a> VolumeDescriptor<'a> {
    /// A stage over the candidate voxels `points` of the scene `grid`, with
    /// the template's fractions at the same radii (world units).
    pub fn new(
        grid: &'a Grid,
        points: &'a [[u16; 3]],
        radii: &[f64],
        template: Vec<f64>,
        threshold: f64,
    ) -> Self {
        let voxel = grid.spec().voxel_size;
        VolumeDescriptor {
            grid,
            points,
            balls: radii.iter().map(|r| Ball::new(r / voxel)).collect(),
            radii: radii.to_vec(),
            template,
            threshold,
        }
    }

    /// The descriptor of one voxel of any grid with this stage's voxel size:
    /// what the template side computes.
    pub fn describe(grid: &Grid, v: [u16; 3], radii: &[f64]) -> Vec<f64> {
        let voxel = grid.spec().voxel_size;
        radii
            .iter()
            .map(|r| Ball::new(r / voxel).fraction(grid, v))
            .collect()
    }
}

impl OnionDescriptor for VolumeDescriptor<'_> {
    type State = f64;

    fn name(&self) -> &'static str {
        "volume"
    }

    fn layers(&self) -> usize {
        self.balls.len()
    }

    fn radius(&self, layer: usize) -> f64 {
        self.radii[layer]
    }

    fn threshold(&self) -> f64 {
        self.threshold
    }

    fn start(&self, _point: u32) -> f64 {
        0.0
    }

    fn extend(&self, point: u32, layer: usize, sum: &mut f64) -> f64 {
        let f = self.balls[layer].fraction(self.grid, self.points[point as usize]);
        *sum += (f - self.template[layer]).abs();
        *sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exec::Backend;
    use crate::math::Vec3;
    use crate::mesh::shapes::{cuboid, uv_sphere};
    use crate::voxel::{GridSpec, voxelize};
    use std::f64::consts::PI;

    #[test]
    fn ball_holds_about_its_volume_in_lattice_points() {
        for r in [3.0, 7.5, 20.0, 41.3] {
            let b = Ball::new(r);
            let want = 4.0 / 3.0 * PI * r * r * r;
            let err = (b.points() as f64 - want).abs() / want;
            assert!(err < 3.0 / r, "r {r}: {} vs {want}", b.points());
        }
        assert_eq!(Ball::new(1.0).points(), 7);
        assert_eq!(Ball::new(0.5).points(), 1);
    }

    #[test]
    fn counting_matches_brute_force_near_and_away_from_the_border() {
        let m = uv_sphere(Vec3::ZERO, 1.0, 24, 48);
        let spec = GridSpec::for_scene(m.bounds(), 40).unwrap();
        let g = voxelize(&m, &spec, Backend::Serial);
        let ball = Ball::new(6.7);
        for v in [
            [20u16, 20, 20],
            [3, 20, 20],
            [21, 1, 38],
            [0, 0, 0],
            [41, 30, 5],
        ] {
            let mut brute = 0;
            let e = 7i64;
            for dz in -e..=e {
                for dy in -e..=e {
                    for dx in -e..=e {
                        if ((dx * dx + dy * dy + dz * dz) as f64) <= 6.7 * 6.7
                            && g.get(v[0] as i64 + dx, v[1] as i64 + dy, v[2] as i64 + dz)
                        {
                            brute += 1;
                        }
                    }
                }
            }
            assert_eq!(ball.count(&g, v), brute, "at {v:?}");
        }
    }

    #[test]
    fn a_point_on_a_large_flat_slab_sees_one_half_at_every_radius() {
        // The top face of a slab, far from its edges: half of every ball is solid.
        let slab = cuboid(Vec3::new(-4.0, -4.0, -1.0), Vec3::new(4.0, 4.0, 0.0));
        let spec = GridSpec::for_scene(slab.bounds(), 256).unwrap();
        let g = voxelize(&slab, &spec, Backend::Serial);
        let skin = crate::voxel::skin(&g);
        let top = spec.to_grid(Vec3::new(0.1, -0.2, 0.0));
        let v = skin
            .iter_ones()
            .filter(|s| s[0] as i64 == top.x as i64 && s[1] as i64 == top.y as i64)
            .max_by_key(|s| s[2])
            .unwrap();
        let radii = [0.1, 0.25, 0.5, 0.75, 0.9];
        for (r, f) in radii.iter().zip(VolumeDescriptor::describe(&g, v, &radii)) {
            // The centre voxel's own layer tips the balance by at most one
            // disc of lattice points.
            let disc =
                PI * (r / spec.voxel_size).powi(2) / Ball::new(r / spec.voxel_size).points() as f64;
            assert!((f - 0.5).abs() <= disc * 0.6 + 1e-9, "r {r}: {f}");
        }
    }

    /// Volume of the intersection of balls of radius `big` and `r` whose
    /// centres are `d` apart (0 < d < big + r, d > big - r).
    fn lens(big: f64, r: f64, d: f64) -> f64 {
        PI * (big + r - d).powi(2)
            * (d * d + 2.0 * d * r - 3.0 * r * r + 2.0 * d * big + 6.0 * r * big - 3.0 * big * big)
            / (12.0 * d)
    }

    #[test]
    fn a_ball_inside_a_solid_is_full_and_fractions_at_a_sphere_are_analytic() {
        let big_r = 1.0;
        let m = uv_sphere(Vec3::ZERO, big_r, 128, 256);
        let spec = GridSpec::for_scene(m.bounds(), 256).unwrap();
        // The centre-sampled interior is an unbiased picture of the solid.
        let g = crate::voxel::fill_solid(&m, &spec, Backend::Serial);
        let centre = spec.to_grid(Vec3::ZERO);
        let c = [centre.x as u16, centre.y as u16, centre.z as u16];
        assert_eq!(VolumeDescriptor::describe(&g, c, &[0.5])[0], 1.0);
        // The topmost solid voxel above the centre, a point near the surface.
        let top = g
            .iter_ones()
            .filter(|s| s[0] == c[0] && s[1] == c[1])
            .max_by_key(|s| s[2])
            .unwrap();
        let d = spec.center(top).norm();
        for r in [0.1, 0.2, 0.4, 0.8] {
            let want = lens(big_r, r, d) / (4.0 / 3.0 * PI * r * r * r);
            let got = VolumeDescriptor::describe(&g, top, &[r])[0];
            // Lattice counting error shrinks with the radius in voxels.
            let tol = 0.1 / (r / spec.voxel_size);
            assert!((got - want).abs() < tol, "r {r}: {got} vs {want}");
        }
    }
}
