//! Exact measures of a triangle inside a ball: its area and the lengths of
//! its edges. The curvature descriptor weighs edges by the second and
//! normalizes by the first, so both must be exact rather than counted by
//! vertices (which would depend on the tessellation).

use crate::math::Vec3;

/// What of a triangle lies inside a ball.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClippedTriangle {
    /// Area inside.
    pub area: f64,
    /// Length inside of each edge; edge i joins corners i and i + 1.
    pub edges: [f64; 3],
}

/// The triangle `p` clipped by the ball of radius `r` at `c`, in one pass:
/// the curvature descriptor needs both the area and the edge lengths of
/// every triangle its spheres cut, and both come from where the edges cross
/// the sphere.
///
/// The plane of the triangle cuts the ball in a disk; the area is that of
/// the polygon of the inside corners and the crossings, plus the circular
/// segment beyond each chord that stands for an arc. A short arc's segment
/// comes from its chord by a series (no transcendental: most cuts are by a
/// sphere much larger than the triangle), a long one from its angle.
pub fn clip_triangle_to_ball(p: [Vec3; 3], c: Vec3, r: f64) -> ClippedTriangle {
    let r2 = r * r;
    let q = p.map(|x| x - c);
    let d2 = q.map(|x| x.length_squared());
    let inside = d2.map(|x| x <= r2);
    let mut edges = [0.0; 3];
    // The boundary of triangle ∩ ball, with chords standing for arcs: each
    // point and whether an arc leaves from it (an exit).
    let mut boundary = [(Vec3::ZERO, false); 6];
    let mut len = 0;
    for i in 0..3 {
        let j = (i + 1) % 3;
        let (a, b) = (q[i], q[j]);
        if inside[i] {
            boundary[len] = (a, false);
            len += 1;
        }
        if inside[i] && inside[j] {
            edges[i] = (b - a).length();
            continue;
        }
        let Some(Crossing { t0, t1, length }) = crossing(a, b, d2[i], d2[j], r2) else {
            continue;
        };
        edges[i] = length;
        let (s0, s1) = (t0.clamp(0.0, 1.0), t1.clamp(0.0, 1.0));
        let at = |t: f64| a + (b - a) * t;
        match (inside[i], inside[j]) {
            (true, false) => {
                boundary[len] = (at(s1), true);
                len += 1;
            }
            (false, true) => {
                boundary[len] = (at(s0), false);
                len += 1;
            }
            _ if t0 > 0.0 && t1 < 1.0 => {
                boundary[len] = (at(t0), false);
                boundary[len + 1] = (at(t1), true);
                len += 2;
            }
            _ => {}
        }
    }
    let n = (p[1] - p[0]).cross(p[2] - p[0]);
    let twice_area = n.length();
    if twice_area == 0.0 {
        return ClippedTriangle { area: 0.0, edges };
    }
    let n = n * (1.0 / twice_area);
    if inside.iter().all(|&x| x) {
        return ClippedTriangle {
            area: 0.5 * twice_area,
            edges,
        };
    }
    // The disk: its centre is c + n h, its radius rho.
    let h = n.dot(q[0]);
    let rho2 = r2 - h * h;
    if rho2 <= 0.0 {
        return ClippedTriangle { area: 0.0, edges };
    }
    if len == 0 {
        // No corner inside and no edge crossing: the disk lies wholly
        // inside the triangle or wholly outside it.
        let m = n * h;
        let holds_centre = (0..3).all(|i| n.dot((q[i] - m).cross(q[(i + 1) % 3] - m)) >= 0.0);
        let area = if holds_centre {
            std::f64::consts::PI * rho2
        } else {
            0.0
        };
        return ClippedTriangle { area, edges };
    }
    let mut twice_polygon = 0.0;
    let mut segments = 0.0;
    for i in 0..len {
        let next = if i + 1 == len { 0 } else { i + 1 };
        let ((a, exit), (b, _)) = (boundary[i], boundary[next]);
        let cross = n.dot(a.cross(b));
        twice_polygon += cross;
        if exit {
            // The arc runs counter-clockwise about n from a to the next
            // point (an entry). Seen from the disk's centre, the two are
            // rho^2 (cos, sin) of the arc's angle apart.
            segments += circular_segment(rho2, cross, a.dot(b) - h * h, (a - b).length_squared());
        }
    }
    ClippedTriangle {
        area: 0.5 * twice_polygon + segments,
        edges,
    }
}

/// Length inside the ball of radius sqrt(`r2`) at the origin of the
/// segment `a`-`b`, measured as [`clip_triangle_to_ball`] measures an
/// edge: for a caller that needs the edges and not the area.
pub fn segment_in_ball(a: Vec3, b: Vec3, r2: f64) -> f64 {
    let (a2, b2) = (a.length_squared(), b.length_squared());
    if a2 <= r2 && b2 <= r2 {
        return (b - a).length();
    }
    crossing(a, b, a2, b2, r2).map_or(0.0, |c| c.length)
}

/// Where the line through `a` and `b` (at squared distances `a2`, `b2`
/// from the origin) meets the sphere of squared radius `r2`.
pub(super) struct Crossing {
    /// The roots along a + t (b - a), t0 <= t1.
    pub(super) t0: f64,
    pub(super) t1: f64,
    /// Length of the segment inside the ball (the roots clamped to it).
    length: f64,
}

/// The line's crossing, or `None` where the segment has no inside part of
/// positive length to find (a tangent, a point, a line that misses).
pub(super) fn crossing(a: Vec3, b: Vec3, a2: f64, b2: f64, r2: f64) -> Option<Crossing> {
    // |a + t d|^2 = r^2:  (d.d) t^2 + 2 (a.d) t + (a.a - r^2) = 0. With
    // one end inside the roots straddle it, so disc >= 0 up to rounding.
    let d = b - a;
    let dd = d.length_squared();
    let half_b = a.dot(d);
    let disc = half_b * half_b - dd * (a2 - r2);
    if dd == 0.0 || (disc <= 0.0 && (a2 <= r2) == (b2 <= r2)) {
        return None;
    }
    let root = disc.max(0.0).sqrt();
    let (t0, t1) = ((-half_b - root) / dd, (-half_b + root) / dd);
    let (s0, s1) = (t0.clamp(0.0, 1.0), t1.clamp(0.0, 1.0));
    Some(Crossing {
        t0,
        t1,
        length: (s1 - s0).max(0.0) * dd.sqrt(),
    })
}

/// Area between a chord and its counter-clockwise arc on a circle of
/// squared radius `rho2`, given `sine` and `cosine` of the arc's angle
/// times `rho2` and the squared chord length.
fn circular_segment(rho2: f64, sine: f64, cosine: f64, chord2: f64) -> f64 {
    // sin^2 of half the angle.
    let s2 = chord2 / (4.0 * rho2);
    if sine > 0.0 && cosine > 0.0 && s2 <= SHORT_ARC {
        // angle - sin(angle) = 2 (asin s - s sqrt(1 - s^2)), s the sine of
        // half the angle, and the bracket is the integral of
        // 2 t^2 / sqrt(1 - t^2) from 0 to s: sum of 2 c_k s^(2k+3) / (2k+3),
        // c_k the coefficients of 1 / sqrt(1 - x) (k = 0..8 leaves under
        // 1e-14 of the value).
        let mut sum = 0.0;
        for &coefficient in SEGMENT_SERIES.iter().rev() {
            sum = sum * s2 + coefficient;
        }
        return rho2 * sum * s2 * s2.sqrt();
    }
    let mut angle = sine.atan2(cosine);
    if angle < 0.0 {
        angle += std::f64::consts::TAU;
        if sine.abs() <= 1e-12 * rho2 && cosine > 0.0 {
            // The same point twice (a tangent chord): no arc.
            angle = 0.0;
        }
    }
    0.5 * rho2 * (angle - angle.sin())
}

/// The largest sin^2 of half an arc's angle that the series takes.
const SHORT_ARC: f64 = 0.04;

/// 2 c_k / (2k + 3) for k = 0..8, c_k = (2k)! / (4^k k!^2).
const SEGMENT_SERIES: [f64; 9] = [
    2.0 / 3.0,
    1.0 / 5.0,
    3.0 / 28.0,
    5.0 / 72.0,
    35.0 / 704.0,
    63.0 / 1664.0,
    231.0 / 7680.0,
    429.0 / 17408.0,
    6435.0 / 311296.0,
];

#[cfg(test)]
mod tests {
    use super::*;

    /// Length of the segment `a`-`b` inside the ball of radius `r` at `c`:
    /// the oracle for the clip's edge lengths, solved on its own.
    fn segment_length_in_ball(a: Vec3, b: Vec3, c: Vec3, r: f64) -> f64 {
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

    /// The independent oracle: the area as a sum over the edges of signed
    /// wedge areas (origin, edge) inside the disk.
    fn area_by_wedges(p: [[f64; 2]; 3], r: f64) -> f64 {
        (0..3)
            .map(|i| wedge_area_in_disk(p[i], p[(i + 1) % 3], r))
            .sum::<f64>()
            .abs()
    }

    /// A fixed pseudo-random sequence in [-1, 1).
    fn sequence(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }
    }

    /// Clips the counter-clockwise plane triangle `p` against the disk of
    /// radius `rho` at the origin the way the descriptor meets it: lifted to
    /// the plane at height `h` in a turned frame, cut by the ball of radius
    /// sqrt(rho^2 + h^2) around the point under the disk's centre; compares
    /// the area with the wedge oracle and the edges with the segment clip,
    /// in both windings.
    fn check_against_oracles(p: [[f64; 2]; 3], rho: f64, h: f64, turn: f64) {
        let (s, c) = (turn.sin(), turn.cos());
        // An orthonormal frame (e1, e2, n) tilted by `turn`.
        let e1 = v(c, 0.0, -s);
        let e2 = v(s * s, c, c * s);
        let n = e1.cross(e2);
        let origin = v(0.3, -1.2, 0.7);
        let lift = |q: [f64; 2]| origin + e1 * q[0] + e2 * q[1] + n * h;
        let corners = p.map(lift);
        let radius = (rho * rho + h * h).sqrt();
        let oracle = area_by_wedges(p, rho);
        for winding in [corners, [corners[0], corners[2], corners[1]]] {
            let clip = clip_triangle_to_ball(winding, origin, radius);
            assert!(
                (clip.area - oracle).abs() < 1e-9 * (1.0 + oracle),
                "{p:?} rho {rho} h {h}: {} vs {oracle}",
                clip.area
            );
            for i in 0..3 {
                let (a, b) = (winding[i], winding[(i + 1) % 3]);
                let want = segment_length_in_ball(a, b, origin, radius);
                assert!((clip.edges[i] - want).abs() < 1e-9, "edge {i}");
                // The descriptor's edges-only path measures the same.
                let alone = segment_in_ball(a - origin, b - origin, radius * radius);
                assert_eq!(alone, clip.edges[i], "edge {i} alone");
            }
        }
    }

    /// A counter-clockwise triangle from `next`, scaled and moved, or None
    /// if it is nearly flat.
    fn random_triangle(
        next: &mut impl FnMut() -> f64,
        scale: f64,
        at: [f64; 2],
    ) -> Option<[[f64; 2]; 3]> {
        let mut p = [0; 3].map(|_| [at[0] + scale * next(), at[1] + scale * next()]);
        let turn =
            (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]);
        if turn.abs() < 1e-6 * scale * scale {
            return None;
        }
        if turn < 0.0 {
            p.swap(1, 2);
        }
        Some(p)
    }

    #[test]
    fn large_triangles_agree_with_the_wedges() {
        // Triangles around and across the disk: long arcs, whole disks.
        let mut next = sequence(0x2545_f491_4f6c_dd1d);
        for _ in 0..20_000 {
            let Some(p) = random_triangle(&mut next, 2.0, [0.0, 0.0]) else {
                continue;
            };
            let rho = 0.2 + next().abs() * 0.6;
            check_against_oracles(p, rho, 0.5 * next(), 3.0 * next());
        }
    }

    #[test]
    fn small_triangles_on_the_circle_agree_with_the_wedges() {
        // Triangles much smaller than the disk, across its circle: the
        // short arcs that take the series.
        let mut next = sequence(0x9e37_79b9_7f4a_7c15);
        for _ in 0..20_000 {
            let angle = 3.2 * next();
            let rho = 1.0 + 0.5 * next();
            let at = [rho * angle.cos(), rho * angle.sin()];
            let scale = 0.3 * next().abs().max(1e-3);
            let Some(p) = random_triangle(&mut next, scale, at) else {
                continue;
            };
            check_against_oracles(p, rho, 0.3 * next(), 3.0 * next());
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
        let a = clip_triangle_to_ball(p, v(0.0, 0.0, 0.0), 0.5).area;
        let disk = PI * (0.25 - 0.09);
        assert!((a - disk).abs() < 1e-12, "{a} vs {disk}");
    }

    #[test]
    fn small_triangle_inside_keeps_its_area() {
        let p = [v(0.0, 0.0, 0.0), v(0.2, 0.0, 0.0), v(0.0, 0.1, 0.1)];
        let full = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
        let a = clip_triangle_to_ball(p, v(0.05, 0.02, 0.0), 1.0).area;
        assert!((a - full).abs() < 1e-12);
    }

    #[test]
    fn half_plane_through_the_centre_holds_half_the_disk() {
        // A huge triangle whose edge x = 0 passes through the centre.
        let p = [v(0.0, -50.0, 0.0), v(50.0, 0.0, 0.0), v(0.0, 50.0, 0.0)];
        let a = clip_triangle_to_ball(p, v(0.0, 0.0, 0.0), 1.0).area;
        assert!((a - PI / 2.0).abs() < 1e-9, "{a}");
    }

    #[test]
    fn area_agrees_with_sampling_on_awkward_cuts() {
        // Monte Carlo oracle on a triangle cut by the sphere across two
        // edges and a corner; both orientations give the same area.
        let p = [v(0.0, 0.0, 0.1), v(1.6, 0.2, 0.1), v(0.3, 1.4, 0.1)];
        let (c, r) = (v(0.9, 0.1, -0.2), 0.9);
        let exact = clip_triangle_to_ball(p, c, r).area;
        let flipped = clip_triangle_to_ball([p[0], p[2], p[1]], c, r).area;
        assert!((exact - flipped).abs() < 1e-12);
        let full = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
        let n = 400;
        let mut inside = 0usize;
        let mut total = 0usize;
        for i in 0..n {
            for j in 0..n - i {
                let (s, t) = ((i as f64 + 0.33) / n as f64, (j as f64 + 0.33) / n as f64);
                let q = p[0] + (p[1] - p[0]) * s + (p[2] - p[0]) * t;
                total += 1;
                inside += (q.distance(c) <= r) as usize;
            }
        }
        let sampled = full * inside as f64 / total as f64;
        assert!(
            (exact - sampled).abs() < 0.01 * full,
            "{exact} vs {sampled}"
        );
    }
}
