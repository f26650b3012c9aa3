use super::parity::{edge, for_each_crossing, owned_edge};
use super::*;
use crate::math::ceil;
use crate::mesh::shapes::{cuboid, torus, uv_sphere};

/// The three-axis vote, which needs no closed shell: the oracle for the
/// one-axis fill of closed ones.
fn voted(mesh: &TriMesh, spec: &GridSpec) -> Grid {
    let out = AtomicGrid::new(*spec);
    for shell in shells(mesh, Threads::Serial) {
        let open = Shell {
            closed: false,
            ..shell
        };
        fill_shell(mesh, &open, spec, &out, Threads::Serial, Path::Dense);
    }
    out.into_grid()
}

/// Every shell of `mesh` filled along `path` (as open shells when
/// `open`), into one grid.
fn filled(mesh: &TriMesh, spec: &GridSpec, path: Path, open: bool) -> Grid {
    let out = AtomicGrid::new(*spec);
    for shell in shells(mesh, Threads::Serial) {
        let shell = Shell {
            closed: shell.closed && !open,
            ..shell
        };
        fill_shell(mesh, &shell, spec, &out, Threads::Serial, path);
    }
    out.into_grid()
}

use crate::math::unit_rng as rng;

/// Separate shells that stress the sparse path: tents (two large
/// triangles sharing an edge), thin slivers lying diagonally, tetrahedra,
/// triangles with axis-parallel edges and corners on column centres.
fn awkward_shells(seed: u64) -> TriMesh {
    let mut rnd = rng(seed);
    let mut positions: Vec<[f32; 3]> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let point = |rnd: &mut dyn FnMut() -> f64| [0; 3].map(|_| (rnd() * 40.0) as f32 - 20.0);
    for i in 0..40u32 {
        let n = positions.len() as u32;
        let [a, b, c, d] = [0; 4].map(|_| point(&mut rnd));
        match i % 5 {
            0 => {
                positions.extend([a, b, c, d]);
                triangles.extend([[n, n + 1, n + 2], [n + 1, n, n + 3]]);
            }
            1 => {
                let near = |p: [f32; 3], rnd: &mut dyn FnMut() -> f64| {
                    p.map(|x| x + (rnd() as f32 - 0.5) * 0.4)
                };
                let (c, d) = (near(a, &mut rnd), near(a, &mut rnd));
                positions.extend([a, b, c, d]);
                triangles.extend([[n, n + 1, n + 2], [n + 1, n, n + 3]]);
            }
            2 => {
                positions.extend([a, b, c, d]);
                triangles.extend([
                    [n, n + 1, n + 2],
                    [n, n + 3, n + 1],
                    [n, n + 2, n + 3],
                    [n + 1, n + 3, n + 2],
                ]);
            }
            3 => {
                // Corners on whole and half units (in a grid of voxel
                // 0.5 with its origin on a whole unit: on voxel corners
                // and column centres), edges parallel to the axes.
                let snap = |p: [f32; 3]| p.map(|x| (x * 4.0).round() / 4.0);
                let (a, b) = (snap(a), snap(b));
                let c = [a[0], b[1], a[2]];
                let d = [b[0], a[1], b[2]];
                positions.extend([a, b, c, d]);
                triangles.extend([[n, n + 1, n + 2], [n + 1, n, n + 3]]);
            }
            _ => {
                positions.extend([a, b, c]);
                triangles.push([n, n + 1, n + 2]);
            }
        }
    }
    TriMesh::new(positions, triangles).unwrap()
}

#[test]
fn sorted_crossings_fill_as_the_dense_block() {
    let mut meshes = vec![
        awkward_shells(7),
        awkward_shells(8),
        torus(Vec3::new(0.3, 0.1, 0.0), 0.8, 0.3, 48, 24),
    ];
    let sphere = uv_sphere(Vec3::ZERO, 1.0, 48, 96);
    meshes.push(
        sphere
            .filter_triangles(|t| sphere.corners(t).iter().all(|p| p.z > -0.9 && p.x < 0.95))
            .unwrap(),
    );
    for (i, m) in meshes.iter().enumerate() {
        for res in [37, 96] {
            let spec = GridSpec::for_scene(m.bounds(), res).unwrap();
            for open in [false, true] {
                let dense = filled(m, &spec, Path::Dense, open);
                let sparse = filled(m, &spec, Path::Sparse, open);
                let cheaper = filled(m, &spec, Path::Cheaper, open);
                assert!(dense == sparse, "mesh {i} at {res}, open {open}");
                assert!(dense == cheaper, "mesh {i} at {res}, open {open}");
            }
        }
    }
    // A grid whose origin is a whole unit and whose voxel is 0.5, so that
    // snapped corners fall on voxel corners and column centres.
    let m = awkward_shells(9);
    let spec = GridSpec {
        origin: Vec3::new(-24.0, -24.0, -24.0),
        voxel_size: 0.5,
        dims: [97, 97, 97],
    };
    let b = m.bounds();
    assert!(b.min.x.min(b.min.y).min(b.min.z) > -24.0 && b.max.x.max(b.max.y).max(b.max.z) < 24.0);
    for open in [false, true] {
        let dense = filled(&m, &spec, Path::Dense, open);
        assert!(dense.count_ones() > 0);
        assert!(dense == filled(&m, &spec, Path::Sparse, open));
        assert!(dense == filled(&m, &spec, Path::Cheaper, open));
    }
}

#[test]
fn a_lone_triangle_fills_nothing() {
    let mut rnd = rng(3);
    for _ in 0..200 {
        let p = [0; 3].map(|_| [0; 3].map(|_| rnd() as f32 * 10.0));
        let m = TriMesh::new(p.to_vec(), vec![[0, 1, 2]]).unwrap();
        let spec = GridSpec::for_scene(m.bounds(), 24).unwrap();
        assert_eq!(filled(&m, &spec, Path::Dense, true).count_ones(), 0);
    }
}

/// The crossings of every column of the triangle's bounding box, tested
/// one by one (what `for_each_crossing` finds run by run).
fn scanned_crossings<const AXIS: usize>(tri: &[Vec3; 3], block: &Block) -> Vec<[usize; 3]> {
    let (u, v) = ((AXIS + 1) % 3, (AXIS + 2) % 3);
    let range = |a: usize| {
        let lo = tri[0][a].min(tri[1][a]).min(tri[2][a]);
        let hi = tri[0][a].max(tri[1][a]).max(tri[2][a]);
        let first = ceil(lo - 0.5).max(block.lo[a] as f64);
        let last = floor(hi - 0.5).min(block.hi[a] as f64);
        first as usize..=last as usize
    };
    let (us, vs) = (range(u), range(v));
    if us.is_empty() || vs.is_empty() {
        return Vec::new();
    }
    let mut p = tri.map(|q| [q[u], q[v]]);
    let mut depth = tri.map(|q| q[AXIS]);
    let area2 = edge(p[0], p[1], p[2]);
    if area2 == 0.0 {
        return Vec::new();
    }
    if area2 < 0.0 {
        p.swap(1, 2);
        depth.swap(1, 2);
    }
    let area2 = area2.abs();
    let mut out = Vec::new();
    for cv in vs {
        for cu in us.clone() {
            let c = [cu as f64 + 0.5, cv as f64 + 0.5];
            let w = [
                owned_edge(p[1], p[2], c),
                owned_edge(p[2], p[0], c),
                owned_edge(p[0], p[1], c),
            ];
            let [Some(w0), Some(w1), Some(w2)] = w else {
                continue;
            };
            let d = (w0 * depth[0] + w1 * depth[1] + w2 * depth[2]) / area2;
            let t = floor(d + 0.5).clamp(block.lo[AXIS] as f64, block.hi[AXIS] as f64);
            let mut at = [0; 3];
            at[AXIS] = t as usize;
            at[u] = cu;
            at[v] = cv;
            out.push(at);
        }
    }
    out
}

#[test]
fn rows_of_crossings_are_those_of_the_whole_box() {
    let mut rnd = rng(11);
    let block = Block {
        lo: [0; 3],
        hi: [39; 3],
        first_word: 0,
        words: 1,
        ny: 40,
        nz: 40,
    };
    for i in 0..3000 {
        let mut tri = [0; 3].map(|_| Vec3::new(rnd() * 40.0, rnd() * 40.0, rnd() * 40.0));
        match i % 4 {
            // A sliver: the third corner near the first.
            0 => tri[2] = tri[0] + Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * 0.3,
            // Corners on half units: on column centres and voxel corners.
            1 => {
                tri = tri.map(|q| {
                    Vec3::new(
                        (q.x * 2.0).round() / 2.0,
                        (q.y * 2.0).round() / 2.0,
                        (q.z * 2.0).round() / 2.0,
                    )
                })
            }
            // Nearly degenerate: the third corner almost on the first edge.
            2 => tri[2] = tri[0] + (tri[1] - tri[0]) * rnd() + Vec3::new(1e-9, -1e-9, 1e-9),
            _ => {}
        }
        fn found<const AXIS: usize>(tri: &[Vec3; 3], block: &Block) -> Vec<[usize; 3]> {
            let mut out = Vec::new();
            for_each_crossing::<AXIS>(tri, block, |v| out.push(v));
            out
        }
        assert_eq!(
            found::<0>(&tri, &block),
            scanned_crossings::<0>(&tri, &block),
            "{tri:?}"
        );
        assert_eq!(
            found::<1>(&tri, &block),
            scanned_crossings::<1>(&tri, &block),
            "{tri:?}"
        );
        assert_eq!(
            found::<2>(&tri, &block),
            scanned_crossings::<2>(&tri, &block),
            "{tri:?}"
        );
    }
}

#[test]
fn closed_shells_are_told_from_open_ones_and_fill_alike() {
    let mut m = uv_sphere(Vec3::ZERO, 1.0, 48, 96);
    m.append(&torus(Vec3::new(2.5, 0.0, 0.3), 0.8, 0.3, 48, 24));
    m.append(&cuboid(
        Vec3::new(-1.0, -1.0, -1.6),
        Vec3::new(3.0, 1.0, -1.2),
    ));
    let found = shells(&m, Threads::Serial);
    assert_eq!(found.len(), 3);
    assert!(found.iter().all(|s| s.closed));
    // A sphere with its south cap cut away is open.
    let open = m
        .filter_triangles(|t| m.corners(t).iter().all(|p| p.z > -0.96 || p.z < -1.1))
        .unwrap();
    let found = shells(&open, Threads::Serial);
    assert_eq!(found.iter().filter(|s| !s.closed).count(), 1);
    let spec = GridSpec::for_scene(m.bounds(), 160).unwrap();
    let one_axis = fill_solid(&m, &spec, Threads::Serial);
    assert!(one_axis.count_ones() > 0);
    assert_eq!(one_axis, voted(&m, &spec));
}

/// A height field over the unit square scaled by `size`, `n` cells a side,
/// its triangles facing up (+z).
fn height_field(n: u32, size: f64, h: impl Fn(f64, f64) -> f64) -> TriMesh {
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (size * i as f64 / n as f64, size * j as f64 / n as f64);
            positions.push([x as f32, y as f32, h(x, y) as f32]);
        }
    }
    let mut triangles = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            let (b, c, d) = (a + 1, a + n + 1, a + n + 2);
            triangles.extend([[a, b, d], [a, d, c]]);
        }
    }
    TriMesh::new(positions, triangles).unwrap()
}

#[test]
fn a_shell_facing_one_way_fills_nothing() {
    // Rolling terrain: the three-axis vote calls inside what its horizontal
    // columns find between two slopes, and, where a column enters over the
    // rim, what lies above the ground.
    let h = |x: f64, y: f64| 0.3 * (x * 1.3).sin() * (y * 0.9).cos() + 0.1 * (x * 3.1 + y).sin();
    let terrain = height_field(60, 6.0, h);
    let spec = GridSpec::lattice(terrain.bounds(), 0.04);
    let voted = filled(&terrain, &spec, Path::Dense, true);
    let dims = spec.dims;
    let above = (0..dims[2] as u16)
        .flat_map(|z| {
            (0..dims[1] as u16).flat_map(move |y| (0..dims[0] as u16).map(move |x| [x, y, z]))
        })
        .filter(|v| voted.get(v[0] as i64, v[1] as i64, v[2] as i64))
        .filter(|&v| {
            let c = spec.center(v);
            c.z - h(c.x, c.y) > 2.0 * spec.voxel_size
        })
        .count();
    assert!(
        above > 1000,
        "the vote alone finds {above} voxels above the ground"
    );
    // A shallow bowl (a cap of a sphere), and the same bowl turned over.
    let sphere = uv_sphere(Vec3::ZERO, 1.0, 48, 96);
    let bowl = sphere
        .filter_triangles(|t| sphere.corners(t).iter().all(|p| p.z < -0.3))
        .unwrap();
    let dome = sphere
        .filter_triangles(|t| sphere.corners(t).iter().all(|p| p.z > 0.3))
        .unwrap();
    for (name, m) in [("terrain", &terrain), ("bowl", &bowl), ("dome", &dome)] {
        let found = shells(m, Threads::Serial);
        assert!(found.iter().all(|s| !s.closed && s.one_sided), "{name}");
        let spec = GridSpec::for_scene(m.bounds(), 96).unwrap();
        assert_eq!(
            fill_solid(m, &spec, Threads::Serial).count_ones(),
            0,
            "{name}"
        );
    }
    // More than half a sphere faces every way: its holes are what the vote
    // is for, and it is filled.
    let holed = sphere
        .filter_triangles(|t| sphere.corners(t).iter().all(|p| p.z > -0.5))
        .unwrap();
    let found = shells(&holed, Threads::Serial);
    assert!(found.iter().all(|s| !s.closed && !s.one_sided));
    let spec = GridSpec::for_scene(holed.bounds(), 96).unwrap();
    assert!(fill_solid(&holed, &spec, Threads::Serial).count_ones() > 0);
    // So does a cup (a box without its lid): its walls face four ways.
    let boxed = cuboid(Vec3::splat(-1.0), Vec3::splat(1.0));
    let cup = boxed
        .filter_triangles(|t| boxed.corners(t).iter().any(|p| p.z < 0.5))
        .unwrap();
    let found = shells(&cup, Threads::Serial);
    assert!(found.iter().all(|s| !s.closed && !s.one_sided));
    let spec = GridSpec::for_scene(cup.bounds(), 48).unwrap();
    assert!(fill_solid(&cup, &spec, Threads::Serial).count_ones() > 0);
    // A closed shell never faces one way.
    assert!(
        shells(&sphere, Threads::Serial)
            .iter()
            .all(|s| s.closed && !s.one_sided)
    );
}
