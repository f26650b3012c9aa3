use super::*;
use crate::exec::Threads;
use crate::math::Vec3;
use crate::mesh::TriMesh;
use crate::mesh::shapes::uv_sphere;

fn nearest_vertex(s: &Surface, p: Vec3) -> u32 {
    (0..s.vertex_count() as u32)
        .min_by(|&a, &b| {
            s.position(a)
                .distance(p)
                .total_cmp(&s.position(b).distance(p))
        })
        .unwrap()
}

/// A square grid of `n` x `n` cells over [-1, 1]^2, lifted by `height`.
fn height_field(n: usize, height: impl Fn(f64, f64) -> f64) -> TriMesh {
    let mut p = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (
                2.0 * i as f64 / n as f64 - 1.0,
                2.0 * j as f64 / n as f64 - 1.0,
            );
            p.push([x as f32, y as f32, height(x, y) as f32]);
        }
    }
    let at = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let mut t = Vec::new();
    for j in 0..n {
        for i in 0..n {
            t.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            t.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    TriMesh::new(p, t).unwrap()
}

#[test]
fn a_sphere_has_curvature_one_over_r_squared_at_every_radius() {
    let radius = 2.0;
    let s = Surface::new(&uv_sphere(Vec3::ZERO, radius, 96, 192), Threads::Parallel);
    // Away from the poles, where the tessellation is most regular.
    let v = nearest_vertex(&s, Vec3::new(radius, 0.0, 0.0));
    let radii = [0.3, 0.6, 0.9, 1.2];
    for g in CurvatureDescriptor::describe(&s, v, &radii) {
        let want = 1.0 / (radius * radius);
        assert!((g - want).abs() < 0.03 * want, "{g} vs {want}");
    }
}

#[test]
fn a_plane_has_none() {
    let s = Surface::new(&height_field(40, |_, _| 0.0), Threads::Parallel);
    let v = nearest_vertex(&s, Vec3::ZERO);
    for g in CurvatureDescriptor::describe(&s, v, &[0.2, 0.4, 0.6]) {
        assert!(g.abs() < 1e-9, "{g}");
    }
}

#[test]
fn a_cylinder_has_about_none() {
    // z = sqrt(R^2 - x^2): curved across x only.
    let s = Surface::new(
        &height_field(80, |x, _| (4.0 - x * x).sqrt()),
        Threads::Parallel,
    );
    let v = nearest_vertex(&s, Vec3::new(0.0, 0.0, 2.0));
    for g in CurvatureDescriptor::describe(&s, v, &[0.2, 0.4, 0.6]) {
        // Next to the sphere's 1 / R^2 = 0.25.
        assert!(g.abs() < 0.01, "{g}");
    }
}

#[test]
fn a_saddle_is_negative() {
    // z = (x^2 - y^2) / 2: K = -1 at the origin.
    let s = Surface::new(
        &height_field(80, |x, y| 0.5 * (x * x - y * y)),
        Threads::Parallel,
    );
    let v = nearest_vertex(&s, Vec3::ZERO);
    let g = CurvatureDescriptor::describe(&s, v, &[0.2]);
    assert!(g[0] < -0.7 && g[0] > -1.3, "{g:?}");
}

#[test]
fn rotation_and_reindexing_change_nothing() {
    let m = uv_sphere(Vec3::ZERO, 1.0, 24, 48);
    // Squash it so the curvature varies, then rotate and reverse the
    // triangle order.
    let squashed = m
        .map_positions(|p| Vec3::new(p.x, 0.7 * p.y, 0.5 * p.z + 0.2 * p.x * p.x))
        .unwrap();
    let (s, c) = (0.6f64.sin(), 0.6f64.cos());
    let turned = squashed
        .map_positions(|p| Vec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z))
        .unwrap();
    let reordered = TriMesh::new(
        turned.positions().to_vec(),
        turned.triangles().iter().rev().copied().collect(),
    )
    .unwrap();
    let (a, b) = (
        Surface::new(&squashed, Threads::Parallel),
        Surface::new(&reordered, Threads::Parallel),
    );
    let radii = [0.15, 0.3, 0.45];
    for v in [0u32, 100, 300, 700] {
        let p = a.position(v);
        let q = Vec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z);
        let w = nearest_vertex(&b, q);
        let ga = CurvatureDescriptor::describe(&a, v, &radii);
        let gb = CurvatureDescriptor::describe(&b, w, &radii);
        for (x, y) in ga.iter().zip(&gb) {
            assert!((x - y).abs() < 1e-4 * (1.0 + x.abs()), "{ga:?} vs {gb:?}");
        }
    }
}

#[test]
fn retessellation_changes_little() {
    let want = 1.0;
    let coarse = Surface::new(&uv_sphere(Vec3::ZERO, 1.0, 48, 96), Threads::Parallel);
    let fine = Surface::new(&uv_sphere(Vec3::ZERO, 1.0, 96, 160), Threads::Parallel);
    let radii = [0.3, 0.5];
    for s in [&coarse, &fine] {
        let v = nearest_vertex(s, Vec3::new(0.0, 1.0, 0.0));
        for g in CurvatureDescriptor::describe(s, v, &radii) {
            assert!((g - want).abs() < 0.05, "{g}");
        }
    }
}

#[test]
fn layers_grow_the_same_neighbourhood_as_a_fresh_gather() {
    let s = Surface::new(&uv_sphere(Vec3::ZERO, 1.0, 32, 64), Threads::Parallel);
    let v = nearest_vertex(&s, Vec3::new(1.0, 0.0, 0.0));
    let radii = [0.2, 0.4, 0.8];
    let incremental = CurvatureDescriptor::describe(&s, v, &radii);
    for (i, &r) in radii.iter().enumerate() {
        let fresh = CurvatureDescriptor::describe(&s, v, &[r]);
        assert!((fresh[0] - incremental[i]).abs() < 1e-12);
    }
}

#[test]
fn a_separate_sheet_inside_the_ball_is_ignored() {
    let plane = height_field(40, |_, _| 0.0);
    let mut both = plane.clone();
    both.append(&uv_sphere(Vec3::new(0.0, 0.0, 0.35), 0.2, 16, 32));
    let (a, b) = (
        Surface::new(&plane, Threads::Parallel),
        Surface::new(&both, Threads::Parallel),
    );
    let v = nearest_vertex(&a, Vec3::ZERO);
    assert_eq!(
        CurvatureDescriptor::describe(&a, v, &[0.6]),
        CurvatureDescriptor::describe(&b, v, &[0.6])
    );
}

/// A surface with curvature of both signs and many sizes.
fn bumpy() -> Surface {
    Surface::new(
        &height_field(60, |x, y| {
            0.3 * (3.0 * x).sin() * (2.0 * y).cos() + 0.2 * x * y
        }),
        Threads::Parallel,
    )
}

#[test]
fn the_bounds_hold_the_exact_curvature() {
    let s = bumpy();
    let radii = [0.1, 0.25, 0.4, 0.6];
    let (mut checked, mut narrow) = (0, 0);
    for v in (0..s.vertex_count() as u32).step_by(7) {
        let mut state = CurvatureState::at(&s, v);
        for &r in &radii {
            let ball = gather(&s, v, r, &mut state);
            let (sums, cut_area) = add_cut_edges(&s, &ball, &state);
            let (low, high) = gaussian_bounds(sums.tensor, sums.area, sums.area + cut_area);
            let clipped: f64 = state
                .cut
                .iter()
                .map(|&t| clip_triangle_to_ball(s.corners(t), ball.centre, r).area)
                .sum();
            let g = add_cut_areas(&s, &ball, &state, sums).gaussian;
            assert!(
                low <= g && g <= high,
                "vertex {v} r {r}: {g} not in {low}..{high}"
            );
            // With the area known the interval closes on the value.
            let area = sums.area + clipped;
            let (at_low, at_high) = gaussian_bounds(sums.tensor, area, area);
            assert!(at_low <= g && g <= at_high, "vertex {v} r {r}");
            assert!(
                at_high - at_low <= 1e-6 * (1.0 + g.abs()),
                "vertex {v} r {r}"
            );
            checked += 1;
            narrow += usize::from(high - low < 0.5 * (1.0 + g.abs()));
        }
    }
    // Useful as well as safe: most intervals are narrow.
    assert!(narrow * 2 > checked, "{narrow} of {checked} narrow");
}

#[test]
fn rejecting_by_the_bounds_keeps_what_the_exact_values_keep() {
    let s = bumpy();
    let radii = [0.1, 0.2, 0.3];
    let scale = radii[2] * radii[2];
    let template = CurvatureDescriptor::describe(&s, 1830, &radii);
    let threshold = 0.02;
    let d = CurvatureDescriptor::new(&s, &radii, &template, threshold);
    let (mut kept, mut by_bound) = (0, 0);
    for v in 0..s.vertex_count() as u32 {
        let exact = CurvatureDescriptor::describe(&s, v, &radii);
        let mut state = d.start(v, 1);
        let mut running = 0.0;
        for layer in 0..radii.len() {
            let step = exact[layer] * scale - template[layer] * scale;
            running += step * step;
            let got = d.extend(v, layer, &mut state);
            if running <= threshold {
                assert_eq!(got, running, "vertex {v} layer {layer}");
                kept += usize::from(layer + 1 == radii.len());
            } else {
                // Rejected either way; a bound never passes the exact value.
                assert!(
                    got > threshold && got <= running * (1.0 + 1e-9),
                    "vertex {v}"
                );
                by_bound += usize::from(got != running);
                break;
            }
        }
    }
    assert!(
        kept > 0 && by_bound > 0,
        "kept {kept}, rejected by the bound {by_bound}"
    );
}

#[test]
fn the_cascade_distance_grows_layer_by_layer() {
    let s = Surface::new(&uv_sphere(Vec3::ZERO, 1.0, 32, 64), Threads::Parallel);
    let radii = [0.2, 0.4];
    let d = CurvatureDescriptor::new(&s, &radii, &[0.0, 0.0], 10.0);
    let v = nearest_vertex(&s, Vec3::new(1.0, 0.0, 0.0));
    let mut state = d.start(v, 1);
    let first = d.extend(v, 0, &mut state);
    let second = d.extend(v, 1, &mut state);
    // Each layer adds (r_k^2 * (1 - 0))^2 = 0.0256.
    assert!((first - 0.0256).abs() < 0.003, "{first}");
    assert!((second - 2.0 * 0.0256).abs() < 0.006, "{second}");
}

#[test]
fn a_mirror_image_keeps_the_curvature_and_flips_the_handedness() {
    // A lopsided blob: its centroids turn one way around the normal.
    let m = uv_sphere(Vec3::ZERO, 1.0, 32, 64)
        .map_positions(|p| {
            Vec3::new(
                p.x + 0.3 * p.y * p.y,
                0.8 * p.y + 0.2 * p.z * p.x,
                0.6 * p.z + 0.25 * p.x * p.y,
            )
        })
        .unwrap();
    let mirror = |p: Vec3| Vec3::new(-p.x, p.y, p.z);
    let mirrored = m.map_positions(mirror).unwrap();
    let mirrored = TriMesh::new(
        mirrored.positions().to_vec(),
        mirrored
            .triangles()
            .iter()
            .map(|t| [t[0], t[2], t[1]])
            .collect(),
    )
    .unwrap();
    let (a, b) = (
        Surface::new(&m, Threads::Parallel),
        Surface::new(&mirrored, Threads::Parallel),
    );
    let radii = [0.3, 0.6, 0.9];
    let mut clear = 0;
    for v in [10u32, 200, 500, 900, 1500] {
        let w = nearest_vertex(&b, mirror(a.position(v)));
        let (la, lb) = (
            CurvatureDescriptor::layers_at(&a, v, &radii),
            CurvatureDescriptor::layers_at(&b, w, &radii),
        );
        for (x, y) in la.iter().zip(&lb) {
            assert!((x.gaussian - y.gaussian).abs() < 1e-6 * (1.0 + x.gaussian.abs()));
        }
        let ha = handedness(a.vertex_normal(v), la[0].centroid, la[2].centroid);
        let hb = handedness(b.vertex_normal(w), lb[0].centroid, lb[2].centroid);
        assert!((ha + hb).abs() < 1e-6, "{ha} vs {hb}");
        if ha.abs() > 0.3 {
            clear += 1;
        }
    }
    assert!(clear >= 2, "the blob should turn clearly somewhere");
}
