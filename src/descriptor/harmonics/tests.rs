//! Harmonics against analytic oracles and under rotation.

use super::transform::{fejer_weights, normalized_legendre, phi, theta};
use super::*;
use crate::exec::Threads;
use crate::math::Vec3;
use crate::mesh::TriMesh;
use crate::mesh::shapes::{cuboid, torus, uv_sphere};
use crate::voxel::{GridSpec, Solid, skin, voxelize};
use std::f64::consts::PI;

fn sample_fn(f: impl Fn(Vec3) -> f64) -> [f32; RINGS * SECTORS] {
    let mut out = [0.0; RINGS * SECTORS];
    for j in 0..RINGS {
        let (st, ct) = theta(j).sin_cos();
        for k in 0..SECTORS {
            let (sp, cp) = phi(k).sin_cos();
            out[j * SECTORS + k] = f(Vec3::new(st * cp, st * sp, ct)) as f32;
        }
    }
    out
}

#[test]
fn legendre_tables_are_orthonormal_under_the_quadrature() {
    let w = fejer_weights();
    assert!((w.iter().sum::<f64>() - 2.0).abs() < 1e-12);
    let values: Vec<_> = (0..RINGS)
        .map(|j| normalized_legendre(theta(j).cos()))
        .collect();
    for m in 0..DEGREES {
        for l in m..DEGREES {
            for l2 in m..DEGREES {
                let dot: f64 = (0..RINGS)
                    .map(|j| w[j] * 2.0 * PI * values[j][l][m] * values[j][l2][m])
                    .sum();
                let want = if l == l2 { 1.0 } else { 0.0 };
                assert!((dot - want).abs() < 1e-10, "l {l} l2 {l2} m {m}: {dot}");
            }
        }
    }
}

/// The signature by the definition: every coefficient as a direct f64 sum
/// over all samples, no folds.
fn signature_by_definition(f: &[f32; RINGS * SECTORS]) -> [f64; DEGREES] {
    let w = fejer_weights();
    let mut energy = [0.0; DEGREES];
    let legendre: Vec<_> = (0..RINGS)
        .map(|j| normalized_legendre(theta(j).cos()))
        .collect();
    for l in 0..DEGREES {
        for m in 0..=l {
            let (mut re, mut im) = (0.0, 0.0);
            for j in 0..RINGS {
                for k in 0..SECTORS {
                    let v = f[j * SECTORS + k] as f64 * w[j] * 2.0 * PI / SECTORS as f64
                        * legendre[j][l][m];
                    re += v * (m as f64 * phi(k)).cos();
                    im -= v * (m as f64 * phi(k)).sin();
                }
            }
            energy[l] += if m == 0 { 1.0 } else { 2.0 } * (re * re + im * im);
        }
    }
    energy.map(|e| (e / (4.0 * PI)).sqrt())
}

#[test]
fn the_folded_transform_equals_the_definition_on_arbitrary_samples() {
    let t = SphericalTransform::new();
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    for _ in 0..3 {
        let mut f = [0.0f32; RINGS * SECTORS];
        for v in f.iter_mut() {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            *v = (state >> 40) as f32 / (1u64 << 24) as f32;
        }
        let fast = t.signature(&f);
        let slow = signature_by_definition(&f);
        for l in 0..DEGREES {
            assert!(
                (fast[l] as f64 - slow[l]).abs() < 1e-5 * (1.0 + slow[l]),
                "degree {l}: folded {} against {}",
                fast[l],
                slow[l]
            );
        }
    }
}

#[test]
fn rings_of_zeros_or_ones_give_the_signature_bit_for_bit() {
    let t = SphericalTransform::new();
    let mut rng = crate::math::unit_rng(17);
    for trial in 0..8 {
        let mut f = [0.0f32; RINGS * SECTORS];
        for (j, ring) in f.chunks_exact_mut(SECTORS).enumerate() {
            match (j + trial) % 3 {
                0 => ring.fill(0.0),
                1 => ring.fill(1.0),
                _ => ring.iter_mut().for_each(|v| *v = rng() as f32),
            }
        }
        if trial == 7 {
            f.fill(0.0);
        }
        let (cached, plain) = (t.signature(&f), t.signature_of_every_ring(&f));
        assert_eq!(
            cached.map(f32::to_bits),
            plain.map(f32::to_bits),
            "trial {trial}"
        );
    }
}

/// The samples of a sphere by their definition: each sample's eight cell
/// corners read one by one, interpolated in f64.
fn samples_by_definition(sampler: &SphereSampler, solid: &Solid, v: [u16; 3]) -> Vec<f64> {
    let (offsets, fractions) = sampler.sample_tables();
    let grid = solid.bits();
    offsets
        .iter()
        .zip(&fractions)
        .map(|(o, f)| {
            let base = [0, 1, 2].map(|a| i64::from(v[a]) + i64::from(o[a]));
            let corner = |dx: i64, dy: i64, dz: i64| {
                f64::from(u8::from(grid.get(base[0] + dx, base[1] + dy, base[2] + dz)))
            };
            let mut value = 0.0;
            for (dx, dy, dz) in (0..8).map(|i| (i & 1, (i >> 1) & 1, i >> 2)) {
                let w = |d: i64, a: usize| {
                    if d == 1 {
                        f64::from(f[a])
                    } else {
                        1.0 - f64::from(f[a])
                    }
                };
                value += w(dx, 0) * w(dy, 1) * w(dz, 2) * corner(dx, dy, dz);
            }
            value
        })
        .collect()
}

#[test]
fn bit_grid_samples_are_the_trilinear_reads_inside_outside_and_across_a_solid() {
    // A box larger than the sphere: spheres around its faces, edges and
    // corners have rings wholly outside, wholly inside and across it, and
    // spheres near the grid's sides leave it.
    let spec = GridSpec {
        origin: Vec3::splat(-20.0),
        voxel_size: 1.0,
        dims: [40, 40, 40],
    };
    let solid = Solid::new(voxelize(
        &cuboid(Vec3::splat(-12.3), Vec3::splat(11.8)),
        &spec,
        Threads::Serial,
    ));
    let sampler = SphereSampler::new(7.4, &solid, Threads::Serial);
    assert_eq!(sampler.level(), 0);
    let mut uniform = [0usize; 2];
    for v in [
        [20, 20, 20],
        [31, 20, 20],
        [32, 31, 20],
        [8, 32, 31],
        [20, 20, 3],
        [38, 1, 20],
    ] {
        let mut got = [0.0f32; RINGS * SECTORS];
        sampler.sample(&solid, v, &mut got);
        for (ring, want) in samples_by_definition(&sampler, &solid, v)
            .chunks(SECTORS)
            .enumerate()
        {
            let got = &got[ring * SECTORS..(ring + 1) * SECTORS];
            for (g, w) in got.iter().zip(want) {
                assert!(
                    (f64::from(*g) - w).abs() < 1e-5,
                    "voxel {v:?} ring {ring}: {g} against {w}"
                );
            }
            for (k, value) in [0.0, 1.0].into_iter().enumerate() {
                if want.iter().all(|&w| w == value) {
                    uniform[k] += 1;
                    assert!(
                        got.iter().all(|&g| f64::from(g) == value),
                        "voxel {v:?} ring {ring}"
                    );
                }
            }
        }
    }
    assert!(uniform[0] > 0 && uniform[1] > 0, "{uniform:?}");
}

#[test]
fn a_constant_has_only_degree_zero() {
    let t = SphericalTransform::new();
    let s = t.signature(&sample_fn(|_| 1.0));
    assert!((s[0] - 1.0).abs() < 1e-5, "{s:?}");
    assert!(s[1..].iter().all(|&x| x.abs() < 1e-5), "{s:?}");
}

#[test]
fn a_single_harmonic_lands_in_its_degree_with_its_energy() {
    let t = SphericalTransform::new();
    for (l, m) in [(1, 0), (2, 1), (5, 3), (9, 9), (15, 7)] {
        // Re(Y_lm) = p_lm(cos theta) cos(m phi), with energy 1/2 for m > 0.
        let f = sample_fn(|d| {
            let p = normalized_legendre(d.z)[l][m];
            p * (m as f64 * d.y.atan2(d.x)).cos()
        });
        let s = t.signature(&f);
        let want = if m == 0 { 1.0 } else { 0.5f64.sqrt() } / (4.0 * PI).sqrt();
        for (deg, &v) in s.iter().enumerate() {
            let expect = if deg == l { want } else { 0.0 };
            assert!(
                (v as f64 - expect).abs() < 1e-5,
                "Y({l},{m}) degree {deg}: {v}"
            );
        }
    }
}

fn rotation(seed: u64) -> impl Fn(Vec3) -> Vec3 {
    // A random unit quaternion from three uniforms (Shoemake).
    let mut s = seed;
    let mut rnd = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let (u1, u2, u3) = (rnd(), rnd(), rnd());
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    let q = [
        a * (2.0 * PI * u2).sin(),
        a * (2.0 * PI * u2).cos(),
        b * (2.0 * PI * u3).sin(),
        b * (2.0 * PI * u3).cos(),
    ];
    let (x, y, z, w) = (q[0], q[1], q[2], q[3]);
    let m = [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - z * w),
            2.0 * (x * z + y * w),
        ],
        [
            2.0 * (x * y + z * w),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - x * w),
        ],
        [
            2.0 * (x * z - y * w),
            2.0 * (y * z + x * w),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ];
    move |p: Vec3| {
        Vec3::new(
            m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z,
            m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z,
            m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z,
        )
    }
}

#[test]
fn a_bandlimited_function_and_its_rotation_have_the_same_signature() {
    let t = SphericalTransform::new();
    // A polynomial of degree 6 in the direction: bandlimited to l <= 6.
    let g = |d: Vec3| 0.3 + d.x * d.y - 0.7 * d.z.powi(3) + 0.5 * (d.x * d.z).powi(3) + 0.2 * d.y;
    let base = t.signature(&sample_fn(g));
    for seed in 1..6 {
        let r = rotation(seed * 7919);
        let rotated = t.signature(&sample_fn(|d| g(r(d))));
        let d2 = signature_distance2(&base, &rotated);
        assert!(d2.sqrt() < 1e-4, "seed {seed}: {}", d2.sqrt());
    }
}

/// An asymmetric solid: a body, an arm and a ring, so that every
/// orientation looks different; `arm` picks the arm's direction.
fn lumpy(arm: Vec3) -> TriMesh {
    let mut m = uv_sphere(Vec3::ZERO, 0.6, 48, 96);
    let lo = Vec3::new(-0.15, -0.15, -0.15);
    m.append(&cuboid(
        lo + arm * 0.3,
        Vec3::new(0.15, 0.15, 0.15) + arm * 1.1,
    ));
    m.append(&torus(Vec3::new(-0.2, 0.5, 0.3), 0.35, 0.1, 48, 16));
    m
}

fn signatures_at(
    mesh: &TriMesh,
    point: Vec3,
    voxel: f64,
    radii: &[f64],
    t: &SphericalTransform,
) -> Vec<Signature> {
    let spec = GridSpec::around(mesh.bounds(), voxel).unwrap();
    let g = Solid::new(voxelize(mesh, &spec, Threads::Serial));
    let target = spec.to_grid(point);
    let v = skin(g.bits(), Threads::Serial)
        .iter_ones()
        .min_by(|a, b| {
            let da =
                Vec3::new(a[0] as f64 + 0.5, a[1] as f64 + 0.5, a[2] as f64 + 0.5).distance(target);
            let db =
                Vec3::new(b[0] as f64 + 0.5, b[1] as f64 + 0.5, b[2] as f64 + 0.5).distance(target);
            da.total_cmp(&db)
        })
        .unwrap();
    HarmonicsDescriptor::describe(&g, v, radii, t, Threads::Serial)
}

fn distance(a: &[Signature], b: &[Signature]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| signature_distance2(x, y))
        .sum::<f64>()
        .sqrt()
}

#[test]
fn voxelized_shapes_are_rotation_invariant_and_distinct() {
    let t = SphericalTransform::new();
    let shape = lumpy(Vec3::new(1.0, 0.0, 0.0));
    let point = shape.closest_point(Vec3::new(0.0, 0.0, 0.0)).point;
    let voxel = 0.02;
    let radii = [0.2, 0.4, 0.6, 0.8, 1.0, 1.2];
    let base = signatures_at(&shape, point, voxel, &radii, &t);
    let mut worst: f64 = 0.0;
    for seed in 1..4 {
        let r = rotation(seed * 104729);
        let rotated = shape.map_positions(&r).unwrap();
        let d = distance(&base, &signatures_at(&rotated, r(point), voxel, &radii, &t));
        worst = worst.max(d);
    }
    // Stated tolerance: rotated copies stay within 0.1 (voxel aliasing and a
    // sub-voxel shift of the centre).
    assert!(worst < 0.1, "rotated copies differ by {worst}");
    // The same parts with the arm elsewhere, same point: clearly further.
    let other = lumpy(Vec3::new(0.0, -0.6, 0.8));
    let d_other = distance(&base, &signatures_at(&other, point, voxel, &radii, &t));
    assert!(
        d_other > 3.0 * worst.max(0.03),
        "other shape at {d_other}, rotations up to {worst}"
    );
}

/// What the paper's order (innermost sphere first) decides for one point:
/// its distance, or `None` when rejected; and whether clutter excused a
/// sphere. Written from the rule in [`super::super::clutter`], sphere by
/// sphere, independently of the stage's bookkeeping.
fn innermost_first(
    h: &HarmonicsDescriptor,
    guard: &ClutterGuard,
    v: [u16; 3],
    clean: usize,
) -> (Option<f64>, bool) {
    let k = h.radii.len();
    let threshold2 = h.threshold * h.threshold;
    let mut sum2 = 0.0;
    for j in 0..k {
        let sig = describe_sphere(h.solid, v, h.sphere(j), h.transform);
        let cluttered = j >= clean
            && (guard.balls[j].fraction(h.solid, v) - guard.templates[0][j]
                > guard.policy.volume_tolerance
                || (sig[0] - h.templates[0][j][0]) as f64 > guard.policy.sphere_tolerance);
        if cluttered {
            // Judged over the j spheres inside: their mean must pass.
            let passes = sum2 * k as f64 / j as f64 <= threshold2;
            return (passes.then_some(sum2.sqrt()), true);
        }
        sum2 += h.weights[j] * signature_distance2(&sig, &h.templates[0][j]);
        if sum2 > threshold2 {
            return (None, false);
        }
    }
    (Some(sum2.sqrt()), false)
}

/// The lumpy template with a slab beside its copy (clutter for the outer
/// spheres of the points on that side) and a torus nearby: the template's
/// solid, its surface voxel nearest `near`, the scene's solid and skin
/// voxels.
fn cluttered_lumpy(voxel: f64, near: Vec3) -> (Solid, [u16; 3], Solid, Vec<[u16; 3]>) {
    let template_mesh = lumpy(Vec3::new(1.0, 0.0, 0.0));
    let tspec = GridSpec::around(template_mesh.bounds(), voxel).unwrap();
    let tsolid = Solid::new(voxelize(&template_mesh, &tspec, Threads::Serial));
    let tv = surface_voxel_near(&tsolid, near);
    let mut scene_mesh = lumpy(Vec3::new(1.0, 0.0, 0.0));
    scene_mesh.append(&cuboid(
        Vec3::new(-1.6, -0.9, -0.9),
        Vec3::new(-1.3, 0.9, 0.9),
    ));
    scene_mesh.append(&torus(Vec3::new(1.6, 1.6, 0.0), 0.4, 0.15, 32, 12));
    let spec = GridSpec::around(scene_mesh.bounds(), voxel).unwrap();
    let solid = Solid::new(voxelize(&scene_mesh, &spec, Threads::Serial));
    let points: Vec<[u16; 3]> = skin(solid.bits(), Threads::Serial).iter_ones().collect();
    (tsolid, tv, solid, points)
}

/// The skin voxel of `solid` nearest `p`.
fn surface_voxel_near(solid: &Solid, p: Vec3) -> [u16; 3] {
    let spec = solid.bits().spec();
    skin(solid.bits(), Threads::Serial)
        .iter_ones()
        .min_by(|a, b| {
            let d = |v: &[u16; 3]| spec.center(*v).distance(p);
            d(a).total_cmp(&d(b))
        })
        .unwrap()
}

#[test]
fn the_selective_order_keeps_the_survivors_of_the_innermost_first_order() {
    use crate::cascade::{finished, run_cascade};
    use crate::descriptor::VolumeDescriptor;
    let t = SphericalTransform::new();
    let voxel = 0.05;
    let radii = [0.2, 0.4, 0.6, 0.8, 1.0, 1.2];
    let (tsolid, tv, solid, points) = cluttered_lumpy(voxel, Vec3::new(0.0, 0.6, 0.0));
    let volume = VolumeDescriptor::new(
        &solid,
        &points,
        &radii,
        vec![VolumeDescriptor::describe(
            &tsolid,
            tv,
            &radii,
            Threads::Serial,
        )],
        1.0,
        Threads::Serial,
    );
    let guard = ClutterGuard {
        policy: ClutterPolicy::DEFAULT,
        balls: volume.balls(),
        templates: volume.templates(),
    };
    let template = HarmonicsDescriptor::describe(&tsolid, tv, &radii, &t, Threads::Serial);
    let stage = |threshold: f64| {
        HarmonicsDescriptor::new(
            &solid,
            &points,
            &t,
            &radii,
            vec![template.clone()],
            threshold,
            Threads::Serial,
        )
        .with_clutter(ClutterGuard { ..guard })
    };
    // A threshold that lets about a third of the points through.
    let probe = stage(f64::INFINITY);
    let clean = probe.clean_layers;
    // r_k is 24 voxels: the four spheres out to 16 voxels always count.
    assert_eq!(clean, 4);
    let decided: Vec<_> = points
        .iter()
        .map(|&v| innermost_first(&probe, &guard, v, clean))
        .collect();
    let mut distances: Vec<f64> = decided.iter().filter_map(|d| d.0).collect();
    distances.sort_by(f64::total_cmp);
    let threshold = distances[distances.len() / 3];
    let h = stage(threshold);
    let decided: Vec<_> = points
        .iter()
        .map(|&v| innermost_first(&h, &guard, v, clean))
        .collect();
    let oracle: Vec<(u32, f64)> = (0..points.len() as u32)
        .zip(&decided)
        .filter_map(|(i, d)| d.0.map(|d| (i, d)))
        .collect();
    // Every way a point can go must occur, or the comparison proves little.
    let count = |excused: bool, passing: bool| {
        let n = decided
            .iter()
            .filter(|d| d.1 == excused && d.0.is_some() == passing);
        n.count()
    };
    let counts = [(false, true), (true, true), (true, false)].map(|(e, p)| count(e, p));
    assert!(counts.iter().all(|&n| n > 20), "{counts:?}");
    assert!(oracle.len() < points.len() / 2, "{}", oracle.len());
    // Both leads, point by point as the cascade runs them.
    for excusable_first in [false, true] {
        let order = ClutterPolicy::selective_order(clean, radii.len(), excusable_first);
        let passed: Vec<(u32, f64)> = (0..points.len() as u32)
            .filter_map(|p| {
                let mut state = h.start(p, 1);
                let mut d = 0.0;
                for &layer in &order {
                    d = h.extend(p, layer, &mut state);
                    if d > h.threshold {
                        return None;
                    }
                }
                Some((p, d))
            })
            .collect();
        assert_eq!(passed.len(), oracle.len(), "{order:?}");
        for ((p, d), (point, distance)) in passed.iter().zip(&oracle) {
            assert_eq!(p, point, "{order:?}");
            assert!((d - distance).abs() <= 1e-9 * distance.max(1.0));
        }
    }
    // And the cascade, with the lead the stage picks.
    let candidates: Vec<u32> = (0..points.len() as u32).collect();
    let order = h.order(&candidates, Threads::Serial);
    assert!(order == [3, 4, 5, 2, 1, 0] || order == [4, 5, 3, 2, 1, 0]);
    let (survivors, stats) = finished(run_cascade(
        &[&h],
        candidates,
        1,
        Threads::Serial,
        None,
        &mut (),
    ))
    .unwrap();
    assert_eq!(stats.iter().map(|s| s.layer - 1).collect::<Vec<_>>(), order);
    assert_eq!(survivors.len(), oracle.len());
    for (s, (point, distance)) in survivors.iter().zip(&oracle) {
        assert_eq!(s.point, *point);
        assert!((s.distance - distance).abs() <= 1e-9 * distance.max(1.0));
    }
}

#[test]
fn a_cascade_of_two_anchors_passes_the_union_of_one_anchor_cascades() {
    use crate::cascade::{Survivor, finished, run_cascade};
    use crate::descriptor::VolumeDescriptor;
    use std::collections::BTreeMap;
    let t = SphericalTransform::new();
    let voxel = 0.05;
    let radii = [0.2, 0.4, 0.6, 0.8, 1.0, 1.2];
    let (tsolid, first, solid, points) = cluttered_lumpy(voxel, Vec3::new(0.0, 0.6, 0.0));
    let second = surface_voxel_near(&tsolid, Vec3::new(1.0, -0.5, 0.3));
    let volume = |anchors: &[[u16; 3]]| {
        let templates = anchors
            .iter()
            .map(|&a| VolumeDescriptor::describe(&tsolid, a, &radii, Threads::Serial))
            .collect();
        VolumeDescriptor::new(&solid, &points, &radii, templates, 0.4, Threads::Serial)
            .with_clutter(ClutterPolicy::DEFAULT)
    };
    let run = |anchors: &[[u16; 3]]| -> Vec<Survivor> {
        let v = volume(anchors);
        let h = HarmonicsDescriptor::new(
            &solid,
            &points,
            &t,
            &radii,
            anchors
                .iter()
                .map(|&a| HarmonicsDescriptor::describe(&tsolid, a, &radii, &t, Threads::Serial))
                .collect(),
            2.0,
            Threads::Serial,
        )
        .with_clutter(ClutterGuard {
            policy: ClutterPolicy::DEFAULT,
            balls: v.balls(),
            templates: v.templates(),
        });
        let candidates = (0..points.len() as u32).collect();
        let all = crate::descriptor::all_anchors(anchors.len());
        finished(run_cascade(
            &[&v, &h],
            candidates,
            all,
            Threads::Parallel,
            None,
            &mut (),
        ))
        .unwrap()
        .0
    };
    let by_point = |s: Vec<Survivor>| -> BTreeMap<u32, Survivor> {
        s.into_iter().map(|s| (s.point, s)).collect()
    };
    let (a, b) = (by_point(run(&[first])), by_point(run(&[second])));
    let both = by_point(run(&[first, second]));
    // Each anchor alone passes points the other rejects, and not every
    // point: otherwise the union proves little.
    let only = |x: &BTreeMap<u32, Survivor>, y: &BTreeMap<u32, Survivor>| {
        x.keys().filter(|p| !y.contains_key(p)).count()
    };
    assert!(
        only(&a, &b) > 5 && only(&b, &a) > 5,
        "{} {}",
        only(&a, &b),
        only(&b, &a)
    );
    assert!(
        a.len() + b.len() < points.len() / 2,
        "{} {}",
        a.len(),
        b.len()
    );
    let union: Vec<u32> = a
        .keys()
        .chain(b.keys())
        .copied()
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    assert_eq!(both.keys().copied().collect::<Vec<_>>(), union);
    for (p, s) in &both {
        let (in_a, in_b) = (a.get(p), b.get(p));
        assert_eq!(
            s.anchors,
            u8::from(in_a.is_some()) | u8::from(in_b.is_some()) << 1,
            "{p}"
        );
        let d = in_a
            .iter()
            .chain(&in_b)
            .map(|s| s.distance)
            .fold(f64::INFINITY, f64::min);
        assert!(
            (s.distance - d).abs() <= 1e-9 * d.max(1.0),
            "{p}: {} vs {d}",
            s.distance
        );
    }
}

/// A batch that returns the CPU's signatures moved by up to `noise` per
/// degree (a fixed pseudo-random pattern per point and layer) and claims
/// `bound` as its error; it counts no balls.
struct NoisyBatch<'a> {
    solid: &'a Solid,
    transform: &'a SphericalTransform,
    noise: f32,
    bound: f32,
}

impl crate::descriptor::LayerBatch for NoisyBatch<'_> {
    fn ball_counts<'a>(
        &'a self,
        _: &'a crate::voxel::Ball,
        _: &'a [[u16; 3]],
    ) -> crate::descriptor::LocalFuture<'a, Result<Vec<u64>, String>> {
        Box::pin(std::future::ready(Err("no balls here".into())))
    }

    fn sphere_signatures<'a>(
        &'a self,
        sampler: &'a SphereSampler,
        voxels: &'a [[u16; 3]],
    ) -> crate::descriptor::LocalFuture<'a, Result<Vec<Signature>, String>> {
        let signatures = voxels
            .iter()
            .map(|&v| {
                let mut s = describe_sphere(self.solid, v, sampler, self.transform);
                let mut h = (v[0] as u64) << 40
                    ^ (v[1] as u64) << 20
                    ^ v[2] as u64
                    ^ sampler.radius().to_bits();
                for x in &mut s {
                    h = h
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    let unit = (h >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0;
                    *x += unit * self.noise;
                }
                s
            })
            .collect();
        Box::pin(std::future::ready(Ok(signatures)))
    }

    fn max_sphere_error(&self) -> f32 {
        self.bound
    }
}

#[test]
fn a_batch_within_its_bound_keeps_exactly_the_cpus_survivors() {
    use crate::cascade::{finished, run_cascade};
    use crate::descriptor::{LayerBatch, VolumeDescriptor};
    let t = SphericalTransform::new();
    let voxel = 0.05;
    let radii = [0.2, 0.4, 0.6, 0.8, 1.0, 1.2];
    let (tsolid, tv, solid, points) = cluttered_lumpy(voxel, Vec3::new(0.0, 0.6, 0.0));
    let volume = VolumeDescriptor::new(
        &solid,
        &points,
        &radii,
        vec![VolumeDescriptor::describe(
            &tsolid,
            tv,
            &radii,
            Threads::Serial,
        )],
        1.0,
        Threads::Serial,
    );
    let template = HarmonicsDescriptor::describe(&tsolid, tv, &radii, &t, Threads::Serial);
    let stage = |threshold: f64| {
        HarmonicsDescriptor::new(
            &solid,
            &points,
            &t,
            &radii,
            vec![template.clone()],
            threshold,
            Threads::Serial,
        )
        .with_clutter(ClutterGuard {
            policy: ClutterPolicy::DEFAULT,
            balls: volume.balls(),
            templates: volume.templates(),
        })
    };
    let candidates: Vec<u32> = (0..points.len() as u32).collect();
    let cascade = |h: &HarmonicsDescriptor, batch: Option<&dyn LayerBatch>| {
        finished(run_cascade(
            &[h],
            candidates.clone(),
            1,
            Threads::Parallel,
            batch,
            &mut (),
        ))
        .unwrap()
        .0
    };
    // The median distance as threshold: many points sit near it.
    let all = cascade(&stage(f64::INFINITY), None);
    let mut distances: Vec<f64> = all.iter().map(|s| s.distance).collect();
    distances.sort_by(f64::total_cmp);
    let threshold = distances[distances.len() / 2];
    let exact = cascade(&stage(threshold), None);
    // Noise of 0.01 per degree: far above a GPU's, so the band is crossed
    // often.
    let noise = 0.01;
    let noisy = |bound: f32| {
        let batch = NoisyBatch {
            solid: &solid,
            transform: &t,
            noise,
            bound,
        };
        let h = stage(threshold);
        let survivors = cascade(&h, Some(&batch));
        assert_eq!(OnionDescriptor::batch_failure(&h), None);
        survivors
    };
    let guarded = noisy(noise);
    assert_eq!(
        guarded.iter().map(|s| s.point).collect::<Vec<_>>(),
        exact.iter().map(|s| s.point).collect::<Vec<_>>()
    );
    for (g, e) in guarded.iter().zip(&exact) {
        // Sum of per-sphere bounds: sqrt(sum_j w_j) * 4 * noise.
        let weights: f64 = layer_weights(&radii, voxel).iter().sum();
        assert!((g.distance - e.distance).abs() <= weights.sqrt() * 4.0 * noise as f64);
    }
    // The same batch trusted blindly keeps other points: the band matters.
    let blind = noisy(0.0);
    assert_ne!(
        blind.iter().map(|s| s.point).collect::<Vec<_>>(),
        exact.iter().map(|s| s.point).collect::<Vec<_>>()
    );
}
