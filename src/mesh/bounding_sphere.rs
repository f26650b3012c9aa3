//! Minimal enclosing sphere (Welzl's randomized incremental algorithm).
//!
//! The template centre c_T is defined from the bounding sphere (paper, sec. 5);
//! the minimal one is unique, so c_T does not depend on vertex order.

use crate::math::Vec3;

/// A sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius.
    pub radius: f64,
}

impl Sphere {
    fn contains(&self, p: Vec3, slack: f64) -> bool {
        (p - self.center).length_squared() <= self.radius * self.radius + slack
    }
}

/// The smallest sphere containing every point (expected linear time; the
/// shuffle uses a fixed seed, so the result is deterministic).
///
/// Returns `None` for an empty input.
pub fn minimal_bounding_sphere(points: &[Vec3]) -> Option<Sphere> {
    let first = *points.first()?;
    let mut pts = points.to_vec();
    shuffle(&mut pts);
    // Containment slack relative to the point cloud's scale, so that rounding
    // never makes a boundary point look outside and restarts the recursion.
    let scale = pts
        .iter()
        .map(|p| (*p - first).length_squared())
        .fold(0.0, f64::max);
    let slack = scale * 1e-12;
    let mut s = Sphere {
        center: pts[0],
        radius: 0.0,
    };
    for i in 1..pts.len() {
        if !s.contains(pts[i], slack) {
            s = with_one(&pts[..i], pts[i], slack);
        }
    }
    Some(s)
}

fn with_one(pts: &[Vec3], q: Vec3, slack: f64) -> Sphere {
    let mut s = Sphere {
        center: q,
        radius: 0.0,
    };
    for j in 0..pts.len() {
        if !s.contains(pts[j], slack) {
            s = with_two(&pts[..j], q, pts[j], slack);
        }
    }
    s
}

fn with_two(pts: &[Vec3], q1: Vec3, q2: Vec3, slack: f64) -> Sphere {
    let mut s = diametral(q1, q2);
    for k in 0..pts.len() {
        if !s.contains(pts[k], slack) {
            s = with_three(&pts[..k], q1, q2, pts[k], slack);
        }
    }
    s
}

fn with_three(pts: &[Vec3], q1: Vec3, q2: Vec3, q3: Vec3, slack: f64) -> Sphere {
    let mut s = circumcircle(q1, q2, q3);
    for &p in pts {
        if !s.contains(p, slack) {
            s = circumsphere(q1, q2, q3, p);
        }
    }
    s
}

fn diametral(a: Vec3, b: Vec3) -> Sphere {
    Sphere {
        center: (a + b) * 0.5,
        radius: a.distance(b) * 0.5,
    }
}

/// The smallest sphere through three points (their circumcircle's); the
/// diametral sphere of the farthest pair when they are collinear.
fn circumcircle(a: Vec3, b: Vec3, c: Vec3) -> Sphere {
    let u = b - a;
    let v = c - a;
    let n = u.cross(v);
    let n2 = n.length_squared();
    if n2 <= 1e-24 * (u.length_squared() * v.length_squared()).max(f64::MIN_POSITIVE) {
        return widest_pair(&[a, b, c]);
    }
    let offset = (v.cross(n) * u.length_squared() + n.cross(u) * v.length_squared()) * (0.5 / n2);
    Sphere {
        center: a + offset,
        radius: offset.length(),
    }
}

/// The sphere through four points; the circumcircle of the best three when
/// they are coplanar.
fn circumsphere(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> Sphere {
    let u = b - a;
    let v = c - a;
    let w = d - a;
    let det = u.dot(v.cross(w));
    let scale = u.length() * v.length() * w.length();
    if det.abs() <= 1e-12 * scale.max(f64::MIN_POSITIVE) {
        // Coplanar: the enclosing sphere of the four is one through three of them.
        return [
            circumcircle(a, b, c),
            circumcircle(a, b, d),
            circumcircle(a, c, d),
            circumcircle(b, c, d),
        ]
        .into_iter()
        .filter(|s| {
            [a, b, c, d]
                .iter()
                .all(|&p| s.contains(p, s.radius * s.radius * 1e-9))
        })
        .min_by(|x, y| x.radius.total_cmp(&y.radius))
        .unwrap_or_else(|| widest_pair(&[a, b, c, d]));
    }
    let offset = (v.cross(w) * u.length_squared()
        + w.cross(u) * v.length_squared()
        + u.cross(v) * w.length_squared())
        * (0.5 / det);
    Sphere {
        center: a + offset,
        radius: offset.length(),
    }
}

fn widest_pair(pts: &[Vec3]) -> Sphere {
    let mut best = diametral(pts[0], pts[0]);
    for i in 0..pts.len() {
        for j in i + 1..pts.len() {
            let s = diametral(pts[i], pts[j]);
            if s.radius > best.radius {
                best = s;
            }
        }
    }
    best
}

/// Fisher-Yates with a fixed xorshift seed: random enough for the expected
/// linear time, and reproducible.
fn shuffle(pts: &mut [Vec3]) {
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    for i in (1..pts.len()).rev() {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let j = (state % (i as u64 + 1)) as usize;
        pts.swap(i, j);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_on_a_sphere_give_that_sphere() {
        let c = Vec3::new(1.0, -2.0, 3.0);
        let mut pts = Vec::new();
        for i in 0..40 {
            for j in 0..20 {
                let th = std::f64::consts::PI * (j as f64 + 0.5) / 20.0;
                let ph = std::f64::consts::TAU * i as f64 / 40.0;
                pts.push(c + Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()) * 2.5);
            }
        }
        // interior points must not matter
        pts.extend((0..50).map(|i| c + Vec3::new(0.01 * i as f64, 0.0, 0.0)));
        let s = minimal_bounding_sphere(&pts).unwrap();
        assert!((s.center - c).length() < 1e-6, "{s:?}");
        assert!((s.radius - 2.5).abs() < 1e-6, "{s:?}");
    }

    #[test]
    fn two_points_and_a_segment() {
        let pts = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(4.0, 0.0, 0.0),
            Vec3::new(2.0, 0.5, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
        ];
        let s = minimal_bounding_sphere(&pts).unwrap();
        assert!((s.center - Vec3::new(2.0, 0.0, 0.0)).length() < 1e-9);
        assert!((s.radius - 2.0).abs() < 1e-9);
    }

    #[test]
    fn cube_corners() {
        let mut pts = Vec::new();
        for i in 0..8 {
            pts.push(Vec3::new(
                (i & 1) as f64,
                ((i >> 1) & 1) as f64,
                ((i >> 2) & 1) as f64,
            ));
        }
        let s = minimal_bounding_sphere(&pts).unwrap();
        assert!((s.center - Vec3::new(0.5, 0.5, 0.5)).length() < 1e-9);
        assert!((s.radius - 3f64.sqrt() / 2.0).abs() < 1e-9);
        assert!(pts.iter().all(|p| p.distance(s.center) <= s.radius + 1e-9));
    }

    #[test]
    fn empty_input() {
        assert!(minimal_bounding_sphere(&[]).is_none());
    }
}
