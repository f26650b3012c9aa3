//! A small 3-vector in f64 and an axis-aligned box: just what the pipeline needs,
//! so the core has no linear-algebra dependency.

use std::ops::{Add, AddAssign, Index, Mul, Neg, Sub};

/// A point or direction in 3D, in f64 so that geometric predicates stay exact
/// enough on f32 input.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Vec3 {
    /// x coordinate.
    pub x: f64,
    /// y coordinate.
    pub y: f64,
    /// z coordinate.
    pub z: f64,
}

impl Vec3 {
    /// The origin.
    pub const ZERO: Vec3 = Vec3::new(0.0, 0.0, 0.0);

    /// A vector from its coordinates.
    pub const fn new(x: f64, y: f64, z: f64) -> Vec3 {
        Vec3 { x, y, z }
    }

    /// Widens an f32 triple.
    pub fn from_f32(p: [f32; 3]) -> Vec3 {
        Vec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
    }

    /// The coordinates as an array.
    pub fn to_array(self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }

    /// Dot product.
    pub fn dot(self, o: Vec3) -> f64 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// Cross product.
    pub fn cross(self, o: Vec3) -> Vec3 {
        Vec3::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }

    /// Squared length.
    pub fn norm2(self) -> f64 {
        self.dot(self)
    }

    /// Length.
    pub fn norm(self) -> f64 {
        self.norm2().sqrt()
    }

    /// Distance to another point.
    pub fn dist(self, o: Vec3) -> f64 {
        (self - o).norm()
    }

    /// Componentwise minimum.
    pub fn min(self, o: Vec3) -> Vec3 {
        Vec3::new(self.x.min(o.x), self.y.min(o.y), self.z.min(o.z))
    }

    /// Componentwise maximum.
    pub fn max(self, o: Vec3) -> Vec3 {
        Vec3::new(self.x.max(o.x), self.y.max(o.y), self.z.max(o.z))
    }

    /// The largest coordinate.
    pub fn max_element(self) -> f64 {
        self.x.max(self.y).max(self.z)
    }

    /// Index (0, 1, 2) of the coordinate with the largest magnitude.
    pub fn dominant_axis(self) -> usize {
        let a = [self.x.abs(), self.y.abs(), self.z.abs()];
        if a[0] >= a[1] && a[0] >= a[2] {
            0
        } else if a[1] >= a[2] {
            1
        } else {
            2
        }
    }
}

impl Index<usize> for Vec3 {
    type Output = f64;
    fn index(&self, i: usize) -> &f64 {
        match i {
            0 => &self.x,
            1 => &self.y,
            _ => &self.z,
        }
    }
}

impl Add for Vec3 {
    type Output = Vec3;
    fn add(self, o: Vec3) -> Vec3 {
        Vec3::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl AddAssign for Vec3 {
    fn add_assign(&mut self, o: Vec3) {
        *self = *self + o;
    }
}

impl Sub for Vec3 {
    type Output = Vec3;
    fn sub(self, o: Vec3) -> Vec3 {
        Vec3::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl Neg for Vec3 {
    type Output = Vec3;
    fn neg(self) -> Vec3 {
        Vec3::new(-self.x, -self.y, -self.z)
    }
}

impl Mul<f64> for Vec3 {
    type Output = Vec3;
    fn mul(self, s: f64) -> Vec3 {
        Vec3::new(self.x * s, self.y * s, self.z * s)
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
        d.norm()
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

#[cfg(test)]
mod tests {
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

#[cfg(test)]
mod eigen_tests {
    use super::*;

    #[test]
    fn reconstructs_random_symmetric_matrices() {
        let mut s: u64 = 5;
        let mut rnd = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
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
                assert!((mx - x * vals[i]).norm() < 1e-12, "{m:?}");
                assert!((x.norm() - 1.0).abs() < 1e-12);
            }
            assert!(vecs[0].dot(vecs[1]).abs() < 1e-12);
        }
        // Repeated eigenvalues.
        let (vals, _) = symmetric_eigen([[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1.0]]);
        assert_eq!(vals, [2.0, 2.0, 1.0]);
    }
}
