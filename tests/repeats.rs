//! Repeated parts found without a template, scored against the shared
//! scenes' `families.json` as `../shared/bench/evaluate_families.py`
//! scores them (positions, then turns up to the part's symmetries), so
//! that the suite needs no Python.

mod common;

use common::scene_dir;
use fast_reject::exec::Threads;
use fast_reject::math::Vec3;
use fast_reject::mesh::io::model::{Attribute, Primitive, TriangleSource};
use fast_reject::mesh::io::{Model, NoResources, load, load_model, write_glb};
use fast_reject::mesh::{TriMesh, minimal_bounding_sphere};
use fast_reject::repeats::{Placement, instanced_model, split_by_material};
use fast_reject::{Family, RepeatCopy, find_repeats};
use serde_json::Value;

type Matrix = [[f64; 4]; 4];
type Point = [f64; 3];

fn matrix(value: &Value) -> Matrix {
    let rows = value.as_array().unwrap();
    std::array::from_fn(|r| std::array::from_fn(|c| rows[r][c].as_f64().unwrap()))
}

fn point(value: &Value) -> Point {
    std::array::from_fn(|i| value[i].as_f64().unwrap())
}

fn apply(m: &Matrix, p: Point) -> Point {
    std::array::from_fn(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3])
}

fn distance(a: Point, b: Point) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt()
}

/// A truth unit: a family, or a rigid group of them.
#[derive(Clone)]
struct Unit {
    id: String,
    members: Vec<String>,
    center: Point,
    radius: f64,
    /// A copy's triangles: a part found in pieces, or short of a piece,
    /// is not the part.
    triangles: usize,
    copies: Vec<Matrix>,
    symmetries: Vec<Matrix>,
    /// The reference points a pose must carry right: the centre, and the
    /// ends of the axes no turn symmetry hides.
    points: Vec<Point>,
}

fn unit(value: &Value, members: Vec<String>) -> Unit {
    let center = point(&value["center"]);
    let radius = value["radius"].as_f64().unwrap();
    let axes = value["symmetry_axes"].as_array().unwrap();
    let mut points = vec![center];
    let along = |d: Point| std::array::from_fn(|i| center[i] + radius * d[i]);
    match axes.len() {
        0 => points.extend([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]].map(along)),
        1 => points.push(along(point(&axes[0]["direction"]))),
        _ => {}
    }
    Unit {
        id: value["id"].as_str().unwrap().to_owned(),
        members,
        center,
        radius,
        triangles: value["triangles"].as_u64().unwrap() as usize,
        copies: value["copies"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| matrix(&c["transform"]))
            .collect(),
        symmetries: value["symmetries"]
            .as_array()
            .unwrap()
            .iter()
            .map(matrix)
            .collect(),
        points,
    }
}

fn units(truth: &Value) -> Vec<Unit> {
    let families = truth["families"].as_array().unwrap();
    let mut units: Vec<Unit> = families
        .iter()
        .map(|f| unit(f, vec![f["id"].as_str().unwrap().to_owned()]))
        .collect();
    for group in truth["rigid_groups"].as_array().unwrap() {
        let members = group["families"].as_array().unwrap();
        let members = members
            .iter()
            .map(|m| m.as_str().unwrap().to_owned())
            .collect();
        units.push(unit(group, members));
    }
    units
}

/// Whether `found` is `unit`: as many copies of as many triangles, one to
/// one where the truth has them, and each pose carrying the reference points, taken where the
/// representative stands, onto the copy's, up to a symmetry.
fn matches(found: &Family, unit: &Unit) -> bool {
    let tolerance = 0.05 * unit.radius;
    let center = [found.center.x, found.center.y, found.center.z];
    // A family read back from an instanced file has no triangle list:
    // its mesh may leave out a piece meshed otherwise in one copy.
    let counted = !found.copies[0].triangles.is_empty();
    if found.copies.len() != unit.copies.len()
        || counted && found.triangles() != unit.triangles
        || (found.radius - unit.radius).abs() > tolerance
    {
        return false;
    }
    let at = |pose: &Matrix| apply(pose, center);
    let truth_of = |pose: &Matrix| {
        unit.copies
            .iter()
            .position(|t| distance(at(pose), apply(t, unit.center)) <= tolerance)
    };
    let Some(first) = truth_of(&found.copies[0].pose) else {
        return false;
    };
    let mut taken = vec![false; unit.copies.len()];
    for copy in &found.copies {
        let Some(j) = truth_of(&copy.pose) else {
            return false;
        };
        let turned_right = unit.symmetries.iter().any(|s| {
            unit.points.iter().all(|&q| {
                let ours = apply(&copy.pose, apply(&unit.copies[first], q));
                distance(ours, apply(&unit.copies[j], apply(s, q))) <= tolerance
            })
        });
        if taken[j] || !turned_right {
            return false;
        }
        taken[j] = true;
    }
    true
}

/// The truth families a shared scene's `families` leaves unfound, and the
/// result families that are two truth units at once.
fn score(scene: &str, families: &[Family]) -> (Vec<String>, usize) {
    let path = scene_dir(scene).join("families.json");
    let truth: Value = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
    score_units(&units(&truth), families)
}

/// The truth families `families` leaves unfound, and the result families
/// that are two truth units at once.
fn score_units(units: &[Unit], families: &[Family]) -> (Vec<String>, usize) {
    let mut found: Vec<&str> = Vec::new();
    let mut merged = 0;
    for family in families {
        let hits: Vec<&Unit> = units.iter().filter(|u| matches(family, u)).collect();
        merged += usize::from(hits.len() > 1);
        found.extend(
            hits.iter()
                .flat_map(|u| u.members.iter().map(String::as_str)),
        );
    }
    let missed = units
        .iter()
        .filter(|u| u.members == [u.id.clone()] && !found.contains(&u.id.as_str()))
        .map(|u| u.id.clone())
        .collect();
    (missed, merged)
}

fn repeats_of(scene: &str) -> Vec<Family> {
    let bytes = std::fs::read(scene_dir(scene).join("scene.glb")).unwrap();
    find_repeats(&load(&bytes, None).unwrap(), Threads::Parallel)
}

#[test]
fn every_repeated_part_of_the_saw_is_found_with_its_poses() {
    for scene in ["real-saw-roller", "real-saw-fin"] {
        let families = repeats_of(scene);
        assert_eq!(score(scene, &families), (vec![], 0), "{scene}");
        for family in &families {
            assert!(
                family
                    .copies
                    .iter()
                    .all(|c| c.residual < 1e-5 * family.radius)
            );
        }
    }
}

#[test]
fn the_trucks_wheel_pairs_are_one_family_of_two() {
    let families = repeats_of("real-truck-wheels");
    assert_eq!(score("real-truck-wheels", &families), (vec![], 0));
}

#[test]
fn the_scorer_refuses_a_family_moved_off_its_copies() {
    // A scorer that cannot fail proves nothing: shifting one copy by a
    // tenth of the part's size, or dropping one, loses that family.
    let mut families = repeats_of("real-truck-wheels");
    let (mut shifted, mut dropped) = (families.clone(), families.clone());
    shifted[0].copies[1].pose[0][3] += 0.1 * families[0].radius;
    dropped[0].copies.pop();
    for broken in [shifted, dropped] {
        assert_eq!(score("real-truck-wheels", &broken).0.len(), 1);
    }
    // So is a turn about the representative's centre that the part does
    // not have: a third of a turn about a diagonal.
    let c = families[0].center;
    let c = [c.x, c.y, c.z];
    let pose = families[0].copies[1].pose;
    let turned = |p: Point| {
        apply(
            &pose,
            std::array::from_fn(|i| c[i] + p[(i + 2) % 3] - c[(i + 2) % 3]),
        )
    };
    let origin = turned([0.0; 3]);
    for (i, row) in families[0].copies[1].pose.iter_mut().take(3).enumerate() {
        for (k, unit) in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
            .into_iter()
            .enumerate()
        {
            row[k] = turned(unit)[i] - origin[i];
        }
        row[3] = origin[i];
    }
    assert_eq!(score("real-truck-wheels", &families).0.len(), 1);
}

/// Four models in units a thousand times apart, placed turned, mirrored
/// (triangles kept, or turned over to face outwards), as a body of two
/// pieces, and a near twin that must join nothing.
#[test]
fn generated_turned_mirrored_and_twin_parts_are_each_their_own_family() {
    use glam::{DMat3, DQuat};

    /// A deterministic turn: no seed file to keep.
    fn turn(k: usize) -> DMat3 {
        let a = 0.37 + 1.91 * k as f64;
        let axis = Vec3::new(a.sin(), (1.3 * a).cos(), 0.6).normalize();
        DMat3::from_quat(DQuat::from_axis_angle(axis, 2.0 * a))
    }
    fn placed(mesh: &TriMesh, m: &Matrix, turned_over: bool) -> TriMesh {
        let positions = mesh
            .positions()
            .iter()
            .map(|p| apply(m, p.map(f64::from)).map(|x| x as f32))
            .collect();
        let triangles = mesh
            .triangles()
            .iter()
            .map(|&[a, b, c]| if turned_over { [a, c, b] } else { [a, b, c] })
            .collect();
        TriMesh::new(positions, triangles).unwrap()
    }
    fn pose(rotation: DMat3, mirrored: bool, at: Vec3) -> Matrix {
        let r = if mirrored {
            rotation * DMat3::from_diagonal(Vec3::new(-1.0, 1.0, 1.0))
        } else {
            rotation
        };
        std::array::from_fn(|i| {
            if i == 3 {
                return [0.0, 0.0, 0.0, 1.0];
            }
            [r.col(0)[i], r.col(1)[i], r.col(2)[i], at[i]]
        })
    }
    let model = |file: &str, size: f64| {
        let mesh = load(&common::model_bytes(file), None).unwrap();
        let sphere = minimal_bounding_sphere(
            &(0..mesh.positions().len() as u32)
                .map(|v| mesh.vertex(v))
                .collect::<Vec<_>>(),
        )
        .unwrap();
        mesh.map_positions(|p| (p - sphere.center) * (size / sphere.radius))
            .unwrap()
    };
    let cow = model("cow.obj", 0.05);
    let fandisk = model("fandisk.obj", 1.0);
    let rocker = model("rocker-arm.obj", 50.0);
    // A body of two pieces apart: a teapot and a smaller cow beside it.
    let mut body = model("teapot.obj", 2.0);
    body.append(
        &model("cow.obj", 0.5)
            .map_positions(|p| p + Vec3::new(3.0, 0.0, 0.0))
            .unwrap(),
    );

    let mut scene: Option<TriMesh> = None;
    let mut add = |mesh: TriMesh| match &mut scene {
        Some(s) => s.append(&mesh),
        None => scene = Some(mesh),
    };
    let mut units = Vec::new();
    // Mirror images left inside out: a mirroring node draws its mesh
    // turned right, so no node draws them as they are.
    let mut inside_out: Vec<(usize, Matrix)> = Vec::new();
    let parts: [(&str, &TriMesh, f64, usize); 4] = [
        ("cow", &cow, 0.05, 6),
        ("fandisk", &fandisk, 1.0, 4),
        ("rocker", &rocker, 50.0, 3),
        ("body", &body, 4.0, 3),
    ];
    for (f, (id, mesh, size, count)) in parts.into_iter().enumerate() {
        let mut copies = Vec::new();
        for k in 0..count {
            // Every third copy mirrored, every other mirror turned over.
            let mirrored = k % 3 == 2;
            let at = Vec3::new(4.0 * size * k as f64, 1000.0 * f as f64, 0.0);
            let m = pose(turn(7 * f + k), mirrored, at);
            add(placed(mesh, &m, mirrored && k % 2 == 1));
            copies.push(m);
            if mirrored && k % 2 == 0 {
                inside_out.push((units.len(), m));
            }
        }
        let vertices: Vec<Vec3> = (0..mesh.positions().len() as u32)
            .map(|v| mesh.vertex(v))
            .collect();
        let sphere = minimal_bounding_sphere(&vertices).unwrap();
        let c = sphere.center.to_array();
        let r = sphere.radius;
        units.push(Unit {
            id: id.to_owned(),
            members: vec![id.to_owned()],
            center: c,
            radius: r,
            triangles: mesh.triangles().len(),
            copies,
            symmetries: vec![pose(DMat3::IDENTITY, false, Vec3::ZERO)],
            points: vec![
                c,
                [c[0] + r, c[1], c[2]],
                [c[0], c[1] + r, c[2]],
                [c[0], c[1], c[2] + r],
            ],
        });
    }
    // A fandisk with one vertex moved by a hundredth of its size.
    let twin = fandisk
        .map_positions(|p| {
            if p == fandisk.vertex(0) {
                p + Vec3::splat(0.01)
            } else {
                p
            }
        })
        .unwrap();
    add(placed(
        &twin,
        &pose(turn(99), false, Vec3::new(0.0, -1000.0, 0.0)),
        false,
    ));
    let scene = scene.unwrap();

    let families = find_repeats(&scene, Threads::Parallel);
    assert_eq!(score_units(&units, &families), (vec![], 0));
    // Nothing else: the twin joins no family, and no family is extra.
    let shapes: Vec<(usize, usize, usize)> = families
        .iter()
        .map(|f| (f.copies.len(), f.pieces, f.triangles()))
        .collect();
    assert_eq!(families.len(), units.len(), "{shapes:?}");
    let mirrored: usize = families
        .iter()
        .flat_map(|f| &f.copies)
        .filter(|c| c.mirrored)
        .count();
    // Every third copy of each: 2 of the 6 cows, one of each of the rest.
    assert_eq!(mirrored, 2 + 1 + 1 + 1);

    // Written instanced and read back: every triangle where it was, facing
    // the same way (mirror images by mirroring nodes), the same families
    // but for the copies left inside out, which stay as they were.
    let model = Model::of_mesh(&scene);
    let (mesh, sources) = model.placed().unwrap();
    let (written, read, tolerance) = written_and_read_back(&model, &mesh, &sources, &families);
    let out = load(&written, None).unwrap();
    assert_eq!(unmatched_triangles(&scene, &out, tolerance), 0);
    assert_eq!(unmatched_triangles(&out, &scene, tolerance), 0);
    let mut drawn = units.clone();
    for (u, m) in &inside_out {
        drawn[*u].copies.retain(|c| c != m);
    }
    assert_eq!(inside_out.len(), 4);
    assert_eq!(score_units(&drawn, &read), (vec![], 0));
}

/// Triangles of `a` that no triangle of `b` matches: the same corners, in
/// the same turning order (any starting corner), each within `tolerance`.
fn unmatched_triangles(a: &TriMesh, b: &TriMesh, tolerance: f64) -> usize {
    unmatched_list(a, b, tolerance).len()
}

fn unmatched_list(a: &TriMesh, b: &TriMesh, tolerance: f64) -> Vec<usize> {
    use std::collections::HashMap;
    let centroid = |m: &TriMesh, t: usize| {
        let [p, q, r] = m.corners(t);
        (p + q + r) / 3.0
    };
    let key = |p: fast_reject::math::Vec3| [p.x, p.y, p.z].map(|x| (x / tolerance).floor() as i64);
    let mut cells: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    for t in 0..b.triangles().len() {
        cells.entry(key(centroid(b, t))).or_default().push(t);
    }
    (0..a.triangles().len())
        .filter(|&t| {
            let corners = a.corners(t);
            let k = key(centroid(a, t));
            !(0..27).any(|d| {
                let near = [k[0] + d % 3 - 1, k[1] + d / 3 % 3 - 1, k[2] + d / 9 - 1];
                cells.get(&near).is_some_and(|list| {
                    list.iter().any(|&u| {
                        let other = b.corners(u);
                        (0..3).any(|turn| {
                            (0..3).all(|i| corners[i].distance(other[(i + turn) % 3]) <= tolerance)
                        })
                    })
                })
            })
        })
        .collect()
}

/// `families` of `mesh` (read from `model`) written as an instanced GLB,
/// and that GLB read back as families: every mesh that several nodes
/// place is one, its first node the representative.
fn written_and_read_back(
    model: &Model,
    mesh: &TriMesh,
    sources: &[TriangleSource],
    families: &[Family],
) -> (Vec<u8>, Vec<Family>, f64) {
    let instanced = instanced_model(model, mesh, sources, families, Placement::Nodes);
    let bytes = write_glb(&instanced.model).unwrap();
    let back = load_model(&bytes, None, &NoResources).unwrap();
    let mut read = Vec::new();
    for (m, shared) in back.meshes.iter().enumerate() {
        let nodes: Vec<&Matrix> = back
            .nodes
            .iter()
            .filter(|n| n.mesh == m)
            .flat_map(|n| &n.placements)
            .collect();
        if nodes.len() < 2 {
            continue;
        }
        let points: Vec<Vec3> = shared
            .primitives
            .iter()
            .flat_map(|p| p.positions().unwrap())
            .map(|p| Vec3::new(p[0].into(), p[1].into(), p[2].into()))
            .collect();
        let sphere = minimal_bounding_sphere(&points).unwrap();
        let first = nodes[0];
        let centre = apply(first, sphere.center.to_array());
        let back_to_mesh = inverse(first);
        read.push(Family {
            center: Vec3::from_array(centre),
            radius: sphere.radius,
            pieces: 1,
            copies: nodes
                .iter()
                .map(|n| RepeatCopy {
                    pose: multiply(n, &back_to_mesh),
                    residual: 0.0,
                    mirrored: false,
                    triangles: Vec::new(),
                })
                .collect(),
        });
    }
    (bytes, read, written_tolerance(mesh, instanced.residual))
}

fn multiply(a: &Matrix, b: &Matrix) -> Matrix {
    std::array::from_fn(|r| std::array::from_fn(|c| (0..4).map(|k| a[r][k] * b[k][c]).sum()))
}

/// The inverse of an affine transform.
fn inverse(m: &Matrix) -> Matrix {
    let a = glam::DMat4::from_cols_array_2d(m)
        .transpose()
        .inverse()
        .transpose();
    a.to_cols_array_2d()
}

/// The tolerance a written copy keeps to its source: twice the largest
/// residual of a placed copy, and the rounding of f32 coordinates as large
/// as the scene's.
fn written_tolerance(mesh: &TriMesh, residual: f64) -> f64 {
    let extent = mesh
        .positions()
        .iter()
        .flatten()
        .map(|x| f64::from(x.abs()))
        .fold(0.0, f64::max);
    2.0 * residual + 8.0 * f64::from(f32::EPSILON) * extent.max(1e-30)
}

#[test]
fn the_saw_written_instanced_keeps_every_triangle_and_every_family() {
    for scene in ["real-saw-roller", "real-truck-wheels"] {
        let bytes = std::fs::read(scene_dir(scene).join("scene.glb")).unwrap();
        let model = load_model(&bytes, None, &NoResources).unwrap();
        let (mesh, sources) = model.placed().unwrap();
        // The model places what the loader loads.
        let loaded = load(&bytes, None).unwrap();
        assert_eq!(mesh.positions(), loaded.positions(), "{scene}");
        assert_eq!(mesh.triangles(), loaded.triangles(), "{scene}");
        let families = split_by_material(
            &model,
            &mesh,
            &sources,
            find_repeats(&mesh, Threads::Parallel),
        );
        let (written, read, tolerance) = written_and_read_back(&model, &mesh, &sources, &families);
        let out = load(&written, None).unwrap();
        assert_eq!(
            unmatched_triangles(&mesh, &out, tolerance),
            0,
            "{scene}: input not in output"
        );
        assert_eq!(
            unmatched_triangles(&out, &mesh, tolerance),
            0,
            "{scene}: output not in input"
        );
        assert_eq!(out.triangles().len(), mesh.triangles().len(), "{scene}");
        assert_eq!(score(scene, &read), (vec![], 0), "{scene}");
        assert!(
            written.len() < bytes.len(),
            "{scene}: {} bytes, from {}",
            written.len(),
            bytes.len()
        );
    }
}

/// A cube of side 2 about the origin, as exporters write one: four
/// vertices a face with the face's normal and texture coordinates, faces
/// turned outwards.
fn textured_cube() -> Primitive {
    let (mut position, mut normal, mut uv, mut triangles) = (vec![], vec![], vec![], vec![]);
    for axis in 0..3 {
        for side in [-1.0f32, 1.0] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let base = position.len() as u32 / 3;
            for (k, (a, b)) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
                .into_iter()
                .enumerate()
            {
                let mut p = [0.0f32; 3];
                p[axis] = side;
                p[u] = a;
                p[v] = b;
                position.extend(p);
                let mut n = [0.0f32; 3];
                n[axis] = side;
                normal.extend(n);
                uv.extend([
                    0.25 * k as f32 + 0.1 * axis as f32,
                    0.5 * side + 0.01 * k as f32,
                ]);
            }
            let quad = if side > 0.0 {
                [0, 1, 2, 0, 2, 3]
            } else {
                [0, 2, 1, 0, 3, 2]
            };
            for t in quad.chunks(3) {
                triangles.push([base + t[0], base + t[1], base + t[2]]);
            }
        }
    }
    let attribute = |semantic: &str, width, values| Attribute {
        semantic: semantic.to_string(),
        width,
        values,
    };
    Primitive {
        attributes: vec![
            attribute("POSITION", 3, position),
            attribute("NORMAL", 3, normal),
            attribute("TEXCOORD_0", 2, uv),
        ],
        triangles,
        material: None,
    }
}

/// Every corner a model draws: where it stands, which way it faces, its
/// texture coordinates and its material, rounded, in one sorted list.
fn drawn_corners(model: &Model) -> Vec<[i64; 9]> {
    let mut corners = Vec::new();
    for node in &model.nodes {
        for m in &node.placements {
            let linear = glam::DMat3::from_cols_array_2d(&[
                [m[0][0], m[1][0], m[2][0]],
                [m[0][1], m[1][1], m[2][1]],
                [m[0][2], m[1][2], m[2][2]],
            ]);
            let normals = linear.inverse().transpose();
            for primitive in &model.meshes[node.mesh].primitives {
                let values = |semantic: &str| {
                    &primitive
                        .attributes
                        .iter()
                        .find(|a| a.semantic == semantic)
                        .unwrap()
                        .values
                };
                let (p, n, uv) = (values("POSITION"), values("NORMAL"), values("TEXCOORD_0"));
                for &v in primitive.triangles.iter().flatten() {
                    let v = v as usize;
                    let at = apply(m, [0, 1, 2].map(|k| f64::from(p[3 * v + k])));
                    let facing = (normals
                        * glam::DVec3::from_array([0, 1, 2].map(|k| f64::from(n[3 * v + k]))))
                    .normalize();
                    let round = |x: f64, step: f64| (x / step).round() as i64;
                    corners.push([
                        round(at[0], 1e-4),
                        round(at[1], 1e-4),
                        round(at[2], 1e-4),
                        round(facing.x, 1e-3),
                        round(facing.y, 1e-3),
                        round(facing.z, 1e-3),
                        round(uv[2 * v].into(), 1e-5),
                        round(uv[2 * v + 1].into(), 1e-5),
                        primitive.material.map_or(-1, i64::from),
                    ]);
                }
            }
        }
    }
    corners.sort_unstable();
    corners
}

#[test]
fn copies_drawn_in_other_materials_are_other_parts_and_keep_their_attributes() {
    use fast_reject::mesh::io::model::{MaterialTable, ModelMesh, ModelNode};
    use glam::{DMat3, DQuat};
    let place = |turn: f64, mirrored: bool, at: [f64; 3]| -> Matrix {
        let axis = Vec3::new(0.3, 1.0, 0.2 + turn).normalize();
        let mut r = DMat3::from_quat(DQuat::from_axis_angle(axis, 1.3 * turn + 0.4));
        if mirrored {
            r *= DMat3::from_diagonal(Vec3::new(1.0, -1.0, 1.0));
        }
        std::array::from_fn(|i| match i {
            3 => [0.0, 0.0, 0.0, 1.0],
            _ => [r.col(0)[i], r.col(1)[i], r.col(2)[i], at[i]],
        })
    };
    let cube = textured_cube();
    let mesh = |name: &str, material| ModelMesh {
        name: Some(name.to_string()),
        primitives: vec![Primitive {
            material: Some(material),
            ..cube.clone()
        }],
    };
    // Three red cubes and two blue ones, one of them a mirror image, each a
    // node of its own as a flattened export has them.
    let placements = [
        (0, 0.0, false),
        (0, 1.0, false),
        (0, 2.0, false),
        (1, 3.0, false),
        (1, 4.0, true),
    ];
    let input = Model {
        meshes: vec![mesh("red", 0), mesh("blue", 1)],
        nodes: placements
            .iter()
            .enumerate()
            .map(|(k, &(m, turn, mirrored))| ModelNode {
                name: Some(format!("cube {k}")),
                mesh: m,
                placements: vec![place(turn, mirrored, [10.0 * k as f64, 0.0, 0.0])],
            })
            .collect(),
        materials: MaterialTable {
            materials: vec![
                serde_json::json!({ "name": "red", "pbrMetallicRoughness": { "baseColorFactor": [1, 0, 0, 1] } }),
                serde_json::json!({ "name": "blue", "pbrMetallicRoughness": { "baseColorFactor": [0, 0, 1, 1] } }),
            ],
            ..MaterialTable::default()
        },
    };
    let bytes = write_glb(&input).unwrap();
    let model = load_model(&bytes, None, &NoResources).unwrap();
    let (mesh, sources) = model.placed().unwrap();
    let alike = find_repeats(&mesh, Threads::Parallel);
    // The shape alone: one part, five copies.
    assert_eq!(
        alike.iter().map(|f| f.copies.len()).collect::<Vec<_>>(),
        [5]
    );
    let families = split_by_material(&model, &mesh, &sources, alike);
    assert_eq!(
        families.iter().map(|f| f.copies.len()).collect::<Vec<_>>(),
        [3, 2]
    );
    assert_eq!(families[1].copies.iter().filter(|c| c.mirrored).count(), 1);
    let instanced = instanced_model(&model, &mesh, &sources, &families, Placement::Nodes);
    assert_eq!(instanced.kept_copies, 0);
    let back = load_model(&write_glb(&instanced.model).unwrap(), None, &NoResources).unwrap();
    // One mesh per material, placed five times, drawing what the input drew.
    assert_eq!(back.meshes.len(), 2);
    assert_eq!(back.nodes.len(), 5);
    assert_eq!(back.materials.materials, input.materials.materials);
    assert_eq!(drawn_corners(&back), drawn_corners(&input));
    let (out, _) = back.placed().unwrap();
    assert_eq!(unmatched_triangles(&mesh, &out, 1e-5), 0);
    assert_eq!(unmatched_triangles(&out, &mesh, 1e-5), 0);
}

#[test]
fn hidden_flattened_and_sheared_nodes_are_written_as_gltf_allows_and_drawn_as_before() {
    use fast_reject::mesh::io::model::{ModelMesh, ModelNode, trs};
    use glam::{DMat3, DMat4, DQuat, DVec3};
    let rows = |m: DMat4| -> Matrix { m.transpose().to_cols_array_2d() };
    let turn = |k: f64| DQuat::from_axis_angle(DVec3::new(0.3, 1.0, 0.2).normalize(), 0.7 * k);
    let at = |x: f64| DVec3::new(6.0 * x, 0.5 * x, 0.0);
    let placed = |k: f64, scale: DVec3| {
        rows(DMat4::from_scale_rotation_translation(
            scale,
            turn(k),
            at(k),
        ))
    };
    // A non-uniform scale on a parent over a turned child: a shear.
    let sheared = rows(
        DMat4::from_translation(at(5.0))
            * DMat4::from_scale(DVec3::new(2.0, 1.0, 1.0))
            * DMat4::from_mat3(DMat3::from_rotation_z(0.5)),
    );
    let placements = [
        placed(0.0, DVec3::ONE),
        placed(1.0, DVec3::ONE),
        placed(2.0, DVec3::ONE),
        placed(3.0, DVec3::ZERO),
        placed(4.0, DVec3::new(1.0, 1.0, 0.0)),
        sheared,
    ];
    assert!(trs(&sheared).is_none());
    for (k, p) in placements[..5].iter().enumerate() {
        let t = trs(p).unwrap_or_else(|| panic!("placement {k} is a turn and a scale"));
        let back = rows(DMat4::from_scale_rotation_translation(
            DVec3::from_array(t.scale),
            DQuat::from_array(t.rotation),
            DVec3::from_array(t.translation),
        ));
        for (a, b) in back.iter().flatten().zip(p.iter().flatten()) {
            assert!((a - b).abs() < 1e-9, "placement {k}: {back:?} for {p:?}");
        }
    }
    let model = Model {
        meshes: vec![ModelMesh {
            name: Some("cube".into()),
            primitives: vec![textured_cube()],
        }],
        nodes: placements
            .iter()
            .enumerate()
            .map(|(k, p)| ModelNode {
                name: Some(format!("cube {k}")),
                mesh: 0,
                placements: vec![*p],
            })
            .collect(),
        ..Model::default()
    };
    let (mesh, sources) = model.placed().unwrap();
    let families = find_repeats(&mesh, Threads::Serial);
    assert_eq!(families.len(), 1, "the three whole cubes");
    for placement in [Placement::Nodes, Placement::GpuInstancing] {
        let instanced = instanced_model(&model, &mesh, &sources, &families, placement);
        let written = write_glb(&instanced.model).unwrap();
        common::nodes_are_turns_and_scales(&written).unwrap();
        let (back, _) = load_model(&written, None, &NoResources)
            .unwrap()
            .placed()
            .unwrap();
        assert_eq!(back.triangles().len(), mesh.triangles().len());
        assert_eq!(unmatched_triangles(&mesh, &back, 1e-5), 0, "{placement:?}");
        assert_eq!(unmatched_triangles(&back, &mesh, 1e-5), 0, "{placement:?}");
    }
}

#[test]
fn a_placement_a_reader_would_round_flat_keeps_its_vertices_moved() {
    // Found by the fuzzer: coordinates near 1e37 placed by a parent's
    // non-uniform scale over a turned child; the node's matrix read back
    // in f32 flattened one triangle the loader had kept.
    let bytes = include_bytes!(
        "../fuzz/regressions/instance_gltf/sheared-looking-turn-of-huge-coordinates-read-back-in-f32"
    );
    let model = load_model(bytes, None, &NoResources).unwrap();
    let (mesh, sources) = model.placed().unwrap();
    let families = find_repeats(&mesh, Threads::Serial);
    for placement in [Placement::Nodes, Placement::GpuInstancing] {
        let instanced = instanced_model(&model, &mesh, &sources, &families, placement);
        let back = load(&write_glb(&instanced.model).unwrap(), None).unwrap();
        assert_eq!(
            back.triangles().len(),
            mesh.triangles().len(),
            "{placement:?}"
        );
    }
}

#[test]
fn a_copy_rounding_would_flatten_is_kept_as_it_was() {
    // Coordinates near 1e36 with triangles a few units across (found by
    // the fuzzer): the copy turned by a quarter turn matches within the
    // residual, but its triangles drawn through the node's f32 matrix
    // would lose their area, and a reader would drop them.
    let bytes =
        include_bytes!("../fuzz/regressions/instance_gltf/huge-coordinates-flatten-a-turned-copy");
    let model = load_model(bytes, None, &NoResources).unwrap();
    let (mesh, sources) = model.placed().unwrap();
    let families = find_repeats(&mesh, Threads::Serial);
    assert!(
        !families.is_empty(),
        "the two placements are found as copies"
    );
    let instanced = instanced_model(&model, &mesh, &sources, &families, Placement::Nodes);
    let back = load(&write_glb(&instanced.model).unwrap(), None).unwrap();
    assert_eq!(back.triangles().len(), mesh.triangles().len());
    assert_eq!(instanced.kept_copies, 2);
}

#[test]
fn finding_repeats_tells_each_step_and_stops_when_asked() {
    use fast_reject::{Error, LayerStats, Observer, Progress, find_repeats_observed};
    use std::ops::ControlFlow;
    struct Steps {
        told: Vec<(usize, usize)>,
        stop_at: usize,
    }
    impl Observer for Steps {
        fn on_layer(&mut self, _: &LayerStats) -> ControlFlow<()> {
            ControlFlow::Continue(())
        }
        fn on_progress(&mut self, p: &Progress) -> ControlFlow<()> {
            assert_eq!(p.step, Progress::REPEATS);
            self.told.push((p.done, p.total));
            match p.done >= self.stop_at {
                true => ControlFlow::Break(()),
                false => ControlFlow::Continue(()),
            }
        }
    }
    let bytes = std::fs::read(scene_dir("real-truck-wheels").join("scene.glb")).unwrap();
    let mesh = load(&bytes, None).unwrap();
    let mut all = Steps {
        told: Vec::new(),
        stop_at: usize::MAX,
    };
    let families = find_repeats_observed(&mesh, Threads::Serial, &mut all).unwrap();
    assert_eq!(families, find_repeats(&mesh, Threads::Serial));
    let total = all.told.len();
    assert!(total >= 3);
    assert_eq!(
        all.told,
        (1..=total).map(|d| (d, total)).collect::<Vec<_>>()
    );
    let mut stop = Steps {
        told: Vec::new(),
        stop_at: 2,
    };
    let stopped = find_repeats_observed(&mesh, Threads::Serial, &mut stop);
    assert!(matches!(stopped, Err(Error::Cancelled)));
    assert_eq!(stop.told.len(), 2);
}
