//! Exact measures of mesh pieces inside a ball: the length of a segment and
//! the area of a triangle. The curvature descriptor weighs edges by the
//! first and normalizes by the second, so both must be exact rather than
//! counted by vertices (which would depend on the tessellation).

use crate::math::Vec3;

/// Length of the segment `a`-`b` inside the ball of radius `r` at `c`.
pub fn segment_length_in_ball(a: Vec3, b: Vec3, c: Vec3, r: f64) -> f64 {
    // |a + t d - c|^2 = r^2:  (d.d) t^2 + 2 (d.f) t + (f.f - r^2) = 0.
    let d = b - a;
    let f = a - c;
    let dd = d.dot(d);
    if dd == 0.0 {
        return 0.0;
    }
    let half_b = d.dot(f);
    let disc = half_b * half_b - dd * (f.dot(f) - r * r);
    if disc <= 0.0 {
        return 0.0;
    }
    let root = disc.sqrt();
    let t0 = ((-half_b - root) / dd).max(0.0);
    let t1 = ((-half_b + root) / dd).min(1.0);
    (t1 - t0).max(0.0) * dd.sqrt()
}

/// Area of the triangle `p` inside the ball of radius `r` at `c`: the plane
/// of the triangle cuts the ball in a disk, and the area is that of the
/// triangle and the disk: the polygon of the inside corners and the points
/// where the edges cross the circle, plus the circular segment beyond each
/// chord that stands for an arc (one transcendental per arc, usually one
/// per triangle: the curvature descriptor clips every triangle its spheres
/// cut).
pub fn triangle_area_in_ball(p: [Vec3; 3], c: Vec3, r: f64) -> f64 {
    let n = (p[1] - p[0]).cross(p[2] - p[0]);
    let area2 = n.norm();
    if area2 == 0.0 {
        return 0.0;
    }
    let n = n * (1.0 / area2);
    let h = (c - p[0]).dot(n);
    let rho2 = r * r - h * h;
    if rho2 <= 0.0 {
        return 0.0;
    }
    let rho = rho2.sqrt();
    let centre = c - n * h;
    let e1 = (p[1] - p[0]) * (1.0 / (p[1] - p[0]).norm());
    let e2 = n.cross(e1);
    let flat = p.map(|q| {
        let v = q - centre;
        [v.dot(e1), v.dot(e2)]
    });
    triangle_area_in_disk(flat, rho)
}

/// Area of the counter-clockwise triangle `p` inside the disk of radius
/// `r` at the origin.
fn triangle_area_in_disk(p: [[f64; 2]; 3], r: f64) -> f64 {
    let r2 = r * r;
    let norm2 = |u: [f64; 2]| u[0] * u[0] + u[1] * u[1];
    let cross = |u: [f64; 2], v: [f64; 2]| u[0] * v[1] - u[1] * v[0];
    let inside = p.map(|q| norm2(q) <= r2);
    if inside.iter().all(|&x| x) {
        return 0.5 * (cross(p[0], p[1]) + cross(p[1], p[2]) + cross(p[2], p[0]));
    }
    // The boundary of triangle ∩ disk, with the chords standing for arcs:
    // each point and whether an arc leaves from it (an exit).
    let mut boundary: [([f64; 2], bool); 9] = [([0.0; 2], false); 9];
    let mut len = 0;
    for i in 0..3 {
        let (a, b) = (p[i], p[(i + 1) % 3]);
        if inside[i] {
            boundary[len] = (a, false);
            len += 1;
        }
        let d = [b[0] - a[0], b[1] - a[1]];
        let dd = norm2(d);
        let half_b = a[0] * d[0] + a[1] * d[1];
        let disc = half_b * half_b - dd * (norm2(a) - r2);
        if dd == 0.0 || disc <= 0.0 {
            continue;
        }
        let root = disc.sqrt();
        let (t0, t1) = ((-half_b - root) / dd, (-half_b + root) / dd);
        let at = |t: f64| [a[0] + t * d[0], a[1] + t * d[1]];
        let b_inside = inside[(i + 1) % 3];
        match (inside[i], b_inside) {
            (true, false) => {
                boundary[len] = (at(t1.clamp(0.0, 1.0)), true);
                len += 1;
            }
            (false, true) => {
                boundary[len] = (at(t0.clamp(0.0, 1.0)), false);
                len += 1;
            }
            (false, false) if t0 > 0.0 && t1 < 1.0 => {
                boundary[len] = (at(t0), false);
                boundary[len + 1] = (at(t1), true);
                len += 2;
            }
            _ => {}
        }
    }
    if len == 0 {
        // No corner inside and no edge crossing: the disk lies wholly
        // inside the triangle or wholly outside it.
        let holds_centre = (0..3).all(|i| cross(p[i], p[(i + 1) % 3]) >= 0.0);
        return if holds_centre {
            std::f64::consts::PI * r2
        } else {
            0.0
        };
    }
    let mut area = 0.0;
    for i in 0..len {
        let ((a, exit), (b, _)) = (boundary[i], boundary[(i + 1) % len]);
        area += 0.5 * cross(a, b);
        if exit {
            // The arc runs counter-clockwise from here to the next point
            // (an entry); its segment lies beyond the chord.
            let sine = cross(a, b);
            let cosine = a[0] * b[0] + a[1] * b[1];
            let mut angle = sine.atan2(cosine);
            if angle < 0.0 {
                angle += std::f64::consts::TAU;
                if sine.abs() <= 1e-12 * r2 && cosine > 0.0 {
                    // The same point twice (a tangent chord): no arc.
                    angle = 0.0;
                }
            }
            area += 0.5 * r2 * (angle - angle.sin());
        }
    }
    area
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The independent oracle: the area as a sum over the edges of signed
    /// wedge areas (origin, edge) inside the disk.
    fn area_by_wedges(p: [[f64; 2]; 3], r: f64) -> f64 {
        (0..3)
            .map(|i| wedge_area_in_disk(p[i], p[(i + 1) % 3], r))
            .sum::<f64>()
            .abs()
    }

    #[test]
    fn the_polygon_and_the_wedges_agree() {
        // A fixed pseudo-random sweep of triangles around and across a disk.
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 4.0 - 2.0
        };
        for _ in 0..20_000 {
            let mut p = [[next(), next()], [next(), next()], [next(), next()]];
            let turn = (p[1][0] - p[0][0]) * (p[2][1] - p[0][1])
                - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]);
            if turn.abs() < 1e-6 {
                continue;
            }
            if turn < 0.0 {
                p.swap(1, 2);
            }
            let r = 0.2 + next().abs() * 0.6;
            let (fast, oracle) = (triangle_area_in_disk(p, r), area_by_wedges(p, r));
            assert!(
                (fast - oracle).abs() < 1e-9,
                "{p:?} r {r}: {fast} vs {oracle}"
            );
        }
    }

    /// Signed area of the triangle (origin, a, b) inside the disk of radius `r`
    /// at the origin (positive when a -> b turns counter-clockwise).
    fn wedge_area_in_disk(a: [f64; 2], b: [f64; 2], r: f64) -> f64 {
        let cross = |u: [f64; 2], v: [f64; 2]| u[0] * v[1] - u[1] * v[0];
        let dot = |u: [f64; 2], v: [f64; 2]| u[0] * v[0] + u[1] * v[1];
        let sector = |u: [f64; 2], v: [f64; 2]| 0.5 * r * r * cross(u, v).atan2(dot(u, v));
        let r2 = r * r;
        let (a_in, b_in) = (dot(a, a) <= r2, dot(b, b) <= r2);
        if a_in && b_in {
            return 0.5 * cross(a, b);
        }
        // Where the segment a + t (b - a) meets the circle.
        let d = [b[0] - a[0], b[1] - a[1]];
        let dd = dot(d, d);
        let half_b = dot(a, d);
        let disc = half_b * half_b - dd * (dot(a, a) - r2);
        let at = |t: f64| [a[0] + t * d[0], a[1] + t * d[1]];
        if dd == 0.0 || disc <= 0.0 {
            return sector(a, b);
        }
        let root = disc.sqrt();
        let (t0, t1) = ((-half_b - root) / dd, (-half_b + root) / dd);
        match (a_in, b_in) {
            (true, false) => {
                let q = at(t1.clamp(0.0, 1.0));
                0.5 * cross(a, q) + sector(q, b)
            }
            (false, true) => {
                let q = at(t0.clamp(0.0, 1.0));
                sector(a, q) + 0.5 * cross(q, b)
            }
            _ => {
                if t0 >= 1.0 || t1 <= 0.0 || t0 < 0.0 && t1 > 1.0 {
                    // The segment misses the disk (both ends are outside, so
                    // t0 < 0 < 1 < t1 cannot happen; kept for robustness).
                    sector(a, b)
                } else {
                    let (q0, q1) = (at(t0), at(t1));
                    sector(a, q0) + 0.5 * cross(q0, q1) + sector(q1, b)
                }
            }
        }
    }

    use std::f64::consts::PI;

    fn v(x: f64, y: f64, z: f64) -> Vec3 {
        Vec3::new(x, y, z)
    }

    #[test]
    fn segment_through_the_centre_is_a_diameter() {
        let l = segment_length_in_ball(v(-5.0, 0.0, 0.0), v(5.0, 0.0, 0.0), v(0.0, 0.0, 0.0), 2.0);
        assert!((l - 4.0).abs() < 1e-12);
    }

    #[test]
    fn segment_partly_inside_and_outside() {
        // From the centre outwards: only r of it is inside.
        let l = segment_length_in_ball(v(0.0, 0.0, 0.0), v(0.0, 3.0, 0.0), v(0.0, 0.0, 0.0), 1.5);
        assert!((l - 1.5).abs() < 1e-12);
        // A chord at distance 0.6 from the centre of a unit ball.
        let l = segment_length_in_ball(v(-2.0, 0.6, 0.0), v(2.0, 0.6, 0.0), v(0.0, 0.0, 0.0), 1.0);
        assert!((l - 1.6).abs() < 1e-12);
        // Wholly inside, and wholly outside.
        let l = segment_length_in_ball(v(0.1, 0.0, 0.0), v(0.3, 0.0, 0.0), v(0.0, 0.0, 0.0), 1.0);
        assert!((l - 0.2).abs() < 1e-12);
        let l = segment_length_in_ball(v(2.0, 0.0, 0.0), v(3.0, 0.0, 0.0), v(0.0, 0.0, 0.0), 1.0);
        assert_eq!(l, 0.0);
    }

    #[test]
    fn segment_pointing_away_from_the_ball_has_nothing_inside() {
        // The line passes through the ball, the segment does not.
        let l = segment_length_in_ball(v(2.0, 0.0, 0.0), v(5.0, 0.0, 0.0), v(0.0, 0.0, 0.0), 1.0);
        assert_eq!(l, 0.0);
    }

    #[test]
    fn big_triangle_around_the_centre_holds_the_whole_disk() {
        let p = [v(-10.0, -10.0, 0.3), v(10.0, -10.0, 0.3), v(0.0, 10.0, 0.3)];
        let a = triangle_area_in_ball(p, v(0.0, 0.0, 0.0), 0.5);
        let disk = PI * (0.25 - 0.09);
        assert!((a - disk).abs() < 1e-12, "{a} vs {disk}");
    }

    #[test]
    fn small_triangle_inside_keeps_its_area() {
        let p = [v(0.0, 0.0, 0.0), v(0.2, 0.0, 0.0), v(0.0, 0.1, 0.1)];
        let full = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).norm();
        let a = triangle_area_in_ball(p, v(0.05, 0.02, 0.0), 1.0);
        assert!((a - full).abs() < 1e-12);
    }

    #[test]
    fn half_plane_through_the_centre_holds_half_the_disk() {
        // A huge triangle whose edge x = 0 passes through the centre.
        let p = [v(0.0, -50.0, 0.0), v(50.0, 0.0, 0.0), v(0.0, 50.0, 0.0)];
        let a = triangle_area_in_ball(p, v(0.0, 0.0, 0.0), 1.0);
        assert!((a - PI / 2.0).abs() < 1e-9, "{a}");
    }

    #[test]
    fn area_agrees_with_sampling_on_awkward_cuts() {
        // Monte Carlo oracle on a triangle cut by the sphere across two
        // edges and a corner; both orientations give the same area.
        let p = [v(0.0, 0.0, 0.1), v(1.6, 0.2, 0.1), v(0.3, 1.4, 0.1)];
        let (c, r) = (v(0.9, 0.1, -0.2), 0.9);
        let exact = triangle_area_in_ball(p, c, r);
        let flipped = triangle_area_in_ball([p[0], p[2], p[1]], c, r);
        assert!((exact - flipped).abs() < 1e-12);
        let full = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).norm();
        let n = 400;
        let mut inside = 0usize;
        let mut total = 0usize;
        for i in 0..n {
            for j in 0..n - i {
                let (s, t) = ((i as f64 + 0.33) / n as f64, (j as f64 + 0.33) / n as f64);
                let q = p[0] + (p[1] - p[0]) * s + (p[2] - p[0]) * t;
                total += 1;
                inside += (q.dist(c) <= r) as usize;
            }
        }
        let sampled = full * inside as f64 / total as f64;
        assert!(
            (exact - sampled).abs() < 0.01 * full,
            "{exact} vs {sampled}"
        );
    }
}
