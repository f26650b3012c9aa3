//! A smooth variant of the curvature layers, measured against the search's
//! (examples/curvature_margin) and not used by it: each edge weighted by
//! w(s) = (1 - s^2)^2, s = |x - c| / r, integrated along the edge, and the
//! tensor divided by the weight's integral over a flat disc (pi r^2 / 3)
//! instead of the neighbourhood's area.
//!
//! Why a candidate: the search's layer jumps as triangles cross the sphere
//! (each brings its full weight in at once) and is divided by an area that
//! jumps with it; here a triangle enters with weight 0 and slope 0, so the
//! value moves continuously with the centre wherever the connected
//! neighbourhood does not change.

use super::neighbourhood::{CurvatureState, full_tensor, gather, gaussian};
use super::surface::Surface;
use crate::math::{Vec3, symmetric_eigen};

/// The smooth layers at vertex `v` for every radius (Gaussian curvature,
/// unscaled).
pub fn kernel_layers_at(surface: &Surface, v: u32, radii: &[f64]) -> Vec<f64> {
    let mut state = CurvatureState::at(surface, v);
    radii
        .iter()
        .map(|&r| {
            let ball = gather(surface, v, r, &mut state);
            let mut tensor = [0.0; 6];
            let triangles = state
                .patches
                .iter()
                .flat_map(|&p| surface.patch_triangles(p))
                .chain(state.region.iter().copied());
            for t in triangles {
                let p = surface.corners(t).map(|q| q - ball.centre);
                let edges = surface.curved_edges(t).iter().filter_map(|e| {
                    let side = e.side as usize;
                    let w = kernel_length(p[side], p[(side + 1) % 3], r);
                    (w > 0.0).then_some((e, w))
                });
                for (sum, x) in tensor.iter_mut().zip(ball.edge_tensor(edges)) {
                    *sum += x;
                }
            }
            let disc = std::f64::consts::PI * r * r / 3.0;
            let (values, _) = symmetric_eigen(full_tensor(tensor).map(|row| row.map(|x| x / disc)));
            gaussian(values)
        })
        .collect()
}

/// The integral of w(|x| / r) = (1 - |x|^2 / r^2)^2 (0 past r) along the
/// segment `a`-`b`, centre at the origin.
pub fn kernel_length(a: Vec3, b: Vec3, r: f64) -> f64 {
    // 1 - |a + t d|^2 / r^2 = c0 + c1 t + c2 t^2, concave: positive on one
    // interval of t, clamped to 0..1.
    let d = b - a;
    let inv = 1.0 / (r * r);
    let (c0, c1, c2) = (
        1.0 - a.length_squared() * inv,
        -2.0 * a.dot(d) * inv,
        -d.length_squared() * inv,
    );
    if c2 >= 0.0 {
        return 0.0;
    }
    let disc = c1 * c1 - 4.0 * c2 * c0;
    if disc <= 0.0 {
        return 0.0;
    }
    let root = disc.sqrt();
    let (lo, hi) = ((-c1 + root) / (2.0 * c2), (-c1 - root) / (2.0 * c2));
    let (lo, hi) = (lo.max(0.0), hi.min(1.0));
    if hi <= lo {
        return 0.0;
    }
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
    use crate::mesh::shapes::uv_sphere;

    #[test]
    fn a_sphere_has_curvature_one_over_r_squared() {
        // The weight's integral over a sphere's cap equals the flat disc's
        // (pi r^2 / 3, Archimedes), so the layers hold the sphere's 1 / R^2.
        let radius = 2.0;
        let s = Surface::new(&uv_sphere(Vec3::ZERO, radius, 96, 192));
        let v = s.nearest_vertex(Vec3::new(radius, 0.0, 0.0)).unwrap();
        for g in kernel_layers_at(&s, v, &[0.3, 0.6, 0.9, 1.2]) {
            let want = 1.0 / (radius * radius);
            assert!((g - want).abs() < 0.03 * want, "{g} vs {want}");
        }
    }

    #[test]
    fn a_diameter_integrates_the_kernel() {
        // Along a diameter: 2 r * integral over 0..1 of (1 - s^2)^2 = 16 r / 15.
        let r = 2.0;
        let w = kernel_length(Vec3::new(-5.0, 0.0, 0.0), Vec3::new(5.0, 0.0, 0.0), r);
        assert!((w - 16.0 * r / 15.0).abs() < 1e-12, "{w}");
        // Split in two, the halves add up.
        let half = kernel_length(Vec3::new(-5.0, 0.0, 0.0), Vec3::ZERO, r);
        assert!((2.0 * half - w).abs() < 1e-12);
        // A chord at distance h: (1 - h^2/r^2)^2 times the chord's own
        // integral scaled to its half-length.
        let h = 1.0;
        let chord = kernel_length(Vec3::new(-5.0, h, 0.0), Vec3::new(5.0, h, 0.0), r);
        let half_length = (r * r - h * h).sqrt();
        let expected = (1.0 - h * h / (r * r)).powi(2) * 16.0 * half_length / 15.0;
        assert!((chord - expected).abs() < 1e-12, "{chord} {expected}");
        assert_eq!(
            kernel_length(Vec3::new(-5.0, 3.0, 0.0), Vec3::new(5.0, 3.0, 0.0), r),
            0.0
        );
    }
}
