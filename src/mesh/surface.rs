//! The connected surface behind a triangle soup: welded vertices, edges with
//! the triangles that share them, and each edge's signed dihedral angle,
//! which the curvature descriptor needs.

use std::collections::HashMap;

use super::{TriMesh, weld_vertices};
use crate::math::Vec3;

/// A welded triangle mesh with edge adjacency.
pub struct Surface {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    /// Edge ids of each triangle: edge i joins corners i and i + 1.
    triangle_edges: Vec<[u32; 3]>,
    /// Per edge: its end vertices and the triangles that use it.
    edges: Vec<Edge>,
    /// Triangles around each vertex (CSR).
    vertex_start: Vec<u32>,
    vertex_triangles: Vec<u32>,
}

/// An edge of the welded mesh.
#[derive(Clone, Copy, Debug)]
pub struct Edge {
    /// End vertices (lower id first).
    pub ends: [u32; 2],
    /// Signed dihedral angle: the turn between the normals of its two
    /// triangles, positive where the surface is convex. Zero on boundary
    /// edges (one triangle) and non-manifold ones (more than two), where no
    /// single angle exists: they add nothing to the curvature.
    pub angle: f64,
    /// Unit normal of the surface along the edge (the mean of its two
    /// triangles' normals; zero where the angle is).
    pub normal: Vec3,
}

impl Surface {
    /// Welds `mesh` (seams in glTF and OBJ split vertices that are one point
    /// of the surface) and builds its adjacency.
    pub fn new(mesh: &TriMesh) -> Surface {
        let (ids, count) = weld_vertices(mesh.positions());
        let mut positions = vec![Vec3::ZERO; count];
        for (i, &id) in ids.iter().enumerate() {
            positions[id as usize] = mesh.vertex(i as u32);
        }
        let triangles: Vec<[u32; 3]> = mesh
            .triangles()
            .iter()
            .map(|t| t.map(|i| ids[i as usize]))
            .filter(|t| t[0] != t[1] && t[1] != t[2] && t[2] != t[0])
            .collect();
        // Directed uses of each undirected edge.
        let mut edge_of: HashMap<[u32; 2], u32> = HashMap::with_capacity(triangles.len() * 2);
        let mut uses: Vec<Vec<(u32, bool)>> = Vec::new();
        let mut triangle_edges = Vec::with_capacity(triangles.len());
        for (ti, t) in triangles.iter().enumerate() {
            let mut te = [0u32; 3];
            for i in 0..3 {
                let (a, b) = (t[i], t[(i + 1) % 3]);
                let key = [a.min(b), a.max(b)];
                let next = uses.len() as u32;
                let e = *edge_of.entry(key).or_insert(next);
                if e == next {
                    uses.push(Vec::new());
                }
                uses[e as usize].push((ti as u32, a < b));
                te[i] = e;
            }
            triangle_edges.push(te);
        }
        let mut keys = vec![[0u32; 2]; uses.len()];
        for (k, &e) in &edge_of {
            keys[e as usize] = *k;
        }
        let normal = |t: &[u32; 3]| {
            let p = t.map(|i| positions[i as usize]);
            (p[1] - p[0]).cross(p[2] - p[0])
        };
        let edges = uses
            .iter()
            .zip(&keys)
            .map(|(u, &ends)| {
                let (angle, normal) = match u.as_slice() {
                    &[(t1, forward1), (t2, forward2)] => {
                        let (tri1, tri2) = (&triangles[t1 as usize], &triangles[t2 as usize]);
                        let (n1, mut n2) = (normal(tri1), normal(tri2));
                        // Consistently oriented neighbours walk the edge in
                        // opposite directions; if not, one is flipped.
                        if forward1 == forward2 {
                            n2 = -n2;
                        }
                        let turn = n1.cross(n2).norm().atan2(n1.dot(n2));
                        // Convex when the far corner of the second triangle
                        // lies below the first one's plane.
                        let far = tri2
                            .iter()
                            .find(|&&v| v != ends[0] && v != ends[1])
                            .expect("a triangle has a corner off each edge");
                        let below =
                            (positions[*far as usize] - positions[ends[0] as usize]).dot(n1);
                        let angle = if below <= 0.0 { turn } else { -turn };
                        let mean = n1 * (1.0 / n1.norm()) + n2 * (1.0 / n2.norm());
                        let len = mean.norm();
                        (
                            angle,
                            if len > 0.0 {
                                mean * (1.0 / len)
                            } else {
                                Vec3::ZERO
                            },
                        )
                    }
                    _ => (0.0, Vec3::ZERO),
                };
                Edge {
                    ends,
                    angle,
                    normal,
                }
            })
            .collect();
        let mut vertex_start = vec![0u32; count + 1];
        for t in &triangles {
            for &v in t {
                vertex_start[v as usize + 1] += 1;
            }
        }
        for i in 0..count {
            vertex_start[i + 1] += vertex_start[i];
        }
        let mut fill = vertex_start.clone();
        let mut vertex_triangles = vec![0u32; vertex_start[count] as usize];
        for (ti, t) in triangles.iter().enumerate() {
            for &v in t {
                vertex_triangles[fill[v as usize] as usize] = ti as u32;
                fill[v as usize] += 1;
            }
        }
        Surface {
            positions,
            triangles,
            triangle_edges,
            edges,
            vertex_start,
            vertex_triangles,
        }
    }

    /// Number of welded vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Position of welded vertex `v`.
    pub fn position(&self, v: u32) -> Vec3 {
        self.positions[v as usize]
    }

    /// The triangles, as welded vertex ids.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Corner positions of triangle `t`.
    pub fn corners(&self, t: u32) -> [Vec3; 3] {
        self.triangles[t as usize].map(|v| self.positions[v as usize])
    }

    /// Edge ids of triangle `t` (edge i joins corners i and i + 1).
    pub fn triangle_edges(&self, t: u32) -> [u32; 3] {
        self.triangle_edges[t as usize]
    }

    /// Edge `e`.
    pub fn edge(&self, e: u32) -> Edge {
        self.edges[e as usize]
    }

    /// Unit normal at vertex `v`: the area-weighted mean of its triangles'
    /// normals (zero if they cancel).
    pub fn vertex_normal(&self, v: u32) -> Vec3 {
        let sum = self.triangles_at(v).iter().fold(Vec3::ZERO, |acc, &t| {
            let p = self.corners(t);
            acc + (p[1] - p[0]).cross(p[2] - p[0])
        });
        let len = sum.norm();
        if len > 0.0 {
            sum * (1.0 / len)
        } else {
            Vec3::ZERO
        }
    }

    /// Triangles using vertex `v`.
    pub fn triangles_at(&self, v: u32) -> &[u32] {
        let (a, b) = (
            self.vertex_start[v as usize],
            self.vertex_start[v as usize + 1],
        );
        &self.vertex_triangles[a as usize..b as usize]
    }

    /// Triangles across the edges of triangle `t` (each neighbour once per
    /// shared edge).
    pub fn neighbours(&self, t: u32) -> impl Iterator<Item = u32> + '_ {
        self.triangle_edges[t as usize]
            .into_iter()
            .flat_map(move |e| {
                let [a, b] = self.edges[e as usize].ends;
                // Triangles sharing edge (a, b): those at a that also use b.
                self.triangles_at(a)
                    .iter()
                    .copied()
                    .filter(move |&u| u != t && self.triangles[u as usize].contains(&b))
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::{cuboid, uv_sphere};

    #[test]
    fn a_cube_has_convex_right_angles_and_flat_diagonals() {
        let s = Surface::new(&cuboid(Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 1.0)));
        assert_eq!(s.vertex_count(), 8);
        let mut right = 0;
        let mut flat = 0;
        for e in 0..s.edges.len() as u32 {
            let a = s.edge(e).angle;
            if (a - std::f64::consts::FRAC_PI_2).abs() < 1e-9 {
                right += 1;
            } else if a.abs() < 1e-9 {
                flat += 1;
            } else {
                panic!("unexpected angle {a}");
            }
        }
        // 12 cube edges, 6 face diagonals.
        assert_eq!((right, flat), (12, 6));
    }

    #[test]
    fn turning_a_mesh_inside_out_flips_every_angle() {
        // Convex is relative to the side the winding calls outside; the
        // Gaussian curvature, a product of two of them, does not care.
        let m = uv_sphere(Vec3::ZERO, 1.0, 8, 16);
        let flipped = TriMesh::new(
            m.positions().to_vec(),
            m.triangles().iter().map(|t| [t[0], t[2], t[1]]).collect(),
        )
        .unwrap();
        let (a, b) = (Surface::new(&m), Surface::new(&flipped));
        let angles = |s: &Surface| {
            let mut v: Vec<([u32; 2], f64)> = s.edges.iter().map(|e| (e.ends, e.angle)).collect();
            v.sort_by_key(|x| x.0);
            v
        };
        for (x, y) in angles(&a).iter().zip(&angles(&b)) {
            assert_eq!(x.0, y.0);
            // Diagonals of the (planar) quads are flat up to rounding.
            assert!(x.1 > -1e-6);
            assert!((x.1 + y.1).abs() < 1e-12);
        }
    }

    #[test]
    fn boundary_edges_have_no_angle() {
        let m = uv_sphere(Vec3::ZERO, 1.0, 8, 16);
        let open = m.filter_triangles(|t| t != 0).unwrap();
        let s = Surface::new(&open);
        let zero = (0..s.edges.len() as u32)
            .filter(|&e| s.edge(e).angle == 0.0)
            .count();
        assert_eq!(zero, 3);
    }

    #[test]
    fn neighbours_share_an_edge() {
        let s = Surface::new(&uv_sphere(Vec3::ZERO, 1.0, 8, 16));
        for t in 0..s.triangles().len() as u32 {
            let n: Vec<u32> = s.neighbours(t).collect();
            assert_eq!(n.len(), 3, "triangle {t}");
        }
    }
}
