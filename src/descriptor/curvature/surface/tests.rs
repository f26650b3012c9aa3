use super::*;
use crate::mesh::shapes::{cuboid, torus, uv_sphere};

#[test]
fn a_cube_has_convex_right_angles_and_flat_diagonals() {
    let s = Surface::new(
        &cuboid(Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 1.0)),
        Threads::Parallel,
    );
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
    let (a, b) = (
        Surface::new(&m, Threads::Parallel),
        Surface::new(&flipped, Threads::Parallel),
    );
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
    let s = Surface::new(&open, Threads::Parallel);
    let zero = (0..s.edges.len() as u32)
        .filter(|&e| s.edge(e).angle == 0.0)
        .count();
    assert_eq!(zero, 3);
}

#[test]
fn neighbours_share_an_edge() {
    let s = Surface::new(&uv_sphere(Vec3::ZERO, 1.0, 8, 16), Threads::Parallel);
    for t in 0..s.triangles().len() as u32 {
        let n = s.neighbours(t);
        assert_eq!(n.len(), 3, "triangle {t}");
    }
}

#[test]
fn patches_are_small_connected_and_cover_every_triangle_once() {
    let s = Surface::new(&uv_sphere(Vec3::ZERO, 1.0, 24, 48), Threads::Parallel);
    let mut seen = vec![0; s.triangles().len()];
    for p in 0..s.patch_count() as u32 {
        let tris: Vec<u32> = s.patch_triangles(p).collect();
        assert!(!tris.is_empty() && tris.len() <= Patches::SIZE);
        // Connected: a walk inside the patch reaches all of it.
        let mut reached = vec![tris[0]];
        let mut i = 0;
        while i < reached.len() {
            for &n in s.neighbours(reached[i]) {
                if s.patch_of(n) == p && !reached.contains(&n) {
                    reached.push(n);
                }
            }
            i += 1;
        }
        assert_eq!(reached.len(), tris.len(), "patch {p}");
        for &t in &tris {
            seen[t as usize] += 1;
            assert_eq!(s.patch_of(t), p);
        }
        let (centre, radius) = s.patch_bounds(p);
        for &t in &tris {
            assert!(
                s.corners(t)
                    .iter()
                    .all(|q| q.distance(centre) <= radius + 1e-12)
            );
        }
        for &b in s.patch_border(p) {
            assert_ne!(s.patch_of(b), p);
        }
    }
    assert!(seen.iter().all(|&n| n == 1));
    let edges: usize = (0..s.patch_count() as u32)
        .map(|p| s.patch_curved_edges(p).len())
        .sum();
    assert_eq!(edges, s.edges.iter().filter(|e| e.angle != 0.0).count());
}

#[test]
fn both_backends_build_the_same_surface() {
    // A triangle soup (every corner its own vertex, so the weld matters),
    // with a fin on one edge (three triangles share it, so no angle) and
    // some triangles wound the other way: every branch of the build, on
    // enough triangles that rayon splits the work.
    let m = torus(Vec3::ZERO, 2.0, 0.7, 80, 40);
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for (i, t) in m.triangles().iter().enumerate() {
        let n = positions.len() as u32;
        positions.extend(t.map(|v| m.positions()[v as usize]));
        triangles.push(if i % 97 == 0 {
            [n, n + 2, n + 1]
        } else {
            [n, n + 1, n + 2]
        });
    }
    let first = m.triangles()[0].map(|v| m.positions()[v as usize]);
    let n = positions.len() as u32;
    positions.extend([first[0], first[1], [0.0, 0.0, 3.0]]);
    triangles.push([n, n + 1, n + 2]);
    let soup = TriMesh::new(positions, triangles).unwrap();
    let (serial, parallel) = (
        Surface::new(&soup, Threads::Serial),
        Surface::new(&soup, Threads::Parallel),
    );
    assert_eq!(serial.vertex_count(), m.positions().len() + 1);
    assert!(serial == parallel);
}
