//! A smooth variant of the curvature layers, measured against the search's
//! (experiments/curvature_margin.rs) and not used by it: each edge weighted by a
//! kernel of s = |x - c| / r that falls to 0 at the sphere, integrated
//! along the edge, and the tensor divided either by the weight's integral
//! over a flat disc or by its integral over the neighbourhood's surface
//! (the search's area, weighted the same way). Two smooth kernels ([`KernelShape`]):
//! w = (1 - s^2)^2 across the ball, and one flat (w = 1) out to r / 2 that
//! then falls as 16/9 (1 - s^2)^2, which keeps the search's area-weighted
//! mean near the centre and smooths only the rim; and a uniform one, the
//! search's own layers, as the oracle that ties this code to them.
//!
//! Why a candidate: the search's layer jumps as triangles cross the sphere
//! (each brings its full weight in at once) and is divided by an area that
//! jumps with it; here a triangle enters with weight 0 and slope 0, so the
//! value moves continuously with the centre wherever the connected
//! neighbourhood does not change.

use super::ball_clip::{crossing, segment_in_ball};
use super::neighbourhood::{CurvatureState, full_tensor, gather, gaussian};
use super::surface::Surface;
use crate::math::{Vec3, symmetric_eigen};
use crate::mesh::closest_point_on_triangle;

/// The kernel's shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KernelShape {
    /// w = (1 - s^2)^2: greatest at the centre, 0 with slope 0 at r.
    Falling,
    /// w = 1 out to r / 2, then 16/9 (1 - s^2)^2 (continuous at r / 2): the
    /// search's uniform weight near the centre, a smooth rim.
    FlatCentre,
    /// w = 1 inside the ball: the search's own layers (up to the
    /// quadrature of the cut triangles' areas), which ties this code to
    /// the search's in a test.
    Uniform,
}

impl KernelShape {
    /// The weight at squared relative distance `s2` = |x - c|^2 / r^2.
    fn weight(self, s2: f64) -> f64 {
        let falling = (1.0 - s2).max(0.0).powi(2);
        match self {
            KernelShape::Falling => falling,
            KernelShape::FlatCentre if s2 <= FLAT_SHARE * FLAT_SHARE => 1.0,
            KernelShape::FlatCentre => RIM_SCALE * falling,
            KernelShape::Uniform => f64::from(u8::from(s2 <= 1.0)),
        }
    }

    /// The weight's integral over a flat disc of radius `r` through the
    /// centre (and over any sphere's cap: Archimedes' hat-box theorem).
    fn disc_integral(self, r: f64) -> f64 {
        // 2 pi r^2 times the integral of w(s) s ds over 0..1: 1/6 for the
        // falling kernel; 1/8 flat plus 16/9 * 9/128 = 1/8 of rim; 1/2.
        let share = match self {
            KernelShape::Falling => 1.0 / 6.0,
            KernelShape::FlatCentre => 0.25,
            KernelShape::Uniform => 0.5,
        };
        2.0 * std::f64::consts::PI * r * r * share
    }
}

/// The flat kernel's flat radius, as a share of r.
const FLAT_SHARE: f64 = 0.5;
/// 1 / (1 - FLAT_SHARE^2)^2: the rim's scale that makes it 1 at r / 2.
const RIM_SCALE: f64 = 16.0 / 9.0;

/// What the kernel-weighted edge tensor is divided by.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KernelNorm {
    /// The weight's integral over a flat disc (pi r^2 / 3 for the falling
    /// kernel): a constant.
    Disc,
    /// The weight's integral over the neighbourhood's triangles.
    Area,
}

/// The smooth layers at vertex `v` for every radius (Gaussian curvature,
/// unscaled).
pub fn kernel_layers_at(
    surface: &Surface,
    v: u32,
    radii: &[f64],
    shape: KernelShape,
    norm: KernelNorm,
) -> Vec<f64> {
    let mut state = CurvatureState::at(surface, v);
    radii
        .iter()
        .map(|&r| {
            let ball = gather(surface, v, r, &mut state);
            let mut tensor = [0.0; 6];
            let mut area = 0.0;
            let triangles = state
                .patches
                .iter()
                .flat_map(|&p| surface.patch_triangles(p))
                .chain(state.region.iter().copied());
            for t in triangles {
                let p = surface.corners(t).map(|q| q - ball.centre);
                if norm == KernelNorm::Area {
                    area += kernel_area(p, r, shape);
                }
                let edges = surface.curved_edges(t).iter().filter_map(|e| {
                    let side = e.side as usize;
                    let w = kernel_length(p[side], p[(side + 1) % 3], r, shape);
                    (w > 0.0).then_some((e, w))
                });
                for (sum, x) in tensor.iter_mut().zip(ball.edge_tensor(edges)) {
                    *sum += x;
                }
            }
            let divisor = match norm {
                KernelNorm::Disc => shape.disc_integral(r),
                KernelNorm::Area => area,
            };
            if divisor <= 0.0 {
                return 0.0;
            }
            let (values, _) =
                symmetric_eigen(full_tensor(tensor).map(|row| row.map(|x| x / divisor)));
            gaussian(values)
        })
        .collect()
}

/// Dunavant's degree-4 rule on a triangle, exact for the weight inside the
/// ball: two orbits of points, barycentric (a, b, b) and its rotations,
/// with each point's weight (the six sum to 1).
const RULE_ORBITS: [(f64, f64, f64); 2] = [
    (0.108103018168070, 0.445948490915965, 0.223381589678011),
    (0.816847572980459, 0.091576213509771, 0.109951743655322),
];

/// A triangle cut by the sphere is split in four until its longest edge is
/// at most this share of the radius (or it has been split `MAX_DEPTH`
/// times), then the rule is applied to the clamped weight.
const CUT_EDGE: f64 = 0.25;
const MAX_DEPTH: u32 = 16;

/// The integral of the kernel (0 past r) over triangle `p`, centre at the
/// origin: exact for a triangle that no sphere the weight changes form at
/// (r, and r / 2 for the flat kernel) cuts, zero for one outside, and for
/// one cut the rule after splits down to a quarter of r (the weight is
/// continuous there, so the rule's error is small and the sum moves
/// continuously with the centre).
fn kernel_area(p: [Vec3; 3], r: f64, shape: KernelShape) -> f64 {
    split_kernel_area(p, r, shape, 0)
}

/// Whether a sphere of squared radius `r2` about the origin cuts triangle
/// `p` (some corner outside it, some point inside), and whether `p` lies
/// wholly outside it.
fn cut_or_outside(p: [Vec3; 3], r2: f64) -> (bool, bool) {
    if p.iter().all(|q| q.length_squared() <= r2) {
        return (false, false);
    }
    let outside = closest_point_on_triangle(Vec3::ZERO, p[0], p[1], p[2], 0).distance2 >= r2;
    (!outside, outside)
}

/// [`kernel_area`] of a triangle split `depth` times already.
fn split_kernel_area(p: [Vec3; 3], r: f64, shape: KernelShape, depth: u32) -> f64 {
    let r2 = r * r;
    let (cut, outside) = cut_or_outside(p, r2);
    if outside {
        return 0.0;
    }
    let cut = cut
        || (shape == KernelShape::FlatCentre && cut_or_outside(p, FLAT_SHARE * FLAT_SHARE * r2).0);
    if cut {
        let longest = (0..3)
            .map(|i| (p[(i + 1) % 3] - p[i]).length_squared())
            .fold(0.0, f64::max);
        if depth < MAX_DEPTH && longest > CUT_EDGE * CUT_EDGE * r2 {
            let m = [
                (p[0] + p[1]) * 0.5,
                (p[1] + p[2]) * 0.5,
                (p[2] + p[0]) * 0.5,
            ];
            return [
                [p[0], m[0], m[2]],
                [m[0], p[1], m[1]],
                [m[2], m[1], p[2]],
                [m[0], m[1], m[2]],
            ]
            .iter()
            .map(|&q| split_kernel_area(q, r, shape, depth + 1))
            .sum();
        }
    }
    let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
    let inv = 1.0 / r2;
    let w = |x: Vec3| shape.weight(x.length_squared() * inv);
    RULE_ORBITS
        .iter()
        .map(|&(a, b, weight)| {
            let rotations = (0..3).map(|i| p[i] * a + p[(i + 1) % 3] * b + p[(i + 2) % 3] * b);
            weight * rotations.map(w).sum::<f64>()
        })
        .sum::<f64>()
        * area
}

/// The integral of the kernel along the segment `a`-`b`, centre at the
/// origin.
fn kernel_length(a: Vec3, b: Vec3, r: f64, shape: KernelShape) -> f64 {
    let falling = |radius: f64| falling_length(a, b, r, radius);
    match shape {
        KernelShape::Falling => falling(r),
        KernelShape::Uniform => segment_in_ball(a, b, r * r),
        KernelShape::FlatCentre => {
            // Length inside r / 2, plus the rim's falling weight between
            // the two spheres.
            let inner = FLAT_SHARE * r;
            segment_in_ball(a, b, inner * inner) + RIM_SCALE * (falling(r) - falling(inner))
        }
    }
}

/// The integral of (1 - |x|^2 / r^2)^2 along the part of segment `a`-`b`
/// inside the sphere of `radius` <= r about the origin.
fn falling_length(a: Vec3, b: Vec3, r: f64, radius: f64) -> f64 {
    let r2 = radius * radius;
    let Some(line) = crossing(a, b, a.length_squared(), b.length_squared(), r2) else {
        return 0.0;
    };
    let (lo, hi) = (line.t0.max(0.0), line.t1.min(1.0));
    if hi <= lo {
        return 0.0;
    }
    // 1 - |a + t d|^2 / r^2 = c0 + c1 t + c2 t^2.
    let d = b - a;
    let inv = 1.0 / (r * r);
    let (c0, c1, c2) = (
        1.0 - a.length_squared() * inv,
        -2.0 * a.dot(d) * inv,
        -d.length_squared() * inv,
    );
    // f^2 = c0^2 + 2 c0 c1 t + (c1^2 + 2 c0 c2) t^2 + 2 c1 c2 t^3 + c2^2 t^4.
    let antiderivative = |t: f64| {
        t * (c0 * c0
            + t * (c0 * c1
                + t * ((c1 * c1 + 2.0 * c0 * c2) / 3.0 + t * (c1 * c2 / 2.0 + t * c2 * c2 / 5.0))))
    };
    (antiderivative(hi) - antiderivative(lo)) * d.length()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::descriptor::curvature::CurvatureDescriptor;
    use crate::exec::Threads;
    use crate::mesh::shapes::{torus, uv_sphere};

    #[test]
    fn a_sphere_has_curvature_one_over_r_squared() {
        // The weight's integral over a sphere's cap equals the flat disc's
        // (Archimedes), so the layers hold the sphere's 1 / R^2.
        let radius = 2.0;
        let s = Surface::new(&uv_sphere(Vec3::ZERO, radius, 96, 192), Threads::Parallel);
        let v = s.nearest_vertex(Vec3::new(radius, 0.0, 0.0)).unwrap();
        for shape in [KernelShape::Falling, KernelShape::FlatCentre] {
            for norm in [KernelNorm::Disc, KernelNorm::Area] {
                for g in kernel_layers_at(&s, v, &[0.3, 0.6, 0.9, 1.2], shape, norm) {
                    let want = 1.0 / (radius * radius);
                    assert!(
                        (g - want).abs() < 0.03 * want,
                        "{shape:?} {norm:?}: {g} vs {want}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_uniform_kernel_gives_the_searchs_layers() {
        // w = 1 is the search's descriptor: every other kernel differs
        // from it by its weight alone. A coarse torus, whose triangles the
        // spheres cut at every radius (and the quadrature with them).
        let s = Surface::new(&torus(Vec3::ZERO, 2.0, 0.7, 40, 16), Threads::Parallel);
        let radii = [0.3, 0.6, 0.9, 1.2, 1.5];
        for v in (0..s.vertex_count() as u32).step_by(37) {
            let search = CurvatureDescriptor::describe(&s, v, &radii);
            let kernel = kernel_layers_at(&s, v, &radii, KernelShape::Uniform, KernelNorm::Area);
            for (a, b) in search.iter().zip(&kernel) {
                assert!(
                    (a - b).abs() <= 0.01 * a.abs().max(0.1),
                    "vertex {v}: {a} vs {b}"
                );
            }
        }
    }

    #[test]
    fn a_plane_weighs_as_a_disc() {
        // One large triangle through the centre: pi r^2 / 3; one wholly
        // inside: its polynomial integral, exactly.
        let r = 1.5;
        let big = [
            Vec3::new(-10.0, -10.0, 0.0),
            Vec3::new(10.0, -10.0, 0.0),
            Vec3::new(0.0, 10.0, 0.0),
        ];
        let disc = std::f64::consts::PI * r * r / 3.0;
        let got = kernel_area(big, r, KernelShape::Falling);
        assert!((got - disc).abs() < 0.01 * disc, "{got} vs {disc}");
        let flat = kernel_area(big, r, KernelShape::FlatCentre);
        let disc = KernelShape::FlatCentre.disc_integral(r);
        assert!((flat - disc).abs() < 0.01 * disc, "{flat} vs {disc}");
        // A small right triangle at the centre, legs h, wholly inside:
        // against a fine grid of cells over it.
        let h = 0.5;
        let small = [Vec3::ZERO, Vec3::new(h, 0.0, 0.0), Vec3::new(0.0, h, 0.0)];
        let exact = kernel_area(small, r, KernelShape::Falling);
        let (mut fine, n) = (0.0, 1000);
        let cell = h / n as f64;
        for i in 0..n {
            for j in 0..n {
                let (x, y) = ((i as f64 + 0.5) * cell, (j as f64 + 0.5) * cell);
                if x + y <= h {
                    let f = 1.0 - (x * x + y * y) / (r * r);
                    fine += f * f * cell * cell;
                }
            }
        }
        assert!((exact - fine).abs() < 0.01 * exact, "{exact} vs {fine}");
        // Across the flat kernel's inner sphere, against the same grid.
        let h = 1.2;
        let across = [Vec3::ZERO, Vec3::new(h, 0.0, 0.0), Vec3::new(0.0, h, 0.0)];
        let split = kernel_area(across, r, KernelShape::FlatCentre);
        let (mut fine, cell) = (0.0, h / n as f64);
        for i in 0..n {
            for j in 0..n {
                let (x, y) = ((i as f64 + 0.5) * cell, (j as f64 + 0.5) * cell);
                if x + y <= h {
                    fine += KernelShape::FlatCentre.weight((x * x + y * y) / (r * r)) * cell * cell;
                }
            }
        }
        assert!((split - fine).abs() < 0.01 * split, "{split} vs {fine}");
    }

    #[test]
    fn a_diameter_integrates_the_kernel() {
        // Along a diameter: 2 r * integral over 0..1 of (1 - s^2)^2 = 16 r / 15.
        let r = 2.0;
        let falling = KernelShape::Falling;
        let w = kernel_length(
            Vec3::new(-5.0, 0.0, 0.0),
            Vec3::new(5.0, 0.0, 0.0),
            r,
            falling,
        );
        assert!((w - 16.0 * r / 15.0).abs() < 1e-12, "{w}");
        // Split in two, the halves add up.
        let half = kernel_length(Vec3::new(-5.0, 0.0, 0.0), Vec3::ZERO, r, falling);
        assert!((2.0 * half - w).abs() < 1e-12);
        // A chord at distance h: (1 - h^2/r^2)^2 times the chord's own
        // integral scaled to its half-length.
        let h = 1.0;
        let chord = kernel_length(Vec3::new(-5.0, h, 0.0), Vec3::new(5.0, h, 0.0), r, falling);
        let half_length = (r * r - h * h).sqrt();
        let expected = (1.0 - h * h / (r * r)).powi(2) * 16.0 * half_length / 15.0;
        assert!((chord - expected).abs() < 1e-12, "{chord} {expected}");
        assert_eq!(
            kernel_length(
                Vec3::new(-5.0, 3.0, 0.0),
                Vec3::new(5.0, 3.0, 0.0),
                r,
                falling
            ),
            0.0
        );
        // The flat kernel along a diameter: r (the flat part, 2 * r / 2)
        // plus twice 16/9 times the integral of (1 - s^2)^2 over 1/2..1,
        // which is 8/15 - (1/2 - 1/12 + 1/160) = 53/480: r (1 + 53/135).
        let flat = KernelShape::FlatCentre;
        let d = kernel_length(Vec3::new(-5.0, 0.0, 0.0), Vec3::new(5.0, 0.0, 0.0), r, flat);
        assert!((d - r * (1.0 + 53.0 / 135.0)).abs() < 1e-12, "{d}");
        // A segment ending inside the flat part weighs its length there.
        let inner = kernel_length(Vec3::new(-0.5, 0.2, 0.0), Vec3::new(0.5, 0.2, 0.0), r, flat);
        assert!((inner - 1.0).abs() < 1e-12, "{inner}");
    }
}
