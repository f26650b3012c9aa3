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
