//! The repeated parts written back as an instanced model: each family's
//! geometry stored once, every copy a node that places it, and what
//! repeats nowhere as it was.
//!
//! A family's geometry is its representative's triangles with every
//! attribute of their source primitives, moved into a frame at the
//! family's centre (normals and tangents turned with them). A copy's node
//! places that frame by the copy's pose, so a mirror image is a node that
//! mirrors, as glTF allows. A placement none of whose triangles repeats
//! keeps its source mesh, shared again by every node that shared it.

use std::collections::HashMap;

use super::{Family, MirrorImages, RepeatCopy, congruent_parts};
use crate::exec::Threads;
use crate::math::Vec3;
use crate::mesh::TriMesh;
use crate::mesh::io::model::{
    Attribute, IDENTITY, Matrix, Model, ModelMesh, ModelNode, Primitive, TriangleSource, Trs,
    determinant, multiply, transform_point, trs,
};
use crate::mesh::is_degenerate;

/// How copies are placed in the written model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Placement {
    /// A node per copy, named after the node it came from.
    Nodes,
    /// One node per family with `EXT_mesh_gpu_instancing`.
    GpuInstancing,
}

/// `model` with each of `families` (found on `mesh`, whose triangles
/// came from `sources`) stored once and placed at each of its copies.
pub fn instanced_model(
    model: &Model,
    mesh: &TriMesh,
    sources: &[TriangleSource],
    families: &[Family],
    placement: Placement,
) -> Instanced {
    let mut taken = vec![false; sources.len()];
    let mut out = Model {
        materials: model.materials.clone(),
        ..Model::default()
    };
    let mut kept_copies = 0;
    let mut residual = 0.0f64;
    // Each family to write, and whether its representative is known to
    // reproduce every copy.
    let mut written: Vec<(Family, bool)> = Vec::with_capacity(families.len());
    let placed = Placed {
        model,
        mesh,
        sources,
    };
    for family in families {
        if family
            .copies
            .iter()
            .all(|copy| placed.reproduces(&family.copies[0].triangles, copy))
        {
            written.push((family.clone(), true));
        } else {
            written.extend(
                reproduced_families(&placed, family)
                    .into_iter()
                    .map(|f| (f, false)),
            );
        }
    }
    for (f, (family, all_reproduced)) in written.iter().enumerate() {
        let frame = translation(family.center);
        // A copy the representative does not reproduce triangle for
        // triangle (a symmetric piece stored turned, its diagonals the
        // other way) stays as it was.
        let exact: Vec<&RepeatCopy> = family
            .copies
            .iter()
            .filter(|copy| *all_reproduced || placed.reproduces(&family.copies[0].triangles, copy))
            .collect();
        let shape = family_mesh(model, sources, family, f);
        // Where coordinates dwarf a copy's triangles, rounding a triangle
        // through the frame and the node's f32 matrix can flatten it: such
        // a copy stays as it was too.
        let (exact, nodes): (Vec<&RepeatCopy>, Vec<(Option<String>, Matrix)>) = exact
            .into_iter()
            .map(|copy| {
                let at = multiply(&copy.pose, &frame);
                (copy, (copy_name(model, sources, copy, f), at))
            })
            .filter(|(_, (_, at))| draws_every_triangle(&shape, at))
            .unzip();
        kept_copies += family.copies.len() - exact.len();
        if exact.len() < 2 {
            continue;
        }
        residual = exact.iter().map(|c| c.residual).fold(residual, f64::max);
        out.meshes.push(shape);
        let m = out.meshes.len() - 1;
        for copy in &exact {
            for &t in &copy.triangles {
                taken[t as usize] = true;
            }
        }
        match placement {
            Placement::Nodes => out
                .nodes
                .extend(nodes.into_iter().map(|(name, at)| ModelNode {
                    name,
                    mesh: m,
                    placements: vec![at],
                })),
            Placement::GpuInstancing => out.nodes.push(ModelNode {
                name: Some(format!("repeat {f}")),
                mesh: m,
                placements: nodes.into_iter().map(|(_, at)| at).collect(),
            }),
        }
    }
    keep_the_rest(model, sources, &taken, &mut out);
    debug_assert_eq!(mesh.triangles().len(), sources.len());
    Instanced {
        model: out,
        kept_copies,
        residual,
    }
}

/// A family whose body pose does not reproduce every copy (a symmetric
/// piece stored turned, its diagonals the other way; a mirror image left
/// inside out), as the copies it reproduces whole, and the families of the
/// rest's stored pieces (triangles joined by shared vertices) by their own
/// motions, vertex for vertex; where it reproduces none whole, as the part
/// of the body it does reproduce in every copy, and the families of the
/// rest's pieces.
fn reproduced_families(placed: &Placed, family: &Family) -> Vec<Family> {
    let mesh = placed.mesh;
    let lead = &family.copies[0];
    // Where the body pose reproduces some copies whole, they stay one
    // family; the others' pieces find their own (a mirror image left
    // inside out is drawn by none).
    let (whole, rest): (Vec<&RepeatCopy>, Vec<&RepeatCopy>) = family.copies[1..]
        .iter()
        .partition(|copy| placed.reproduces(&lead.triangles, copy));
    if !whole.is_empty() {
        let pieces: Vec<Vec<u32>> = rest
            .iter()
            .flat_map(|copy| stored_pieces_of(mesh, &copy.triangles))
            .collect();
        let mut out = vec![Family {
            copies: std::iter::once(lead).chain(whole).cloned().collect(),
            ..family.clone()
        }];
        out.extend(piece_families(mesh, &pieces, family.radius));
        return out;
    }
    let landings: Vec<Vec<Option<u32>>> = family.copies[1..]
        .iter()
        .map(|copy| placed.landing(&lead.triangles, copy))
        .collect();
    let (mut good, mut bad) = (Vec::new(), Vec::new());
    for piece in stored_pieces_of(mesh, &lead.triangles) {
        let index: Vec<usize> = piece
            .iter()
            .map(|t| {
                lead.triangles
                    .binary_search(t)
                    .expect("a piece of the lead")
            })
            .collect();
        match landings
            .iter()
            .all(|l| index.iter().all(|&i| l[i].is_some()))
        {
            true => good.extend(index),
            false => bad.push(piece),
        }
    }
    let mut out = Vec::new();
    let mut rest: Vec<Vec<u32>> = bad;
    let mut copies = vec![RepeatCopy {
        triangles: good.iter().map(|&i| lead.triangles[i]).collect(),
        ..lead.clone()
    }];
    for (copy, landing) in family.copies[1..].iter().zip(&landings) {
        let mine: Vec<u32> = good.iter().filter_map(|&i| landing[i]).collect();
        let mut others = copy.triangles.clone();
        others.retain(|t| !mine.contains(t));
        rest.extend(stored_pieces_of(mesh, &others));
        copies.push(RepeatCopy {
            triangles: mine,
            ..copy.clone()
        });
    }
    if !good.is_empty() {
        out.push(Family {
            copies,
            ..family.clone()
        });
    }
    out.extend(piece_families(mesh, &rest, family.radius));
    out
}

/// The families among `pieces` (triangle lists), each copied vertex for
/// vertex, mirror images included.
fn piece_families(mesh: &TriMesh, pieces: &[Vec<u32>], radius: f64) -> Vec<Family> {
    let lists: Vec<&[u32]> = pieces.iter().map(Vec::as_slice).collect();
    let copies = congruent_parts(mesh, &lists, Threads::Serial, MirrorImages::Accepted);
    let mut groups: Vec<(usize, Vec<RepeatCopy>)> = Vec::new();
    for (k, copy) in copies.iter().enumerate() {
        let Some(copy) = copy else { continue };
        let repeat = RepeatCopy {
            pose: copy.motion.to_rows(),
            residual: copy.residual,
            mirrored: copy.mirrored(),
            triangles: pieces[k].clone(),
        };
        match groups.iter_mut().find(|(o, _)| *o == copy.original) {
            Some((_, list)) => list.push(repeat),
            None => groups.push((copy.original, vec![repeat])),
        }
    }
    groups
        .into_iter()
        .map(|(original, more)| {
            let lead = &pieces[original];
            let vertices = mesh.vertices_of(lead);
            let center =
                vertices.iter().map(|&v| mesh.vertex(v)).sum::<Vec3>() / vertices.len() as f64;
            let mut copies = vec![RepeatCopy {
                pose: IDENTITY,
                residual: 0.0,
                mirrored: false,
                triangles: lead.clone(),
            }];
            copies.extend(more);
            Family {
                center,
                radius,
                pieces: 1,
                copies,
            }
        })
        .collect()
}

/// `triangles` split where they share no vertex (by index).
fn stored_pieces_of(mesh: &TriMesh, triangles: &[u32]) -> Vec<Vec<u32>> {
    let mut parent: HashMap<u32, u32> = HashMap::new();
    fn root(parent: &mut HashMap<u32, u32>, v: u32) -> u32 {
        let mut r = v;
        while let Some(&p) = parent.get(&r).filter(|&&p| p != r) {
            r = p;
        }
        parent.insert(v, r);
        r
    }
    for &t in triangles {
        let [a, b, c] = mesh.triangles()[t as usize];
        for v in [a, b, c] {
            parent.entry(v).or_insert(v);
        }
        let ra = root(&mut parent, a);
        for v in [b, c] {
            let rv = root(&mut parent, v);
            parent.insert(rv, ra);
        }
    }
    let mut pieces: Vec<Vec<u32>> = Vec::new();
    let mut index: HashMap<u32, usize> = HashMap::new();
    for &t in triangles {
        let r = root(&mut parent, mesh.triangles()[t as usize][0]);
        let k = *index.entry(r).or_insert_with(|| {
            pieces.push(Vec::new());
            pieces.len() - 1
        });
        pieces[k].push(t);
    }
    pieces
}

/// An instanced model, and how many copies of its families it stores as
/// they were, because their representative does not reproduce them.
#[derive(Clone, Debug)]
pub struct Instanced {
    pub model: Model,
    pub kept_copies: usize,
    /// The largest residual of a copy placed by its family's mesh: its
    /// triangles lie within twice that (and f32 rounding) of the source's.
    pub residual: f64,
}

/// The placed mesh with each triangle's source in the model.
struct Placed<'a> {
    model: &'a Model,
    mesh: &'a TriMesh,
    sources: &'a [TriangleSource],
}

impl Placed<'_> {
    /// Whether `lead`'s triangles moved by `copy`'s pose are `copy`'s (see
    /// [`Placed::landing`]).
    fn reproduces(&self, lead: &[u32], copy: &RepeatCopy) -> bool {
        lead.len() == copy.triangles.len() && self.landing(lead, copy).iter().all(Option::is_some)
    }

    /// For each triangle of `lead` moved by `copy`'s pose, the triangle of
    /// `copy` it lands on: corner for corner in the order a renderer reads
    /// them (turned where the pose mirrors), within twice the copy's
    /// residual and the rounding of f32 coordinates where it stands, with
    /// the same material and the same texture coordinates, colours and
    /// other attributes that do not turn with the part.
    fn landing(&self, lead: &[u32], copy: &RepeatCopy) -> Vec<Option<u32>> {
        let mesh = self.mesh;
        let extent = copy
            .triangles
            .iter()
            .flat_map(|&t| mesh.corners(t as usize))
            .map(|p| p.abs().max_element())
            .fold(0.0, f64::max);
        let tolerance = (2.0 * copy.residual + 8.0 * f64::from(f32::EPSILON) * extent).max(1e-300);
        let turned = determinant(&copy.pose) < 0.0;
        // `t` moved, its corners in the order a renderer reads them, and
        // which of its own corners each is.
        let moved_corners = |t: u32| {
            let [a, b, c] = mesh.corners(t as usize).map(|p| moved(&copy.pose, p));
            match turned {
                true => ([a, c, b], [0, 2, 1]),
                false => ([a, b, c], [0, 1, 2]),
            }
        };
        let lands = |t: u32, u: u32, corners: &[Vec3; 3], order: &[usize; 3]| {
            let other = mesh.corners(u as usize);
            (0..3).any(|turn| {
                (0..3).all(|i| {
                    let j = (i + turn) % 3;
                    corners[i].distance(other[j]) <= tolerance
                        && self.same_attributes(t, order[i], u, j)
                })
            })
        };
        // A copy stored as its representative was lists its triangles in
        // the same order: most land on their namesakes.
        if lead.len() == copy.triangles.len()
            && lead.iter().zip(&copy.triangles).all(|(&t, &u)| {
                let (corners, order) = moved_corners(t);
                lands(t, u, &corners, &order)
            })
        {
            return copy.triangles.iter().map(|&u| Some(u)).collect();
        }
        let key = |p: Vec3| [p.x, p.y, p.z].map(|x| (x / tolerance).floor() as i64);
        let centroid = |c: [Vec3; 3]| (c[0] + c[1] + c[2]) / 3.0;
        let mut at: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        for &t in &copy.triangles {
            at.entry(key(centroid(mesh.corners(t as usize))))
                .or_default()
                .push(t);
        }
        lead.iter()
            .map(|&t| {
                let (corners, order) = moved_corners(t);
                let k = key(centroid(corners));
                (0..27).find_map(|d| {
                    let near = [k[0] + d % 3 - 1, k[1] + d / 3 % 3 - 1, k[2] + d / 9 - 1];
                    at.get(&near)?
                        .iter()
                        .copied()
                        .find(|&u| lands(t, u, &corners, &order))
                })
            })
            .collect()
    }

    /// The primitive and vertex behind corner `corner` of placed triangle
    /// `t`.
    fn corner(&self, t: u32, corner: usize) -> (&Primitive, usize) {
        let s = self.sources[t as usize];
        let node = &self.model.nodes[s.node as usize];
        let primitive = &self.model.meshes[node.mesh].primitives[s.primitive as usize];
        // A mirroring placement's triangles were turned when placed.
        let turned = determinant(&node.placements[s.placement as usize]) < 0.0;
        let source = if turned { [0, 2, 1][corner] } else { corner };
        (
            primitive,
            primitive.triangles[s.triangle as usize][source] as usize,
        )
    }

    /// Whether two placed corners have one material and the same values of
    /// every attribute that does not turn with the part.
    fn same_attributes(&self, t: u32, i: usize, u: u32, j: usize) -> bool {
        let ((p, v), (q, w)) = (self.corner(t, i), self.corner(u, j));
        if p.material != q.material || p.attributes.len() != q.attributes.len() {
            return false;
        }
        p.attributes.iter().all(|a| {
            if matches!(a.semantic.as_str(), "POSITION" | "NORMAL" | "TANGENT") {
                return true;
            }
            q.attributes
                .iter()
                .find(|b| b.semantic == a.semantic && b.width == a.width)
                .is_some_and(|b| {
                    let x = &a.values[v * a.width..][..a.width];
                    let y = &b.values[w * b.width..][..b.width];
                    x.iter()
                        .zip(y)
                        .all(|(x, y)| (x - y).abs() <= 1e-6 * x.abs().max(y.abs()).max(1.0))
                })
        })
    }
}

/// Whether `mesh` placed by `at`, read back as a glTF reader reads it
/// (the matrix in f32, each point rounded to f32), keeps every triangle's
/// area.
fn draws_every_triangle(mesh: &ModelMesh, at: &Matrix) -> bool {
    let read = at.map(|row| row.map(|v| f64::from(v as f32)));
    mesh.primitives.iter().all(|primitive| {
        let Ok(local) = primitive.positions() else {
            return false;
        };
        let world: Vec<[f32; 3]> = local.iter().map(|&p| transform_point(&read, p)).collect();
        primitive
            .triangles
            .iter()
            .all(|&t| !is_degenerate(&world, t))
    })
}

/// Whether `mesh` placed by `at` (whose parts are `trs`), read back as a
/// glTF reader reads the node the writer makes of it (a matrix, or the
/// parts for a singular one, in f32), has the same triangles flat as
/// placed by `at` itself.
fn reads_back_alike(mesh: &ModelMesh, at: &Matrix, trs: &Trs) -> bool {
    let read = match trs.is_singular() {
        true => {
            let f = |v: [f64; 3]| glam::DVec3::from_array(v.map(|x| f64::from(x as f32)));
            let [x, y, z, w] = trs.rotation.map(|x| f64::from(x as f32));
            let m = glam::DMat4::from_scale_rotation_translation(
                f(trs.scale),
                glam::DQuat::from_xyzw(x, y, z, w),
                f(trs.translation),
            );
            m.transpose().to_cols_array_2d()
        }
        false => at.map(|row| row.map(|v| f64::from(v as f32))),
    };
    mesh.primitives.iter().all(|primitive| {
        let Ok(local) = primitive.positions() else {
            return false;
        };
        let placed: Vec<[f32; 3]> = local.iter().map(|&p| transform_point(at, p)).collect();
        let drawn: Vec<[f32; 3]> = local.iter().map(|&p| transform_point(&read, p)).collect();
        primitive
            .triangles
            .iter()
            .all(|&t| is_degenerate(&placed, t) == is_degenerate(&drawn, t))
    })
}

/// The representative's triangles, grouped by source primitive, in the
/// family's frame.
fn family_mesh(model: &Model, sources: &[TriangleSource], family: &Family, f: usize) -> ModelMesh {
    let mut groups: Vec<((u32, u32, u32), Vec<u32>)> = Vec::new();
    for &t in &family.copies[0].triangles {
        let s = sources[t as usize];
        let key = (s.node, s.placement, s.primitive);
        match groups.iter_mut().find(|(k, _)| *k == key) {
            Some((_, list)) => list.push(s.triangle),
            None => groups.push((key, vec![s.triangle])),
        }
    }
    let to_frame = translation(-family.center);
    let primitives = groups
        .into_iter()
        .map(|((n, p, k), triangles)| {
            let node = &model.nodes[n as usize];
            let source = &model.meshes[node.mesh].primitives[k as usize];
            let world = multiply(&to_frame, &node.placements[p as usize]);
            moved_subset(source, &triangles, &world)
        })
        .collect();
    ModelMesh {
        name: Some(format!("repeat {f}")),
        primitives,
    }
}

/// A copy's node name: the source node's, where the copy's triangles all
/// come from one.
fn copy_name(
    model: &Model,
    sources: &[TriangleSource],
    copy: &RepeatCopy,
    f: usize,
) -> Option<String> {
    let first = sources[copy.triangles[0] as usize].node;
    let one = copy
        .triangles
        .iter()
        .all(|&t| sources[t as usize].node == first);
    match (one, &model.nodes[first as usize].name) {
        (true, Some(name)) => Some(name.clone()),
        _ => Some(format!("repeat {f}")),
    }
}

/// Every placement's triangles no family took, as they were: a placement
/// that lost none keeps its source mesh (shared by the nodes that shared
/// it), one that lost some a mesh of the rest.
fn keep_the_rest(model: &Model, sources: &[TriangleSource], taken: &[bool], out: &mut Model) {
    // Per placement, its primitives' taken triangles.
    let mut lost: HashMap<(u32, u32), Vec<Vec<u32>>> = HashMap::new();
    for (s, &took) in sources.iter().zip(taken) {
        if took {
            let primitives = model.meshes[model.nodes[s.node as usize].mesh]
                .primitives
                .len();
            lost.entry((s.node, s.placement))
                .or_insert_with(|| vec![Vec::new(); primitives])[s.primitive as usize]
                .push(s.triangle);
        }
    }
    let mut whole: HashMap<usize, usize> = HashMap::new();
    for (n, node) in model.nodes.iter().enumerate() {
        let source = &model.meshes[node.mesh];
        for (p, &placement) in node.placements.iter().enumerate() {
            // A shear (a non-uniform scale over a turned child) is no
            // placement glTF can hold, and one that a reader's f32 matrix
            // would draw with other triangles flat (huge coordinates) is
            // not what was read: their vertices are moved instead.
            let (at, moved_by) = match trs(&placement) {
                Some(t) if reads_back_alike(source, &placement, &t) => (placement, IDENTITY),
                _ => (IDENTITY, placement),
            };
            let mesh = match lost.get(&(n as u32, p as u32)) {
                None if moved_by == IDENTITY => *whole.entry(node.mesh).or_insert_with(|| {
                    out.meshes.push(source.clone());
                    out.meshes.len() - 1
                }),
                None => {
                    out.meshes.push(ModelMesh {
                        name: source.name.clone(),
                        primitives: source
                            .primitives
                            .iter()
                            .map(|primitive| {
                                let all: Vec<u32> = (0..primitive.triangles.len() as u32).collect();
                                moved_subset(primitive, &all, &moved_by)
                            })
                            .collect(),
                    });
                    out.meshes.len() - 1
                }
                Some(lost) => {
                    let primitives: Vec<Primitive> = source
                        .primitives
                        .iter()
                        .zip(lost)
                        .filter_map(|(primitive, lost)| {
                            let mut gone = vec![false; primitive.triangles.len()];
                            for &t in lost {
                                gone[t as usize] = true;
                            }
                            let rest: Vec<u32> = (0..primitive.triangles.len() as u32)
                                .filter(|&t| !gone[t as usize])
                                .collect();
                            (!rest.is_empty()).then(|| moved_subset(primitive, &rest, &moved_by))
                        })
                        .collect();
                    if primitives.is_empty() {
                        continue;
                    }
                    out.meshes.push(ModelMesh {
                        name: source.name.clone(),
                        primitives,
                    });
                    out.meshes.len() - 1
                }
            };
            out.nodes.push(ModelNode {
                name: node.name.clone(),
                mesh,
                placements: vec![at],
            });
        }
    }
}

/// `triangles` of `source` with the vertices they use, moved by `m`: points
/// by it, normals by its inverse transpose, tangents by its linear part;
/// where `m` mirrors, each triangle's corners turned, so that it still
/// faces out.
fn moved_subset(source: &Primitive, triangles: &[u32], m: &Matrix) -> Primitive {
    let mut new_index: HashMap<u32, u32> = HashMap::new();
    let mut used = Vec::new();
    let turned = determinant(m) < 0.0;
    let triangles: Vec<[u32; 3]> = triangles
        .iter()
        .map(|&t| {
            let [a, b, c] = source.triangles[t as usize];
            let corners = if turned { [a, c, b] } else { [a, b, c] };
            corners.map(|v| {
                *new_index.entry(v).or_insert_with(|| {
                    used.push(v);
                    used.len() as u32 - 1
                })
            })
        })
        .collect();
    let linear = linear_part(m);
    let normals = inverse_transpose(&linear);
    let sign = if turned { -1.0 } else { 1.0 };
    let moving = *m != IDENTITY;
    let attributes = source
        .attributes
        .iter()
        .map(|a| {
            let mut values = Vec::with_capacity(used.len() * a.width);
            for &v in &used {
                let x = &a.values[v as usize * a.width..][..a.width];
                match (moving, a.semantic.as_str(), a.width) {
                    (true, "POSITION", 3) => values.extend(
                        crate::mesh::io::model::transform_point(m, [x[0], x[1], x[2]]),
                    ),
                    (true, "NORMAL", 3) => values.extend(apply(&normals, x)),
                    (true, "TANGENT", 4) => {
                        values.extend(apply(&linear, x));
                        values.push(x[3] * sign);
                    }
                    _ => values.extend_from_slice(x),
                }
            }
            Attribute {
                semantic: a.semantic.clone(),
                width: a.width,
                values,
            }
        })
        .collect();
    Primitive {
        attributes,
        triangles,
        material: source.material,
    }
}

fn translation(v: Vec3) -> Matrix {
    let mut m = IDENTITY;
    m[0][3] = v.x;
    m[1][3] = v.y;
    m[2][3] = v.z;
    m
}

fn linear_part(m: &Matrix) -> [[f64; 3]; 3] {
    std::array::from_fn(|r| std::array::from_fn(|c| m[r][c]))
}

/// The inverse transpose of `a` (the cofactor matrix over the
/// determinant): what turns normals.
fn inverse_transpose(a: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let cofactor = |r: usize, c: usize| {
        let (r1, r2) = ((r + 1) % 3, (r + 2) % 3);
        let (c1, c2) = ((c + 1) % 3, (c + 2) % 3);
        a[r1][c1] * a[r2][c2] - a[r1][c2] * a[r2][c1]
    };
    let det: f64 = (0..3).map(|c| a[0][c] * cofactor(0, c)).sum();
    std::array::from_fn(|r| std::array::from_fn(|c| cofactor(r, c) / det))
}

/// `a` applied to the first three values of `x`, as f32.
fn apply(a: &[[f64; 3]; 3], x: &[f32]) -> [f32; 3] {
    let [p, q, r] = [x[0], x[1], x[2]].map(f64::from);
    std::array::from_fn(|row| (a[row][0] * p + a[row][1] * q + a[row][2] * r) as f32)
}

/// The triangles of family copies whose materials differ from their
/// representative's, moved into families of their own (or out of every
/// family, alone): parts with different materials are different parts.
pub fn split_by_material(
    model: &Model,
    mesh: &TriMesh,
    sources: &[TriangleSource],
    families: Vec<Family>,
) -> Vec<Family> {
    split_by_material_counted(model, mesh, sources, families).0
}

/// [`split_by_material`], and how many pairs of copies it compared
/// triangle by triangle.
///
/// Each copy is led by the first remaining copy of its family that it
/// matches, as before; but a copy is compared only with copies that use
/// the same materials as many times each (a copy's triangles land one to
/// one on its match's, so they do wherever it matches): comparing each
/// remaining copy with each lead was quadratic, 10 000 copies each in a
/// material of its own took minutes.
pub(crate) fn split_by_material_counted(
    model: &Model,
    mesh: &TriMesh,
    sources: &[TriangleSource],
    families: Vec<Family>,
) -> (Vec<Family>, usize) {
    let material = |t: u32| {
        let s = sources[t as usize];
        model.meshes[model.nodes[s.node as usize].mesh].primitives[s.primitive as usize].material
    };
    if (0..sources.len() as u32).all(|t| material(t).is_none()) {
        return (families, 0);
    }
    let mut compared = 0;
    // The families found, by the place of their lead among the copies
    // (its family, then its copy): each family's copies split as before,
    // in the order the leads had.
    let mut out: Vec<((usize, usize), Family)> = Vec::new();
    for (f, family) in families.into_iter().enumerate() {
        // The copies by the materials they use, each with its count.
        let mut by_materials: HashMap<Vec<(Option<u32>, u32)>, Vec<usize>> = HashMap::new();
        for (c, copy) in family.copies.iter().enumerate() {
            let mut used: Vec<Option<u32>> = copy.triangles.iter().map(|&t| material(t)).collect();
            used.sort_unstable();
            let mut counted: Vec<(Option<u32>, u32)> = Vec::new();
            for m in used {
                match counted.last_mut() {
                    Some((last, count)) if *last == m => *count += 1,
                    _ => counted.push((m, 1)),
                }
            }
            by_materials.entry(counted).or_default().push(c);
        }
        let mut buckets: Vec<Vec<usize>> = by_materials.into_values().collect();
        buckets.sort_unstable_by_key(|bucket| bucket[0]);
        for bucket in buckets {
            let mut rest: Vec<usize> = bucket;
            while rest.len() >= 2 {
                let lead_at = rest.remove(0);
                let lead = &family.copies[lead_at];
                let back = inverse_rigid(&lead.pose);
                let (same, other): (Vec<usize>, Vec<usize>) = rest.into_iter().partition(|&c| {
                    let c = &family.copies[c];
                    let relative = multiply(&c.pose, &back);
                    // Where the two copies' vertices may lie apart.
                    let tolerance = (2.0 * (c.residual + lead.residual))
                        .max(family.radius * 1e-6)
                        .max(1e-12);
                    compared += 1;
                    same_materials(
                        mesh,
                        &lead.triangles,
                        &c.triangles,
                        &relative,
                        tolerance,
                        &material,
                    )
                });
                rest = other;
                if same.is_empty() {
                    continue;
                }
                let centre = moved(&lead.pose, family.center);
                let mut copies = vec![RepeatCopy {
                    pose: IDENTITY,
                    residual: 0.0,
                    mirrored: false,
                    triangles: lead.triangles.clone(),
                }];
                copies.extend(same.into_iter().map(|c| {
                    let c = &family.copies[c];
                    RepeatCopy {
                        pose: multiply(&c.pose, &back),
                        // At most the two copies' own residuals apart.
                        residual: c.residual + lead.residual,
                        mirrored: c.mirrored != lead.mirrored,
                        triangles: c.triangles.clone(),
                    }
                }));
                out.push((
                    (f, lead_at),
                    Family {
                        center: centre,
                        radius: family.radius,
                        pieces: family.pieces,
                        copies,
                    },
                ));
            }
        }
    }
    out.sort_by_key(|&(lead, _)| lead);
    let mut out: Vec<Family> = out.into_iter().map(|(_, family)| family).collect();
    out.sort_by_key(|f| std::cmp::Reverse(f.triangles() * f.copies.len()));
    (out, compared)
}

/// Whether every triangle of `lead`, moved by `pose`, lands on a triangle
/// of `copy` with its material (their centroids within `tolerance`).
fn same_materials(
    mesh: &TriMesh,
    lead: &[u32],
    copy: &[u32],
    pose: &Matrix,
    tolerance: f64,
    material: &dyn Fn(u32) -> Option<u32>,
) -> bool {
    let centroid = |t: u32| {
        let [a, b, c] = mesh.corners(t as usize);
        (a + b + c) / 3.0
    };
    let cell = tolerance;
    let key = |p: Vec3| [p.x, p.y, p.z].map(|x| (x / cell).floor() as i64);
    let mut at: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    for &t in copy {
        at.entry(key(centroid(t))).or_default().push(t);
    }
    lead.iter().all(|&t| {
        let p = moved(pose, centroid(t));
        let k = key(p);
        let want = material(t);
        (0..27).any(|d| {
            let near = [k[0] + d % 3 - 1, k[1] + d / 3 % 3 - 1, k[2] + d / 9 - 1];
            at.get(&near).is_some_and(|list| {
                list.iter()
                    .any(|&u| material(u) == want && centroid(u).distance(p) <= cell)
            })
        })
    })
}

fn moved(m: &Matrix, p: Vec3) -> Vec3 {
    Vec3::new(
        m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3],
        m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3],
        m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3],
    )
}

/// The inverse of a rigid motion (or a reflection): the transposed linear
/// part, and the translation turned back.
fn inverse_rigid(m: &Matrix) -> Matrix {
    let mut inverse = IDENTITY;
    for r in 0..3 {
        for c in 0..3 {
            inverse[r][c] = m[c][r];
        }
    }
    for r in 0..3 {
        inverse[r][3] = -(0..3).map(|k| inverse[r][k] * m[k][3]).sum::<f64>();
    }
    inverse
}

#[cfg(test)]
mod split_tests {
    use super::*;
    use crate::mesh::io::model::ModelNode;
    use crate::mesh::shapes::cuboid;
    use crate::repeats::find_repeats;

    /// `n` copies of one box, each a node whose mesh is drawn in
    /// material `k % materials`.
    fn boxes(n: usize, materials: usize) -> Model {
        let shape = cuboid(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0));
        let mesh = |material: usize| ModelMesh {
            name: None,
            primitives: vec![Primitive {
                attributes: vec![Attribute {
                    semantic: "POSITION".to_string(),
                    width: 3,
                    values: shape.positions().iter().flatten().copied().collect(),
                }],
                triangles: shape.triangles().to_vec(),
                material: Some(material as u32),
            }],
        };
        Model {
            meshes: (0..materials).map(mesh).collect(),
            nodes: (0..n)
                .map(|k| {
                    let mut at = IDENTITY;
                    at[0][3] = 5.0 * (k % 32) as f64;
                    at[1][3] = 5.0 * (k / 32) as f64;
                    ModelNode {
                        name: None,
                        mesh: k % materials,
                        placements: vec![at],
                    }
                })
                .collect(),
            materials: Default::default(),
        }
    }

    #[test]
    fn copies_in_materials_of_their_own_are_compared_a_linear_number_of_times() {
        for n in [200, 400, 800] {
            for materials in [n, 7] {
                let model = boxes(n, materials);
                let (mesh, sources) = model.placed().unwrap();
                let alike = find_repeats(&mesh, Threads::Serial);
                assert_eq!(alike.len(), 1);
                assert_eq!(alike[0].copies.len(), n);
                let (families, compared) =
                    split_by_material_counted(&model, &mesh, &sources, alike);
                // As many families as materials that two copies or more use.
                let expected = if materials == n { 0 } else { materials };
                assert_eq!(families.len(), expected);
                // Each copy is compared with the lead of its material once:
                // every pair was n (n - 1) / 2.
                assert!(
                    compared < n,
                    "{n} copies, {materials} materials: {compared}"
                );
            }
        }
    }
}
