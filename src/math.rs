//! The vector type (glam's f64 `DVec3`: geometric predicates stay exact
//! enough on f32 input), an axis-aligned box, and what glam lacks: a
//! symmetric 3x3 eigen-solver and floor/ceil that compile to one
//! instruction on every target.

/// A point or direction in 3D.
pub use glam::DVec3 as Vec3;

/// Widens an f32 triple (mesh positions are stored as f32).
pub fn from_f32(p: [f32; 3]) -> Vec3 {
    Vec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

/// Index (0, 1, 2) of the coordinate of `v` with the largest magnitude
/// (the first on ties).
pub fn dominant_axis(v: Vec3) -> usize {
    let a = [v.x.abs(), v.y.abs(), v.z.abs()];
    if a[0] >= a[1] && a[0] >= a[2] {
        0
    } else if a[1] >= a[2] {
        1
    } else {
        2
    }
}

/// An axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl Aabb {
    /// The box around a set of points, or `None` for an empty set.
    pub fn around(points: impl IntoIterator<Item = Vec3>) -> Option<Aabb> {
        let mut it = points.into_iter();
        let first = it.next()?;
        Some(it.fold(
            Aabb {
                min: first,
                max: first,
            },
            |b, p| Aabb {
                min: b.min.min(p),
                max: b.max.max(p),
            },
        ))
    }

    /// Side lengths.
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    /// Centre point.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Distance from a point to the box (0 inside).
    pub fn distance_to(&self, p: Vec3) -> f64 {
        let d = (self.min - p).max(p - self.max).max(Vec3::ZERO);
        d.length()
    }

    /// The box around both.
    pub fn union(self, other: Aabb) -> Aabb {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// The distance between the nearest points of two boxes (0 where they
    /// overlap or touch).
    pub fn gap(&self, other: &Aabb) -> f64 {
        (self.min - other.max)
            .max(other.min - self.max)
            .max(Vec3::ZERO)
            .length()
    }

    /// Whether the boxes share a point.
    pub fn overlaps(&self, other: &Aabb) -> bool {
        self.gap(other) == 0.0
    }
}

/// `x.floor()` without a libm call (baseline x86-64 has no rounding
/// instruction and the voxel loops round a lot); exact for |x| < 2^62.
#[inline]
pub fn floor(x: f64) -> f64 {
    let t = x as i64 as f64;
    if t > x { t - 1.0 } else { t }
}

/// `x.ceil()` without a libm call; exact for |x| < 2^62.
#[inline]
pub fn ceil(x: f64) -> f64 {
    let t = x as i64 as f64;
    if t < x { t + 1.0 } else { t }
}

/// The smaller of two numbers that are not NaN. `f64::min` keeps the
/// other operand for a NaN, which WebAssembly's `f64.min` does not, so
/// there it is a library call: several per cent of a search in the voxel
/// loops. Without NaN both give the same.
#[inline]
pub fn min_of(a: f64, b: f64) -> f64 {
    if b < a { b } else { a }
}

/// The larger of two numbers that are not NaN (see [`min_of`]).
#[inline]
pub fn max_of(a: f64, b: f64) -> f64 {
    if b > a { b } else { a }
}

/// [`min_of`] per coordinate.
#[inline]
pub fn min_each(a: Vec3, b: Vec3) -> Vec3 {
    Vec3::new(min_of(a.x, b.x), min_of(a.y, b.y), min_of(a.z, b.z))
}

/// [`max_of`] per coordinate.
#[inline]
pub fn max_each(a: Vec3, b: Vec3) -> Vec3 {
    Vec3::new(max_of(a.x, b.x), max_of(a.y, b.y), max_of(a.z, b.z))
}

#[cfg(test)]
mod tests {
    #[test]
    fn min_of_and_max_of_match_std_without_nan() {
        use super::{max_of, min_of};
        let values = [
            -3.5,
            -0.0,
            0.0,
            1e-300,
            2.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        for a in values {
            for b in values {
                assert_eq!(min_of(a, b), a.min(b), "{a} {b}");
                assert_eq!(max_of(a, b), a.max(b), "{a} {b}");
            }
        }
    }

    #[test]
    fn floor_and_ceil_match_std() {
        for x in [
            -2.5,
            -2.0,
            -0.3,
            -0.0,
            0.0,
            0.3,
            1.0,
            1.5,
            1e9 + 0.5,
            -1e9 - 0.5,
        ] {
            assert_eq!(super::floor(x), x.floor(), "{x}");
            assert_eq!(super::ceil(x), x.ceil(), "{x}");
        }
    }
}

/// A symmetric 3x3 matrix's eigenvalues (descending) and unit eigenvectors
/// (`vectors[i]` belongs to `values[i]`), by cyclic Jacobi rotations: slow
/// next to closed forms but exact to rounding even for repeated eigenvalues.
pub fn symmetric_eigen(m: [[f64; 3]; 3]) -> ([f64; 3], [Vec3; 3]) {
    let mut a = m;
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..64 {
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        let scale = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2] + off;
        if off <= 1e-30 * scale.max(f64::MIN_POSITIVE) {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // a <- J^T a J, v <- v J, with J the rotation in the (p, q) plane.
            for k in 0..3 {
                let (akp, akq) = (a[k][p], a[k][q]);
                a[k][p] = c * akp - s * akq;
                a[k][q] = s * akp + c * akq;
            }
            for k in 0..3 {
                let (apk, aqk) = (a[p][k], a[q][k]);
                a[p][k] = c * apk - s * aqk;
                a[q][k] = s * apk + c * aqk;
            }
            for row in &mut v {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let mut order = [0, 1, 2];
    order.sort_by(|&i, &j| a[j][j].total_cmp(&a[i][i]));
    let values = order.map(|i| a[i][i]);
    let vectors = order.map(|i| Vec3::new(v[0][i], v[1][i], v[2][i]));
    (values, vectors)
}

/// A seeded xorshift source of uniform numbers in [0, 1), for tests that
/// need many reproducible random inputs.
#[cfg(test)]
pub(crate) fn unit_rng(mut s: u64) -> impl FnMut() -> f64 {
    move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[cfg(test)]
mod eigen_tests {
    use super::*;

    #[test]
    fn reconstructs_random_symmetric_matrices() {
        let mut unit = unit_rng(5);
        let mut rnd = || unit() - 0.5;
        for _ in 0..200 {
            let (a, b, c, d, e, f) = (rnd(), rnd(), rnd(), rnd(), rnd(), rnd());
            let m = [[a, b, c], [b, d, e], [c, e, f]];
            let (vals, vecs) = symmetric_eigen(m);
            assert!(vals[0] >= vals[1] && vals[1] >= vals[2]);
            for i in 0..3 {
                let x = vecs[i];
                let mx = Vec3::new(
                    m[0][0] * x.x + m[0][1] * x.y + m[0][2] * x.z,
                    m[1][0] * x.x + m[1][1] * x.y + m[1][2] * x.z,
                    m[2][0] * x.x + m[2][1] * x.y + m[2][2] * x.z,
                );
                assert!((mx - x * vals[i]).length() < 1e-12, "{m:?}");
                assert!((x.length() - 1.0).abs() < 1e-12);
            }
            assert!(vecs[0].dot(vecs[1]).abs() < 1e-12);
        }
        // Repeated eigenvalues.
        let (vals, _) = symmetric_eigen([[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1.0]]);
        assert_eq!(vals, [2.0, 2.0, 1.0]);
    }
}
