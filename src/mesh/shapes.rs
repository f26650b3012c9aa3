//! Simple closed meshes built in code: analytic oracles for the tests, and
//! the parts of the embedded demo scene.

use super::TriMesh;
use crate::math::Vec3;
use std::f64::consts::{PI, TAU};

/// A latitude-longitude sphere with `rings` bands and `segments` sectors,
/// outward-facing, watertight (the poles are single vertices).
pub fn uv_sphere(center: Vec3, radius: f64, rings: usize, segments: usize) -> TriMesh {
    let (rings, segments) = (rings.max(2), segments.max(3));
    let mut p = vec![center + Vec3::new(0.0, 0.0, radius)];
    for i in 1..rings {
        let th = PI * i as f64 / rings as f64;
        for j in 0..segments {
            let ph = TAU * j as f64 / segments as f64;
            p.push(center + Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()) * radius);
        }
    }
    p.push(center - Vec3::new(0.0, 0.0, radius));
    let south = (p.len() - 1) as u32;
    let at = |i: usize, j: usize| (1 + (i - 1) * segments + j % segments) as u32;
    let mut t = Vec::new();
    for j in 0..segments {
        t.push([0, at(1, j), at(1, j + 1)]);
        t.push([south, at(rings - 1, j + 1), at(rings - 1, j)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            t.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            t.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    build(p, t)
}

/// An axis-aligned box, outward-facing, 12 triangles.
pub fn cuboid(min: Vec3, max: Vec3) -> TriMesh {
    let p: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { min.x } else { max.x },
                if i & 2 == 0 { min.y } else { max.y },
                if i & 4 == 0 { min.z } else { max.z },
            )
        })
        .collect();
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let t = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    build(p, t)
}

/// A torus around the z axis: tube radius `minor` at distance `major`.
pub fn torus(center: Vec3, major: f64, minor: f64, n_major: usize, n_minor: usize) -> TriMesh {
    let mut p = Vec::new();
    for i in 0..n_major {
        let a = TAU * i as f64 / n_major as f64;
        for j in 0..n_minor {
            let b = TAU * j as f64 / n_minor as f64;
            let r = major + minor * b.cos();
            p.push(center + Vec3::new(r * a.cos(), r * a.sin(), minor * b.sin()));
        }
    }
    let at = |i: usize, j: usize| ((i % n_major) * n_minor + j % n_minor) as u32;
    let mut t = Vec::new();
    for i in 0..n_major {
        for j in 0..n_minor {
            t.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            t.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    build(p, t)
}

fn build(p: Vec<Vec3>, t: Vec<[u32; 3]>) -> TriMesh {
    let p = p
        .into_iter()
        .map(|v| [v.x as f32, v.y as f32, v.z as f32])
        .collect();
    TriMesh::new(p, t).expect("generated shapes are valid")
}
