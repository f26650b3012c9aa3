//! Closest point on a triangle (Ericson, Real-Time Collision Detection, 5.1.5).

use crate::math::Vec3;

/// A surface point nearest to a query.
#[derive(Clone, Copy, Debug)]
pub struct ClosestPoint {
    /// The point on the surface.
    pub point: Vec3,
    /// Squared distance from the query.
    pub distance2: f64,
    /// The triangle it lies on.
    pub triangle: usize,
}

/// The point of triangle `abc` nearest to `p`, by Voronoi regions of the
/// corners and edges.
pub fn closest_point_on_triangle(
    p: Vec3,
    a: Vec3,
    b: Vec3,
    c: Vec3,
    triangle: usize,
) -> ClosestPoint {
    let point = closest(p, a, b, c);
    ClosestPoint {
        point,
        distance2: (p - point).length_squared(),
        triangle,
    }
}

fn closest(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

#[cfg(test)]
mod tests {
    use super::*;

    const A: Vec3 = Vec3::new(0.0, 0.0, 0.0);
    const B: Vec3 = Vec3::new(1.0, 0.0, 0.0);
    const C: Vec3 = Vec3::new(0.0, 1.0, 0.0);

    #[test]
    fn regions() {
        let q = |p| closest(p, A, B, C);
        assert!((q(Vec3::new(0.2, 0.2, 5.0)) - Vec3::new(0.2, 0.2, 0.0)).length() < 1e-12);
        assert_eq!(q(Vec3::new(-1.0, -1.0, 0.0)), A);
        assert_eq!(q(Vec3::new(2.0, -0.5, 1.0)), B);
        assert_eq!(q(Vec3::new(-0.5, 3.0, 0.0)), C);
        assert_eq!(q(Vec3::new(0.5, -2.0, 0.0)), Vec3::new(0.5, 0.0, 0.0));
        let on_hyp = q(Vec3::new(1.0, 1.0, 0.0));
        assert!((on_hyp - Vec3::new(0.5, 0.5, 0.0)).length() < 1e-12);
    }
}
