//! A model as a file holds it, for writing it back changed: meshes of
//! primitives with every vertex attribute, placed by nodes, and the file's
//! materials.
//!
//! The search needs positions only ([`TriMesh`]); a model that is written
//! out again (an instanced glTF) must keep what a viewer draws: normals,
//! texture coordinates, colours and materials. [`Model::placed`] places it
//! as the loaders do, with each triangle's source, so that what the search
//! finds on the mesh can be written back in the model's own terms.

use crate::error::{Error, Result};
use crate::mesh::{Part, TriMesh, is_degenerate};

/// A row-major 4x4 transform, as instances' poses are.
pub type Matrix = [[f64; 4]; 4];

/// The identity transform.
pub const IDENTITY: Matrix = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

/// Meshes, the nodes that place them, and the materials they use.
#[derive(Clone, Debug, Default)]
pub struct Model {
    pub meshes: Vec<ModelMesh>,
    pub nodes: Vec<ModelNode>,
    /// The glTF's materials, textures, samplers and images; empty for the
    /// formats without them.
    pub materials: MaterialTable,
}

/// A mesh: its primitives, each drawn with one material.
#[derive(Clone, Debug, Default)]
pub struct ModelMesh {
    pub name: Option<String>,
    pub primitives: Vec<Primitive>,
}

/// Triangles over vertices that carry attributes.
#[derive(Clone, Debug, Default)]
pub struct Primitive {
    /// `POSITION` first, then the others the file has, in its order.
    pub attributes: Vec<Attribute>,
    pub triangles: Vec<[u32; 3]>,
    /// An index into [`MaterialTable::materials`].
    pub material: Option<u32>,
}

/// One vertex attribute, its values as floats (integer encodings
/// dequantized as glTF defines them).
#[derive(Clone, Debug, PartialEq)]
pub struct Attribute {
    /// The glTF semantic: `POSITION`, `NORMAL`, `TANGENT`, `TEXCOORD_0`, ...
    pub semantic: String,
    /// Values per vertex (1 to 4).
    pub width: usize,
    pub values: Vec<f32>,
}

/// A node: a mesh placed once, or at several places.
#[derive(Clone, Debug)]
pub struct ModelNode {
    pub name: Option<String>,
    pub mesh: usize,
    /// Where the mesh stands: model to world, one per copy.
    pub placements: Vec<Matrix>,
}

/// Materials as the glTF's JSON holds them, written back unchanged: only
/// their images move (into the written file's buffer).
#[derive(Clone, Debug, Default)]
pub struct MaterialTable {
    pub materials: Vec<gltf::json::Value>,
    pub textures: Vec<gltf::json::Value>,
    pub samplers: Vec<gltf::json::Value>,
    pub images: Vec<Image>,
    /// Extensions the materials and textures use, and those of them the
    /// file required.
    pub extensions_used: Vec<String>,
    pub extensions_required: Vec<String>,
}

/// An image: its JSON (name, mime type) and where its bytes are.
#[derive(Clone, Debug)]
pub struct Image {
    /// The image's JSON without `bufferView` and `uri`.
    pub json: gltf::json::Value,
    pub data: ImageData,
}

/// An image's bytes, or a `data:` URI that holds them, or the reference
/// to a file that could not be read.
#[derive(Clone, Debug)]
pub enum ImageData {
    /// Shared by the images of one file (read once, written once).
    Bytes(std::sync::Arc<Vec<u8>>),
    DataUri(String),
    /// Missing, refused or too large: written back as the reference it
    /// was, so that a viewer beside the file still finds it.
    Unread {
        uri: String,
        /// Why, in words.
        reason: String,
    },
}

/// Where a placed triangle comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TriangleSource {
    pub node: u32,
    pub placement: u32,
    pub primitive: u32,
    pub triangle: u32,
}

impl Model {
    /// A model of one mesh of positions only, placed once where it is:
    /// what the formats without nodes or materials hold.
    pub fn of_mesh(mesh: &TriMesh) -> Model {
        let values = mesh.positions().iter().flatten().copied().collect();
        Model {
            meshes: vec![ModelMesh {
                name: None,
                primitives: vec![Primitive {
                    attributes: vec![Attribute {
                        semantic: "POSITION".to_string(),
                        width: 3,
                        values,
                    }],
                    triangles: mesh.triangles().to_vec(),
                    material: None,
                }],
            }],
            nodes: vec![ModelNode {
                name: None,
                mesh: 0,
                placements: vec![IDENTITY],
            }],
            materials: MaterialTable::default(),
        }
    }

    /// The mesh the loaders build (every placement in world space, a
    /// mirroring placement's triangles turned so that they face out, no
    /// triangle without area), with each triangle's source.
    pub fn placed(&self) -> Result<(TriMesh, Vec<TriangleSource>)> {
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        let mut sources = Vec::new();
        let mut parts = Vec::new();
        for (n, node) in self.nodes.iter().enumerate() {
            let mesh = self.meshes.get(node.mesh).ok_or_else(|| {
                Error::invalid_option("model", format!("node {n} places a mesh it lacks"))
            })?;
            for (p, world) in node.placements.iter().enumerate() {
                let first_vertex = positions.len() as u32;
                let first_triangle = triangles.len() as u32;
                let turned = determinant(world) < 0.0;
                for (k, primitive) in mesh.primitives.iter().enumerate() {
                    let base = positions.len() as u32;
                    let local = primitive.positions()?;
                    positions.extend(local.iter().map(|&q| transform_point(world, q)));
                    let vertices = local.len() as u32;
                    for (t, &[a, b, c]) in primitive.triangles.iter().enumerate() {
                        if [a, b, c].iter().any(|&i| i >= vertices) {
                            return Err(Error::invalid_option(
                                "model",
                                format!("a triangle of mesh {} is past its vertices", node.mesh),
                            ));
                        }
                        let corners = if turned { [a, c, b] } else { [a, b, c] };
                        let placed = corners.map(|i| i + base);
                        if is_degenerate(&positions, placed) {
                            continue;
                        }
                        triangles.push(placed);
                        sources.push(TriangleSource {
                            node: n as u32,
                            placement: p as u32,
                            primitive: k as u32,
                            triangle: t as u32,
                        });
                    }
                }
                parts.push(Part {
                    first_vertex,
                    vertex_count: positions.len() as u32 - first_vertex,
                    first_triangle,
                    triangle_count: triangles.len() as u32 - first_triangle,
                    source: node.mesh as u32,
                });
            }
        }
        let mesh = TriMesh::with_parts(positions, triangles, parts)?;
        debug_assert_eq!(mesh.triangles().len(), sources.len());
        Ok((mesh, sources))
    }
}

impl Primitive {
    /// The `POSITION` attribute's points.
    pub fn positions(&self) -> Result<Vec<[f32; 3]>> {
        let position = self
            .attributes
            .iter()
            .find(|a| a.semantic == "POSITION" && a.width == 3)
            .ok_or_else(|| Error::invalid_option("model", "a primitive has no POSITION"))?;
        Ok(position
            .values
            .chunks_exact(3)
            .map(|p| [p[0], p[1], p[2]])
            .collect())
    }

    /// Vertices the attributes hold.
    pub fn vertex_count(&self) -> usize {
        self.attributes
            .first()
            .map_or(0, |a| a.values.len() / a.width.max(1))
    }
}

/// `m` applied to point `p`, rounded to f32 as the loaders round.
pub fn transform_point(m: &Matrix, p: [f32; 3]) -> [f32; 3] {
    let [x, y, z] = p.map(f64::from);
    [0, 1, 2].map(|r| (m[r][0] * x + m[r][1] * y + m[r][2] * z + m[r][3]) as f32)
}

/// The determinant of `m`'s linear part: negative for a mirroring one.
pub fn determinant(m: &Matrix) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// The product `a b` (b first).
pub fn multiply(a: &Matrix, b: &Matrix) -> Matrix {
    let mut m = [[0.0; 4]; 4];
    for (r, row) in m.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = (0..4).map(|k| a[r][k] * b[k][c]).sum();
        }
    }
    m
}

/// A placement as glTF's node properties hold one: translation, rotation
/// (a unit quaternion x, y, z, w) and scale, whose x is negative for a
/// mirror image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Trs {
    pub translation: [f64; 3],
    pub rotation: [f64; 4],
    pub scale: [f64; 3],
}

impl Trs {
    /// Whether a scale is zero: the placement flattens what it places, and
    /// glTF accepts that only as node properties, not as a matrix.
    pub fn is_singular(&self) -> bool {
        self.scale.contains(&0.0)
    }
}

/// How far from perpendicular (as a cosine) a placement's axes may be and
/// still count as turned and scaled, not sheared: f32 rotations and their
/// products stay far below it, and a reader that decomposes the matrix
/// draws the same shape.
const SHEAR_TOLERANCE: f64 = 1e-5;

/// `m` as translation, rotation and scale, where it is one: `None` for a
/// shear (a non-uniform scale over a turned child, which glTF forbids in a
/// node) or a projection. An axis scaled to nothing (a hidden or flattened
/// part) gets a rotation all the same, from the axes that remain.
pub fn trs(m: &Matrix) -> Option<Trs> {
    use glam::{DMat3, DQuat, DVec3};
    if m[3] != [0.0, 0.0, 0.0, 1.0] || m.iter().flatten().any(|x| !x.is_finite()) {
        return None;
    }
    let columns = [0, 1, 2].map(|c| DVec3::new(m[0][c], m[1][c], m[2][c]));
    let longest = columns.iter().map(|c| c.length()).fold(0.0, f64::max);
    // An axis this much shorter than the longest is nothing in f64.
    let scale = columns
        .map(|c| c.length())
        .map(|s| match s > longest * 1e-12 {
            true => s,
            false => 0.0,
        });
    let mut axes = [0, 1, 2].map(|c| match scale[c] > 0.0 {
        true => Some(columns[c] / scale[c]),
        false => None,
    });
    for (i, j) in [(0, 1), (0, 2), (1, 2)] {
        if let (Some(a), Some(b)) = (axes[i], axes[j])
            && a.dot(b).abs() > SHEAR_TOLERANCE
        {
            return None;
        }
    }
    // The missing axes, completing a right-handed frame: e_c = e_(c+1) x
    // e_(c+2), the indices taken cyclically.
    let known: Vec<usize> = (0..3).filter(|&c| axes[c].is_some()).collect();
    let axes = match known[..] {
        [] => [DVec3::X, DVec3::Y, DVec3::Z],
        [i] => {
            let a = axes[i].expect("known");
            let b = a.any_orthonormal_vector();
            let mut frame = [DVec3::ZERO; 3];
            frame[i] = a;
            frame[(i + 1) % 3] = b;
            frame[(i + 2) % 3] = a.cross(b);
            frame
        }
        [_, _] => {
            let c = (0..3).find(|c| axes[*c].is_none()).expect("one missing");
            axes[c] = Some(
                axes[(c + 1) % 3]
                    .expect("known")
                    .cross(axes[(c + 2) % 3].expect("known")),
            );
            axes.map(|a| a.expect("complete"))
        }
        _ => axes.map(|a| a.expect("complete")),
    };
    let mut scale = scale;
    let mut rotation = DMat3::from_cols(axes[0], axes[1], axes[2]);
    // A mirror image: the x axis turned back, its scale negative.
    if rotation.determinant() < 0.0 {
        scale[0] = -scale[0];
        rotation.x_axis = -rotation.x_axis;
    }
    let q = DQuat::from_mat3(&rotation).normalize();
    Some(Trs {
        translation: [m[0][3], m[1][3], m[2][3]],
        rotation: q.to_array(),
        scale,
    })
}
