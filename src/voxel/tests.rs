//! Voxelization against analytic and independent oracles.

use super::grid::Rows;
use super::window::WindowedMesh;
use super::*;
use crate::math::{Aabb, Vec3};
use crate::mesh::TriMesh;
use crate::mesh::shapes::{cuboid, torus, uv_sphere};
use std::f64::consts::PI;

fn spec_for(mesh: &TriMesh, resolution: u32) -> GridSpec {
    GridSpec::for_scene(mesh.bounds(), resolution).unwrap()
}

fn volume(g: &Grid) -> f64 {
    g.count_ones() as f64 * g.spec().voxel_size.powi(3)
}

fn rel_err(got: f64, want: f64) -> f64 {
    (got - want).abs() / want
}

#[test]
fn sphere_volume_is_analytic_within_one_percent() {
    let r = 1.0;
    let m = uv_sphere(Vec3::ZERO, r, 128, 256);
    let want = 4.0 / 3.0 * PI * r * r * r;
    for res in [128, 512] {
        let spec = spec_for(&m, res);
        let interior = fill_solid(&m, &spec, Threads::Parallel);
        let solid = voxelize(&m, &spec, Threads::Parallel);
        // Centre sampling is unbiased; the surface voxels add at most a layer.
        assert!(
            rel_err(volume(&interior), want) < 0.01,
            "res {res}: interior {}",
            volume(&interior)
        );
        if res == 512 {
            assert!(
                rel_err(volume(&solid), want) < 0.01,
                "res {res}: solid {}",
                volume(&solid)
            );
        }
    }
}

#[test]
fn cube_volume_is_analytic_within_one_percent() {
    // Rotated, so that faces do not line up with voxel boundaries.
    let (s, c) = (0.3f64.sin(), 0.3f64.cos());
    let m = cuboid(Vec3::new(-0.5, -0.5, -0.5), Vec3::new(0.5, 0.5, 0.5))
        .map_positions(|p| Vec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z))
        .unwrap();
    let want = 1.0;
    let spec = spec_for(&m, 512);
    let solid = volume(&voxelize(&m, &spec, Threads::Parallel));
    let interior = volume(&fill_solid(&m, &spec, Threads::Parallel));
    assert!(rel_err(solid, want) < 0.01, "solid {solid}");
    assert!(rel_err(interior, want) < 0.005, "interior {interior}");
}

#[test]
fn a_sphere_with_a_hole_fills_like_the_closed_one() {
    let m = uv_sphere(Vec3::ZERO, 1.0, 64, 128);
    // Cut away a cap around the south pole: a big hole (about 15 degrees).
    let open = m
        .filter_triangles(|t| m.corners(t).iter().all(|p| p.z > -0.96))
        .unwrap();
    assert!(open.triangles().len() < m.triangles().len());
    let spec = spec_for(&m, 128);
    let closed = fill_solid(&m, &spec, Threads::Serial);
    let holed = fill_solid(&open, &spec, Threads::Serial);
    let differ = closed
        .words()
        .iter()
        .zip(holed.words())
        .map(|(a, b)| (a ^ b).count_ones() as u64)
        .sum::<u64>();
    assert!(
        (differ as f64) < 0.002 * closed.count_ones() as f64,
        "{differ} of {} voxels differ",
        closed.count_ones()
    );
}

#[test]
fn overlapping_shells_fill_their_union() {
    // Two unit spheres whose centres are 1 apart, in one mesh: parity over the
    // whole mesh would empty the lens where they overlap.
    let mut m = uv_sphere(Vec3::ZERO, 1.0, 96, 192);
    m.append(&uv_sphere(Vec3::new(1.0, 0.0, 0.0), 1.0, 96, 192));
    let d: f64 = 1.0;
    let lens = PI * (4.0 + d) * (2.0 - d).powi(2) / 12.0;
    let want = 2.0 * 4.0 / 3.0 * PI - lens;
    let spec = spec_for(&m, 256);
    let got = volume(&fill_solid(&m, &spec, Threads::Parallel));
    assert!(rel_err(got, want) < 0.01, "{got} vs {want}");
}

#[test]
fn orientation_does_not_matter() {
    let m = torus(Vec3::ZERO, 1.0, 0.35, 64, 32);
    let flipped = TriMesh::new(
        m.positions().to_vec(),
        m.triangles()
            .iter()
            .enumerate()
            .map(|(i, t)| if i % 3 == 0 { [t[0], t[2], t[1]] } else { *t })
            .collect(),
    )
    .unwrap();
    let spec = spec_for(&m, 128);
    assert_eq!(
        fill_solid(&m, &spec, Threads::Serial),
        fill_solid(&flipped, &spec, Threads::Serial)
    );
    // The hole of the torus stays empty.
    let centre = spec.to_grid(Vec3::ZERO);
    let g = fill_solid(&m, &spec, Threads::Serial);
    assert!(!g.get(centre.x as i64, centre.y as i64, centre.z as i64));
    let want = 2.0 * PI * PI * 1.0 * 0.35 * 0.35;
    assert!(rel_err(volume(&g), want) < 0.02);
}

#[test]
fn serial_and_parallel_voxelizations_are_identical() {
    let mut m = torus(Vec3::ZERO, 1.0, 0.35, 48, 24);
    m.append(&uv_sphere(Vec3::new(0.5, 0.2, 0.1), 0.6, 32, 64));
    let spec = spec_for(&m, 100);
    assert_eq!(
        voxelize(&m, &spec, Threads::Serial),
        voxelize(&m, &spec, Threads::Parallel)
    );
}

#[test]
fn skin_of_a_box_is_its_outer_layer() {
    // A box covering voxels 1..=10, 1..=6, 1..=4 exactly (centres inside).
    let spec = GridSpec {
        origin: Vec3::ZERO,
        voxel_size: 1.0,
        dims: [12, 8, 6],
    };
    let m = cuboid(Vec3::new(1.2, 1.2, 1.2), Vec3::new(10.8, 6.8, 4.8));
    let solid = fill_solid(&m, &spec, Threads::Serial);
    assert_eq!(solid.count_ones(), 10 * 6 * 4);
    let s = skin(&solid, Threads::Serial);
    assert_eq!(s.count_ones(), 10 * 6 * 4 - 8 * 4 * 2);
    assert!(s.get(1, 1, 1) && !s.get(5, 3, 2));
}

/// Generalized winding number (Jacobson et al. 2013): the solid angle the
/// surface subtends at `p`, over 4 pi. About 1 inside, 0 outside, and a
/// graceful in-between near holes: an oracle independent of any ray casting.
fn winding_number(mesh: &TriMesh, p: Vec3) -> f64 {
    let mut total = 0.0;
    for t in 0..mesh.triangles().len() {
        let [a, b, c] = mesh.corners(t).map(|q| q - p);
        let (la, lb, lc) = (a.length(), b.length(), c.length());
        let num = a.dot(b.cross(c));
        let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
        total += 2.0 * num.atan2(den);
    }
    total / (4.0 * PI)
}

#[test]
fn the_open_bunny_fills_like_its_winding_number() {
    // A real scan, with the holes in its base that make this test.
    let bytes = crate::shared_bytes("models/stanford-bunny.obj");
    let mesh = crate::mesh::io::load(&bytes, Some(crate::Format::Obj))
        .unwrap_or_else(|e| panic!("the shared stanford-bunny.obj does not load: {e}"));
    let spec = spec_for(&mesh, 96);
    let solid = fill_solid(&mesh, &spec, Threads::Parallel);
    let mut state: u64 = 7;
    let (mut agree, mut total) = (0, 0);
    let b: Aabb = mesh.bounds();
    while total < 1500 {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let v = [0, 1, 2].map(|a| ((state >> (20 * a)) % spec.dims[a] as u64) as i64);
        let c = spec.center([v[0] as u16, v[1] as u16, v[2] as u16]);
        if b.distance_to(c) > 0.0 {
            continue;
        }
        // Skip voxels within two voxels of the surface, where any two
        // discretizations may disagree.
        if mesh.closest_point(c).distance2.sqrt() < 2.0 * spec.voxel_size {
            continue;
        }
        total += 1;
        let inside = winding_number(&mesh, c) > 0.5;
        if inside == solid.get(v[0], v[1], v[2]) {
            agree += 1;
        }
    }
    assert!(
        agree as f64 >= 0.99 * total as f64,
        "{agree} of {total} agree"
    );
}

#[test]
fn spaced_skin_keeps_one_voxel_per_cube() {
    use super::spaced;
    // A plane of skin voxels at z = 3 and a few at z = 4, in (z, y, x) order.
    let mut skin = Vec::new();
    for z in 3..5u16 {
        for y in 0..6u16 {
            for x in 0..6u16 {
                if z == 3 || x < 2 {
                    skin.push([x, y, z]);
                }
            }
        }
    }
    assert_eq!(spaced(&skin, 1), (0..skin.len() as u32).collect::<Vec<_>>());
    let kept: Vec<[u16; 3]> = spaced(&skin, 2).iter().map(|&i| skin[i as usize]).collect();
    // z = 3 lies in the cube layer 1 alone; z = 4 in layer 2.
    let mut cubes: Vec<[u16; 3]> = kept.iter().map(|v| v.map(|c| c / 2)).collect();
    cubes.sort();
    cubes.dedup();
    assert_eq!(cubes.len(), kept.len(), "one voxel per cube");
    assert_eq!(kept.iter().filter(|v| v[2] == 3).count(), 9);
    assert_eq!(kept.iter().filter(|v| v[2] == 4).count(), 3);
    // Every skin voxel is within a cube's diagonal of a kept one.
    for v in &skin {
        assert!(
            kept.iter()
                .any(|k| (0..3).all(|i| k[i].abs_diff(v[i]) <= 1))
        );
    }
}

#[test]
fn a_window_holds_the_whole_grids_voxels_off_its_border() {
    // Overlapping shells, an open one (a sphere with a hole: its columns
    // through the hole abstain) and a closed box, cut by windows through
    // every one of them.
    let mut mesh = torus(Vec3::ZERO, 1.0, 0.35, 48, 24);
    let holed = uv_sphere(Vec3::new(0.9, 0.4, 0.2), 0.6, 24, 48);
    let kept: Vec<u32> = (0..holed.triangles().len() as u32)
        .filter(|&t| {
            let c = holed.corners(t as usize);
            (c[0] + c[1] + c[2]).z / 3.0 < 0.65
        })
        .collect();
    mesh.append(&holed.subset(&kept));
    mesh.append(&cuboid(
        Vec3::new(-1.2, -0.3, -0.5),
        Vec3::new(-0.4, 1.3, 0.1),
    ));
    // Off the mesh's box by a fraction of a voxel: the extreme vertices
    // would lie on voxel boundaries, where the two grids' origins round
    // differently.
    let mut whole_spec = spec_for(&mesh, 80);
    whole_spec.origin -= Vec3::splat(0.37 * whole_spec.voxel_size);
    whole_spec.dims = whole_spec.dims.map(|d| d + 1);
    let whole = voxelize(&mesh, &whole_spec, Threads::Parallel);
    let windowed = WindowedMesh::new(mesh.clone(), Threads::Parallel);
    let b = mesh.bounds();
    let boxes = [
        (Vec3::new(-0.2, -0.2, -0.2), Vec3::new(0.3, 0.5, 0.1)),
        (Vec3::new(0.5, 0.0, -0.1), Vec3::new(1.6, 0.9, 0.9)),
        (b.min, Vec3::new(-0.3, 0.1, 0.0)),
        (Vec3::new(-1.0, 0.8, 0.0), b.max),
    ];
    for (lo, hi) in boxes {
        let spec = whole_spec.crop(Aabb { min: lo, max: hi }, 3).unwrap();
        let window = windowed.voxelize(&spec, Threads::Parallel);
        let shift = ((spec.origin - whole_spec.origin) / spec.voxel_size)
            .round()
            .to_array()
            .map(|c| c as i64);
        let [nx, ny, nz] = spec.dims.map(|d| d as i64);
        let (mut compared, mut solid) = (0, 0);
        for z in 1..nz - 1 {
            for y in 1..ny - 1 {
                for x in 1..nx - 1 {
                    let want = whole.get(x + shift[0], y + shift[1], z + shift[2]);
                    assert_eq!(window.get(x, y, z), want, "{x} {y} {z} of {spec:?}");
                    compared += 1;
                    solid += usize::from(want);
                }
            }
        }
        assert!(solid > 100 && solid < compared, "{solid} of {compared}");
    }
}

/// Whether every set voxel of `grid` lies in its rows.
fn set_voxels_in_rows(grid: &Grid) -> bool {
    let rows = grid.rows();
    grid.words().len() == grid.words_per_row() * grid.dims()[1] * grid.dims()[2] + 1
        && (0..grid.dims()[2]).all(|z| {
            (0..grid.dims()[1]).all(|y| rows.holds(y, z) || grid.row(y, z).iter().all(|&w| w == 0))
        })
}

/// `grid` with every row taken as one that may hold set voxels.
fn all_rows(grid: &Grid) -> Grid {
    Grid::from_words(*grid.spec(), grid.words().to_vec())
}

#[test]
fn passes_over_the_rows_that_hold_solid_give_what_passes_over_all_rows_give() {
    // Parts padded as a search pads them (most rows empty), a soup of
    // random triangles, an open sheet and a window that cuts shells: the
    // rows each producer claims hold every set voxel, and the skin, the
    // levels, the counts and the dilation read over them alone equal those
    // read over every row.
    let mut rng = crate::math::unit_rng(0x5eed);
    let mut soup = Vec::new();
    let mut tris = Vec::new();
    for t in 0..40u32 {
        let c = Vec3::new(rng(), rng(), rng()) * 2.0;
        for _ in 0..3 {
            let p = c + Vec3::new(rng(), rng(), rng()) * 0.4;
            soup.push([p.x as f32, p.y as f32, p.z as f32]);
        }
        tris.push([3 * t, 3 * t + 1, 3 * t + 2]);
    }
    let soup = TriMesh::new(soup, tris).unwrap();
    let mut sheet = uv_sphere(Vec3::ZERO, 1.0, 24, 48);
    let upper: Vec<u32> = (0..sheet.triangles().len() as u32)
        .filter(|&t| sheet.corners(t as usize)[0].z > 0.2)
        .collect();
    sheet = sheet.subset(&upper);
    let boxed = cuboid(Vec3::new(0.2, -0.3, 0.1), Vec3::new(0.5, 0.4, 0.3));
    for (name, mesh) in [("soup", soup), ("sheet", sheet), ("box", boxed)] {
        let tight = spec_for(&mesh, 48);
        // Padded by a third of the grid on every side, as a part's grid is.
        let spec = tight.crop(mesh.bounds(), 20).unwrap();
        let solid = voxelize(&mesh, &spec, Threads::Parallel);
        assert!(set_voxels_in_rows(&solid), "{name}");
        let rows = solid.rows();
        assert!(
            !rows.is_empty() && rows != Rows::all(spec.dims),
            "{name}: {rows:?}"
        );
        let full = all_rows(&solid);
        assert_eq!(solid.count_ones(), full.count_ones(), "{name}");
        assert!(solid.iter_ones().eq(full.iter_ones()), "{name}");
        let (skin_rows, skin_all) = (
            skin(&solid, Threads::Parallel),
            skin(&full, Threads::Serial),
        );
        assert!(set_voxels_in_rows(&skin_rows), "{name}");
        assert_eq!(skin_rows.words(), skin_all.words(), "{name}");
        let grown = dilate(&solid, Threads::Parallel);
        assert!(set_voxels_in_rows(&grown), "{name}");
        assert_eq!(
            grown.words(),
            dilate(&full, Threads::Serial).words(),
            "{name}"
        );
        let (limited, every) = (Solid::new(solid), Solid::new(full));
        for level in 1..=3 {
            let (a, b) = (
                limited.level(level, Threads::Parallel),
                every.level(level, Threads::Serial),
            );
            assert_eq!(a.prefix(), b.prefix(), "{name} level {level}");
            assert_eq!(a.occupancy(), b.occupancy(), "{name} level {level}");
        }
    }
    // A window's shells reach past it: its fill's rows hold all it fills.
    let mesh = torus(Vec3::ZERO, 1.0, 0.35, 48, 24);
    let whole = spec_for(&mesh, 64);
    let windowed = WindowedMesh::new(mesh.clone(), Threads::Parallel);
    let spec = whole
        .crop(
            Aabb {
                min: Vec3::new(-0.3, -1.4, -0.5),
                max: Vec3::new(0.3, -0.2, 0.5),
            },
            2,
        )
        .unwrap();
    let window = windowed.voxelize(&spec, Threads::Parallel);
    assert!(window.count_ones() > 0 && set_voxels_in_rows(&window));
}
