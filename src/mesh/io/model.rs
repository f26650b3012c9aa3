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

/// An image's bytes, or a `data:` URI that holds them.
#[derive(Clone, Debug)]
pub enum ImageData {
    Bytes(Vec<u8>),
    DataUri(String),
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
