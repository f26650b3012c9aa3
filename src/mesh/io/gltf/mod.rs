//! glTF 2.0 (`.glb` and `.gltf`): every triangle primitive of the default
//! scene, with the node hierarchy's transforms applied.
//!
//! The `gltf` crate parses and validates the JSON; accessors are read here with
//! every offset checked against the actual buffer, so a truncated or lying file
//! is an error, not a panic. Buffers are resolved only when a primitive needs
//! them: embedded (GLB `BIN` chunk or `data:` URI) or external through the
//! caller's [`ResourceResolver`]. Meshes shared by several nodes are decoded
//! once.

use std::collections::HashMap;
use std::rc::Rc;

use gltf::mesh::Mode;

use super::{ResourcePath, ResourceResolver, SizeLimit};
use crate::error::{Error, Format, Result};
use crate::mesh::{Part, TriMesh};

mod accessor;
mod instancing;
mod model;
#[cfg(test)]
mod tests;
mod write;

pub(crate) use model::read_model;
pub(crate) use write::write_glb;

/// Deeper node nesting than this is treated as a cycle (validation does not catch them).
const MAX_DEPTH: usize = 256;

/// A 4x4 matrix, column-major like glTF: `m[column][row]`.
type Mat4 = [[f64; 4]; 4];

const IDENTITY: Mat4 = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

pub(super) fn parse(
    bytes: &[u8],
    resources: &dyn ResourceResolver,
    limit: SizeLimit,
) -> Result<TriMesh> {
    let gltf = read_document(bytes)?;
    let mut loader = Loader::new(&gltf, bytes.len(), limit, resources);
    loader.visit_scene(&gltf, bytes)?;
    loader.place_all();
    TriMesh::with_parts(loader.positions, loader.triangles, loader.parts)
}

/// The document, parsed and validated, after the checks on its start.
fn read_document(bytes: &[u8]) -> Result<gltf::Gltf> {
    check_glb_header(bytes)?;
    // A file named .glb that is neither (a text file, an archive) would
    // fail in the JSON reader, "expected value at line 1 column 1".
    if !bytes.starts_with(b"glTF") && !super::trim_start(bytes).starts_with(b"{") {
        return Err(Error::malformed(
            Format::Gltf,
            "start",
            format!(
                "the content is neither a binary glTF (starting with 'glTF') nor a JSON glTF (starting with '{{'); it starts with {}",
                super::describe_start(bytes)
            ),
        ));
    }
    let gltf = gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|e| Error::malformed(Format::Gltf, "document", e.to_string()))?;
    validate(&gltf.document)?;
    Ok(gltf)
}

impl<'a> Loader<'a> {
    fn new(
        gltf: &'a gltf::Gltf,
        input_len: usize,
        limit: SizeLimit,
        resources: &'a dyn ResourceResolver,
    ) -> Loader<'a> {
        Loader {
            input_len,
            limit,
            buffers: vec![None; gltf.buffers().len()],
            resource_lengths: resource_lengths(&gltf.document),
            resources_read: HashMap::new(),
            blob: gltf.blob.as_deref(),
            resources,
            meshes: HashMap::new(),
            visited: vec![false; gltf.nodes().len()],
            positions: Vec::new(),
            triangles: Vec::new(),
            parts: Vec::new(),
            placements: Vec::new(),
            instances: HashMap::new(),
            placed_vertices: 0,
            placed_triangles: 0,
        }
    }

    /// Visits the default scene's nodes (or, without scenes, every node
    /// that is nobody's child), collecting the placements.
    fn visit_scene(&mut self, gltf: &gltf::Gltf, bytes: &[u8]) -> Result<()> {
        self.instances = self.read_instancing(gltf, bytes)?;
        let roots: Vec<gltf::Node> = match gltf.default_scene().or_else(|| gltf.scenes().next()) {
            Some(scene) => scene.nodes().collect(),
            // No scene: every node that is nobody's child is a root.
            None => {
                let mut is_child = vec![false; gltf.nodes().len()];
                for n in gltf.nodes() {
                    for c in n.children() {
                        is_child[c.index()] = true;
                    }
                }
                gltf.nodes().filter(|n| !is_child[n.index()]).collect()
            }
        };
        for node in roots {
            self.visit(&node, &IDENTITY, 0)?;
        }
        Ok(())
    }
}

/// A GLB's 12-byte header, checked before the `gltf` crate reads it: 1.4.1
/// subtracts the header from the declared length unchecked, which wraps
/// (or panics, with overflow checks) for a length below 12.
fn check_glb_header(bytes: &[u8]) -> Result<()> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    let header = |m: String| Err(Error::malformed(Format::Gltf, "GLB header", m));
    let Some(length) = bytes.get(8..12) else {
        return header(format!("{} bytes, fewer than the header's 12", bytes.len()));
    };
    let length = u32::from_le_bytes([length[0], length[1], length[2], length[3]]) as usize;
    if length > bytes.len() {
        return header(format!(
            "the file is truncated: it declares {length} bytes, and {} are here",
            bytes.len()
        ));
    }
    if length < 12 {
        return header(format!(
            "declares {length} bytes, fewer than the header's own 12"
        ));
    }
    Ok(())
}

/// The crate's validation, minus one rule: POSITION accessors without
/// `min`/`max` are accepted, because many exporters omit them and they are
/// not needed here. Everything the readers rely on (indices in range, known
/// component types) is still checked.
fn validate(document: &gltf::Document) -> Result<()> {
    use gltf::json::validation::{Checked, Error as Rule, Validate};
    let root = document.as_json();
    // gltf-json's own check of POSITION accessors indexes the accessor list
    // before anything has checked the index: an out-of-range index would
    // panic there, so it is checked here first.
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let position = prim
                .attributes
                .get(&Checked::Valid(gltf::json::mesh::Semantic::Positions));
            if let Some(index) = position.filter(|i| i.value() >= root.accessors.len()) {
                return Err(Error::malformed(
                    Format::Gltf,
                    format!("mesh {m} primitive {p}"),
                    format!(
                        "POSITION refers to accessor {}, but there are {}",
                        index.value(),
                        root.accessors.len()
                    ),
                ));
            }
        }
    }
    check_required_extensions(&root.extensions_required)?;
    let mut problems = Vec::new();
    let mut more = 0usize;
    root.validate(root, gltf::json::Path::new, &mut |path, rule| {
        let path = path();
        let bounds = path.as_str().ends_with(".min") || path.as_str().ends_with(".max");
        // Required extensions were judged above, by what they change.
        let extension =
            path.as_str().starts_with("extensionsRequired") && matches!(rule, Rule::Unsupported);
        if bounds && matches!(rule, Rule::Missing) || extension {
            return;
        }
        // A broken file may break a rule a million times: a few say enough.
        if problems.len() < MAX_PROBLEMS {
            problems.push(format!("{path}: {rule}"));
        } else {
            more += 1;
        }
    });
    if more > 0 {
        problems.push(format!("and {more} more"));
    }
    if problems.is_empty() {
        Ok(())
    } else {
        Err(Error::malformed(
            Format::Gltf,
            "document",
            format!("invalid glTF: {}", problems.join("; ")),
        ))
    }
}

/// Rule violations a message lists before it counts the rest.
const MAX_PROBLEMS: usize = 8;

/// Extensions a file may require that change no triangle's place: they
/// concern materials, textures, lights or cameras, which matching ignores.
const GEOMETRY_NEUTRAL: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_anisotropy",
    "KHR_materials_clearcoat",
    "KHR_materials_dispersion",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_iridescence",
    "KHR_materials_pbrSpecularGlossiness",
    "KHR_materials_sheen",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_unlit",
    "KHR_materials_variants",
    "KHR_materials_volume",
    "KHR_texture_basisu",
    "KHR_texture_transform",
    "EXT_texture_avif",
    "EXT_texture_webp",
    "MSFT_texture_dds",
];

/// Fails for a required extension that changes geometry and is not read.
/// `KHR_mesh_quantization` is read: positions stored as (normalized)
/// integers, which CAD and BIM exporters write to halve their files.
fn check_required_extensions(required: &[String]) -> Result<()> {
    for name in required {
        if [instancing::INSTANCING, "KHR_mesh_quantization"].contains(&name.as_str())
            || GEOMETRY_NEUTRAL.contains(&name.as_str())
        {
            continue;
        }
        let advice = match name.as_str() {
            "KHR_draco_mesh_compression" | "EXT_meshopt_compression" => {
                "its geometry is compressed, which is not read: export it without compression"
            }
            _ => "an extension a file requires may change its geometry, and this one is not read",
        };
        return Err(Error::malformed(
            Format::Gltf,
            "extensionsRequired",
            format!("the file requires the extension '{name}': {advice}"),
        ));
    }
    Ok(())
}

/// The most bytes a buffer reads of each external resource.
fn resource_lengths(document: &gltf::Document) -> HashMap<ResourcePath, usize> {
    let mut lengths = HashMap::new();
    for buffer in document.buffers() {
        if let gltf::buffer::Source::Uri(uri) = buffer.source() {
            if let Ok(path) = ResourcePath::parse(uri) {
                let most = lengths.entry(path).or_insert(0);
                *most = buffer.length().max(*most);
            }
        }
    }
    lengths
}

/// Local-space triangles of one mesh (all its triangle primitives).
struct LocalMesh {
    positions: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
}

struct Loader<'a> {
    /// Bytes of the document (with its GLB chunk).
    input_len: usize,
    /// The caller's cap on the placed mesh.
    limit: SizeLimit,
    /// Each buffer's bytes (a resource's may be longer than the buffer).
    buffers: Vec<Option<Rc<[u8]>>>,
    /// The most bytes any buffer reads of each external resource, and
    /// what was read: a resource is read once, however many buffers name
    /// it (forty buffers naming one 64 MiB file were 2.6 GB).
    resource_lengths: HashMap<ResourcePath, usize>,
    resources_read: HashMap<ResourcePath, Rc<[u8]>>,
    blob: Option<&'a [u8]>,
    resources: &'a dyn ResourceResolver,
    meshes: HashMap<usize, LocalMesh>,
    visited: Vec<bool>,
    positions: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
    /// One per placed mesh, so that instances of a mesh are known as such.
    parts: Vec<Part>,
    /// Each node's world transform, mesh and index, to be placed once all
    /// are counted.
    placements: Vec<(Mat4, usize, usize)>,
    /// The instances of each node that places its mesh by
    /// `EXT_mesh_gpu_instancing`, relative to the node.
    instances: HashMap<usize, instancing::Instances>,
    placed_vertices: usize,
    placed_triangles: usize,
}

impl Loader<'_> {
    fn visit(&mut self, node: &gltf::Node, parent: &Mat4, depth: usize) -> Result<()> {
        if depth > MAX_DEPTH {
            return Err(Error::malformed(
                Format::Gltf,
                format!("node {}", node.index()),
                "the node hierarchy is deeper than 256 levels or has a cycle",
            ));
        }
        // glTF nodes form a forest: a node reached twice has two parents or
        // sits on a cycle, and following it again could take exponential time.
        if std::mem::replace(&mut self.visited[node.index()], true) {
            return Err(Error::malformed(
                Format::Gltf,
                format!("node {}", node.index()),
                "the node is reached twice: it has several parents or the hierarchy has a cycle",
            ));
        }
        let local = node.transform().matrix().map(|c| c.map(f64::from));
        let world = mul(parent, &local);
        if let Some(mesh) = node.mesh() {
            if !self.meshes.contains_key(&mesh.index()) {
                let decoded = self.decode_mesh(&mesh)?;
                self.meshes.insert(mesh.index(), decoded);
            }
            // Each node places a copy: all are counted before any is made,
            // so that a small file instancing a mesh many times stops here
            // having allocated nothing for them.
            let m = &self.meshes[&mesh.index()];
            let (vertices, triangles) = (m.positions.len(), m.triangles.len());
            let instances = self.instances.remove(&node.index());
            let count = instances.as_ref().map_or(1, |i| i.count);
            for i in 0..count {
                let world = match &instances {
                    Some(list) => mul(&world, &list.matrix(i)),
                    None => world,
                };
                self.placed_vertices += vertices;
                self.placed_triangles += triangles;
                self.limit
                    .check(self.placed_vertices, self.placed_triangles)?;
                self.placements.push((world, mesh.index(), node.index()));
            }
        }
        for child in node.children() {
            self.visit(&child, &world, depth + 1)?;
        }
        Ok(())
    }

    /// Copies every placed mesh into world space, after [`SizeLimit::check`]
    /// accepted their total.
    fn place_all(&mut self) {
        self.positions.reserve_exact(self.placed_vertices);
        self.triangles.reserve_exact(self.placed_triangles);
        for (world, mesh, _) in std::mem::take(&mut self.placements) {
            let m = &self.meshes[&mesh];
            // A mirroring node turns its triangles inside out: glTF reads
            // their corners the other way round there.
            let turned = determinant(&world) < 0.0;
            let base = self.positions.len() as u32;
            self.parts.push(Part {
                first_vertex: base,
                vertex_count: m.positions.len() as u32,
                first_triangle: self.triangles.len() as u32,
                triangle_count: m.triangles.len() as u32,
                source: mesh as u32,
            });
            self.positions
                .extend(m.positions.iter().map(|&p| transform(&world, p)));
            self.triangles.extend(m.triangles.iter().map(|&[a, b, c]| {
                let corners = if turned { [a, c, b] } else { [a, b, c] };
                corners.map(|i| i + base)
            }));
        }
    }

    fn decode_mesh(&mut self, mesh: &gltf::Mesh) -> Result<LocalMesh> {
        let mut out = LocalMesh {
            positions: Vec::new(),
            triangles: Vec::new(),
        };
        for prim in mesh.primitives() {
            let at = format!("mesh {} primitive {}", mesh.index(), prim.index());
            let mode = prim.mode();
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                continue; // points and lines have no surface
            }
            let Some(pos_acc) = prim.get(&gltf::Semantic::Positions) else {
                return Err(Error::malformed(
                    Format::Gltf,
                    at,
                    "primitive has no POSITION",
                ));
            };
            let positions = self.read_positions(&pos_acc, &at)?;
            let indices: Vec<u32> = match prim.indices() {
                Some(acc) => self.read_indices(&acc, &at)?,
                None => (0..positions.len() as u32).collect(),
            };
            if let Some(&bad) = indices.iter().find(|&&i| i as usize >= positions.len()) {
                return Err(Error::malformed(
                    Format::Gltf,
                    at,
                    format!("index {bad} is past the {} positions", positions.len()),
                ));
            }
            self.limit.check(
                out.positions.len() + positions.len(),
                out.triangles.len() + indices.len() / 3,
            )?;
            let base = out.positions.len() as u32;
            out.positions.extend_from_slice(&positions);
            let tris =
                assemble(mode, &indices).map_err(|m| Error::malformed(Format::Gltf, &at, m))?;
            out.triangles
                .extend(tris.into_iter().map(|t| t.map(|i| i + base)));
        }
        Ok(out)
    }
}

/// Triangles from a primitive's index list.
fn assemble(mode: Mode, idx: &[u32]) -> std::result::Result<Vec<[u32; 3]>, String> {
    Ok(match mode {
        Mode::Triangles => {
            if !idx.len().is_multiple_of(3) {
                return Err(format!(
                    "{} triangle indices is not a multiple of 3",
                    idx.len()
                ));
            }
            idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect()
        }
        Mode::TriangleStrip => (0..idx.len().saturating_sub(2))
            .map(|i| {
                if i % 2 == 0 {
                    [idx[i], idx[i + 1], idx[i + 2]]
                } else {
                    [idx[i + 1], idx[i], idx[i + 2]]
                }
            })
            .collect(),
        Mode::TriangleFan => (1..idx.len().saturating_sub(1))
            .map(|i| [idx[0], idx[i], idx[i + 1]])
            .collect(),
        _ => Vec::new(),
    })
}

fn mul(a: &Mat4, b: &Mat4) -> Mat4 {
    let mut m = [[0.0; 4]; 4];
    for (c, col) in m.iter_mut().enumerate() {
        for (r, v) in col.iter_mut().enumerate() {
            *v = (0..4).map(|k| a[k][r] * b[c][k]).sum();
        }
    }
    m
}

/// The determinant of a column-major transform's linear part.
fn determinant(m: &Mat4) -> f64 {
    let row_major: [[f64; 4]; 4] = std::array::from_fn(|r| std::array::from_fn(|c| m[c][r]));
    crate::mesh::io::model::determinant(&row_major)
}

fn transform(m: &Mat4, p: [f32; 3]) -> [f32; 3] {
    let [x, y, z] = p.map(f64::from);
    [0, 1, 2].map(|r| (m[0][r] * x + m[1][r] * y + m[2][r] * z + m[3][r]) as f32)
}
