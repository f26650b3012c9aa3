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

use base64::Engine as _;
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;

use super::{MAX_TRIANGLES, MAX_VERTICES};
use super::{ResourceError, ResourcePath, ResourceResolver};
use crate::error::{Error, Format, Result};
use crate::mesh::{Part, TriMesh};

/// Deeper node nesting than this is treated as a cycle (validation does not catch them).
const MAX_DEPTH: usize = 256;

/// An accessor without a buffer view is zeros except for its sparse values:
/// its elements are not stored anywhere, so a few bytes could declare 10^15
/// of them. It may have at most this many elements per byte of the file.
const UNSTORED_ELEMENTS_PER_BYTE: usize = 1;

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
    max_mesh_bytes: u64,
) -> Result<TriMesh> {
    check_glb_header(bytes)?;
    let gltf = gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|e| Error::malformed(Format::Gltf, "document", e.to_string()))?;
    validate(&gltf.document)?;
    let mut loader = Loader {
        input_len: bytes.len(),
        max_mesh_bytes,
        buffers: vec![None; gltf.buffers().len()],
        blob: gltf.blob.as_deref(),
        resources,
        meshes: HashMap::new(),
        visited: vec![false; gltf.nodes().len()],
        positions: Vec::new(),
        triangles: Vec::new(),
        parts: Vec::new(),
        placements: Vec::new(),
        placed_vertices: 0,
        placed_triangles: 0,
    };
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
        loader.visit(&node, &IDENTITY, 0)?;
    }
    loader.place_all();
    TriMesh::with_parts(loader.positions, loader.triangles, loader.parts)
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
    if length < 12 || length > bytes.len() {
        return header(format!(
            "declares {length} bytes, but the file has {} and the header alone is 12",
            bytes.len()
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
    let mut problems = Vec::new();
    root.validate(root, gltf::json::Path::new, &mut |path, rule| {
        let path = path();
        let bounds = path.as_str().ends_with(".min") || path.as_str().ends_with(".max");
        if !(bounds && matches!(rule, Rule::Missing)) {
            problems.push(format!("{path}: {rule}"));
        }
    });
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

/// Local-space triangles of one mesh (all its triangle primitives).
struct LocalMesh {
    positions: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
}

struct Loader<'a> {
    /// Bytes of the document (with its GLB chunk).
    input_len: usize,
    /// The caller's cap on the placed mesh.
    max_mesh_bytes: u64,
    buffers: Vec<Option<Vec<u8>>>,
    blob: Option<&'a [u8]>,
    resources: &'a dyn ResourceResolver,
    meshes: HashMap<usize, LocalMesh>,
    visited: Vec<bool>,
    positions: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
    /// One per placed mesh, so that instances of a mesh are known as such.
    parts: Vec<Part>,
    /// Each node's world transform and mesh, to be placed once all are counted.
    placements: Vec<(Mat4, usize)>,
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
            self.placed_vertices += m.positions.len();
            self.placed_triangles += m.triangles.len();
            check_size(
                self.placed_vertices,
                self.placed_triangles,
                self.max_mesh_bytes,
            )?;
            self.placements.push((world, mesh.index()));
        }
        for child in node.children() {
            self.visit(&child, &world, depth + 1)?;
        }
        Ok(())
    }

    /// Copies every placed mesh into world space, after [`check_size`]
    /// accepted their total.
    fn place_all(&mut self) {
        self.positions.reserve_exact(self.placed_vertices);
        self.triangles.reserve_exact(self.placed_triangles);
        for (world, mesh) in std::mem::take(&mut self.placements) {
            let m = &self.meshes[&mesh];
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
            self.triangles
                .extend(m.triangles.iter().map(|t| t.map(|i| i + base)));
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
            check_size(
                out.positions.len() + positions.len(),
                out.triangles.len() + indices.len() / 3,
                self.max_mesh_bytes,
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

    fn buffer(&mut self, buffer: &gltf::Buffer) -> Result<&[u8]> {
        let i = buffer.index();
        if self.buffers[i].is_none() {
            let data = match buffer.source() {
                gltf::buffer::Source::Bin => self
                    .blob
                    .ok_or_else(|| {
                        Error::malformed(
                            Format::Gltf,
                            format!("buffer {i}"),
                            "refers to the GLB binary chunk, which is missing",
                        )
                    })?
                    .to_vec(),
                gltf::buffer::Source::Uri(uri) => match uri.strip_prefix("data:") {
                    Some(rest) => decode_data_uri(rest)
                        .map_err(|m| Error::malformed(Format::Gltf, format!("buffer {i}"), m))?,
                    None => {
                        let refused = |reason: String| Error::ResourceRefused {
                            uri: uri.to_string(),
                            reason,
                        };
                        let path = ResourcePath::parse(uri).map_err(refused)?;
                        match self.resources.resolve(&path, buffer.length()) {
                            Ok(mut bytes) => {
                                bytes.truncate(buffer.length());
                                bytes
                            }
                            Err(ResourceError::Missing) => {
                                return Err(Error::MissingResource {
                                    uri: uri.to_string(),
                                });
                            }
                            Err(ResourceError::Refused(reason)) => return Err(refused(reason)),
                        }
                    }
                },
            };
            if data.len() < buffer.length() {
                return Err(Error::malformed(
                    Format::Gltf,
                    format!("buffer {i}"),
                    format!(
                        "declares {} bytes but only {} are present (truncated file?)",
                        buffer.length(),
                        data.len()
                    ),
                ));
            }
            self.buffers[i] = Some(data);
        }
        Ok(self.buffers[i].as_deref().unwrap_or_default())
    }

    /// The bytes of a buffer view, checked against the buffer.
    fn view_bytes(&mut self, view: &gltf::buffer::View, at: &str) -> Result<&[u8]> {
        let (offset, length) = (view.offset(), view.length());
        let data = self.buffer(&view.buffer())?;
        offset
            .checked_add(length)
            .and_then(|end| data.get(offset..end))
            .ok_or_else(|| {
                Error::malformed(
                    Format::Gltf,
                    at,
                    format!(
                        "buffer view {} (bytes {offset}..+{length}) lies outside its buffer of {} bytes",
                        view.index(),
                        data.len()
                    ),
                )
            })
    }

    /// Reads every element of an accessor as raw component bytes, honouring
    /// byte strides and sparse substitution. Returns `count` elements of
    /// `elem` bytes each, packed.
    fn read_elements(&mut self, acc: &gltf::Accessor, at: &str) -> Result<Vec<u8>> {
        let elem = acc.size();
        let count = acc.count();
        if acc.view().is_none() {
            if acc.sparse().is_none() {
                return Err(Error::malformed(
                    Format::Gltf,
                    at,
                    format!(
                        "accessor {} has neither a buffer view nor sparse values",
                        acc.index()
                    ),
                ));
            }
            let most = self.input_len.saturating_mul(UNSTORED_ELEMENTS_PER_BYTE);
            if count > most {
                return Err(Error::malformed(
                    Format::Gltf,
                    at,
                    format!(
                        "accessor {} has no buffer view but declares {count} elements, more than the {most} a file of {} bytes may leave unstored",
                        acc.index(),
                        self.input_len
                    ),
                ));
            }
        }
        let total = count
            .checked_mul(elem)
            .filter(|&t| t <= isize::MAX as usize / 2)
            .ok_or_else(|| Error::malformed(Format::Gltf, at, "accessor is impossibly large"))?;
        let mut out = match acc.view() {
            None => {
                // No view: zeros, unless sparse values fill some in.
                vec![0u8; total]
            }
            Some(view) => {
                let stride = view.stride().unwrap_or(elem);
                let offset = acc.offset();
                let bytes = self.view_bytes(&view, at)?;
                let needed = if count == 0 {
                    Some(offset)
                } else {
                    stride
                        .checked_mul(count - 1)
                        .and_then(|s| s.checked_add(offset))
                        .and_then(|s| s.checked_add(elem))
                };
                if stride < elem || needed.is_none_or(|n| n > bytes.len()) {
                    return Err(Error::malformed(
                        Format::Gltf,
                        at,
                        format!(
                            "accessor {} ({count} elements of {elem} bytes, stride {stride}, offset {offset}) does not fit its buffer view of {} bytes",
                            acc.index(),
                            bytes.len()
                        ),
                    ));
                }
                let mut out = Vec::with_capacity(total);
                for k in 0..count {
                    let s = offset + k * stride;
                    out.extend_from_slice(&bytes[s..s + elem]);
                }
                out
            }
        };
        if let Some(sparse) = acc.sparse() {
            let n = sparse.count();
            let idx_view = sparse.indices().view();
            let idx_size = match sparse.indices().index_type() {
                gltf::accessor::sparse::IndexType::U8 => 1,
                gltf::accessor::sparse::IndexType::U16 => 2,
                gltf::accessor::sparse::IndexType::U32 => 4,
            };
            let idx_off = sparse.indices().offset();
            let idx_bytes = self.view_bytes(&idx_view, at)?.to_vec();
            let val_view = sparse.values().view();
            let val_off = sparse.values().offset();
            let val_bytes = self.view_bytes(&val_view, at)?.to_vec();
            let idx_end = n.checked_mul(idx_size).and_then(|b| b.checked_add(idx_off));
            let val_end = n.checked_mul(elem).and_then(|b| b.checked_add(val_off));
            if idx_end.is_none_or(|e| e > idx_bytes.len())
                || val_end.is_none_or(|e| e > val_bytes.len())
            {
                return Err(Error::malformed(
                    Format::Gltf,
                    at,
                    "sparse accessor data exceeds its buffer views",
                ));
            }
            for k in 0..n {
                let b = &idx_bytes[idx_off + k * idx_size..idx_off + (k + 1) * idx_size];
                let target = match idx_size {
                    1 => b[0] as usize,
                    2 => u16::from_le_bytes([b[0], b[1]]) as usize,
                    _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize,
                };
                if target >= count {
                    return Err(Error::malformed(
                        Format::Gltf,
                        at,
                        format!("sparse index {target} is past the accessor's {count} elements"),
                    ));
                }
                out[target * elem..(target + 1) * elem]
                    .copy_from_slice(&val_bytes[val_off + k * elem..val_off + (k + 1) * elem]);
            }
        }
        Ok(out)
    }

    fn read_positions(&mut self, acc: &gltf::Accessor, at: &str) -> Result<Vec<[f32; 3]>> {
        if acc.dimensions() != Dimensions::Vec3 {
            return Err(Error::malformed(
                Format::Gltf,
                at,
                "POSITION is not a VEC3 accessor",
            ));
        }
        let data_type = acc.data_type();
        let normalized = acc.normalized();
        let raw = self.read_elements(acc, at)?;
        let c = data_type.size();
        Ok(raw
            .chunks_exact(3 * c)
            .map(|e| {
                [0, 1, 2].map(|k| component_to_f32(&e[k * c..(k + 1) * c], data_type, normalized))
            })
            .collect())
    }

    fn read_indices(&mut self, acc: &gltf::Accessor, at: &str) -> Result<Vec<u32>> {
        if acc.dimensions() != Dimensions::Scalar {
            return Err(Error::malformed(
                Format::Gltf,
                at,
                "indices are not a SCALAR accessor",
            ));
        }
        let data_type = acc.data_type();
        if !matches!(data_type, DataType::U8 | DataType::U16 | DataType::U32) {
            return Err(Error::malformed(
                Format::Gltf,
                at,
                "indices are not unsigned integers",
            ));
        }
        let raw = self.read_elements(acc, at)?;
        Ok(raw
            .chunks_exact(data_type.size())
            .map(|b| match b.len() {
                1 => b[0] as u32,
                2 => u16::from_le_bytes([b[0], b[1]]) as u32,
                _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            })
            .collect())
    }
}

/// Fails when the placed meshes would pass the loaders' size limits.
fn check_size(vertices: usize, triangles: usize, max_bytes: u64) -> Result<()> {
    let bytes = 12 * (vertices as u64 + triangles as u64);
    if vertices > MAX_VERTICES || triangles > MAX_TRIANGLES || bytes > max_bytes {
        return Err(Error::MeshTooLarge {
            limit: MAX_VERTICES as u64,
            vertices: vertices as u64,
            triangles: triangles as u64,
            max_bytes: max_bytes.min(12 * (MAX_VERTICES + MAX_TRIANGLES) as u64),
        });
    }
    Ok(())
}

/// One little-endian component as f32 (integer positions come from
/// KHR_mesh_quantization; normalized ones map to [-1, 1] or [0, 1]).
fn component_to_f32(b: &[u8], t: DataType, normalized: bool) -> f32 {
    match t {
        DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        DataType::I8 => {
            let v = b[0] as i8 as f32;
            if normalized { (v / 127.0).max(-1.0) } else { v }
        }
        DataType::U8 => {
            let v = b[0] as f32;
            if normalized { v / 255.0 } else { v }
        }
        DataType::I16 => {
            let v = i16::from_le_bytes([b[0], b[1]]) as f32;
            if normalized {
                (v / 32767.0).max(-1.0)
            } else {
                v
            }
        }
        DataType::U16 => {
            let v = u16::from_le_bytes([b[0], b[1]]) as f32;
            if normalized { v / 65535.0 } else { v }
        }
        DataType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
    }
}

/// Triangles from a primitive's index list.
fn assemble(mode: Mode, idx: &[u32]) -> std::result::Result<Vec<[u32; 3]>, String> {
    Ok(match mode {
        Mode::Triangles => {
            if idx.len() % 3 != 0 {
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

/// Decodes the part of a `data:` URI after the scheme; only base64 payloads
/// carry binary buffers.
fn decode_data_uri(rest: &str) -> std::result::Result<Vec<u8>, String> {
    let Some((meta, payload)) = rest.split_once(',') else {
        return Err("data URI has no ',' before its payload".into());
    };
    if !meta.ends_with(";base64") {
        return Err("data URI is not base64-encoded".into());
    }
    base64::engine::general_purpose::STANDARD
        .decode(payload.trim())
        .map_err(|e| format!("data URI is not valid base64: {e}"))
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

fn transform(m: &Mat4, p: [f32; 3]) -> [f32; 3] {
    let [x, y, z] = p.map(f64::from);
    [0, 1, 2].map(|r| (m[0][r] * x + m[1][r] * y + m[2][r] * z + m[3][r]) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::io::{NoResources, load};

    /// A minimal .gltf with one triangle in an embedded buffer, placed by a
    /// translated parent node and a scaled child.
    fn tiny_gltf(uri: &str) -> String {
        format!(
            r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
            "nodes":[{{"translation":[10,0,0],"children":[1]}},{{"scale":[2,2,2],"mesh":0}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
            "buffers":[{{"byteLength":42,"uri":"{uri}"}}],
            "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":6}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}},
                         {{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}}]}}"#
        )
    }

    fn tiny_buffer() -> Vec<u8> {
        let mut b = Vec::new();
        for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for i in [0u16, 1, 2] {
            b.extend_from_slice(&i.to_le_bytes());
        }
        b
    }

    fn data_uri() -> String {
        format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(tiny_buffer())
        )
    }

    #[test]
    fn node_transforms_compose() {
        let m = load(tiny_gltf(&data_uri()).as_bytes(), Some(Format::Gltf)).unwrap();
        assert_eq!(
            m.positions(),
            &[[10.0, 0.0, 0.0], [12.0, 0.0, 0.0], [10.0, 2.0, 0.0]]
        );
        assert_eq!(m.triangles(), &[[0, 1, 2]]);
    }

    #[test]
    fn external_buffers_come_from_the_resolver() {
        let doc = tiny_gltf("tri.bin");
        let e = parse(doc.as_bytes(), &NoResources, u64::MAX).unwrap_err();
        assert!(
            matches!(&e, Error::MissingResource { uri } if uri == "tri.bin"),
            "{e}"
        );
        let resolver = |uri: &str| (uri == "tri.bin").then(tiny_buffer);
        let m = parse(doc.as_bytes(), &resolver, u64::MAX).unwrap();
        assert_eq!(m.triangles().len(), 1);
        // A short external buffer is reported, not read past.
        let short = |_: &str| Some(tiny_buffer()[..20].to_vec());
        assert!(matches!(
            parse(doc.as_bytes(), &short, u64::MAX),
            Err(Error::Malformed { .. })
        ));
    }

    #[test]
    fn a_position_accessor_out_of_range_is_an_error_not_a_panic() {
        // Regression: gltf-json 1.4.1 indexes accessors with this value
        // before validating it.
        let doc = tiny_gltf(&data_uri()).replace(r#""POSITION":0"#, r#""POSITION":7"#);
        let e = load(doc.as_bytes(), Some(Format::Gltf)).unwrap_err();
        assert!(e.to_string().contains("accessor 7"), "{e}");
    }

    #[test]
    fn a_node_cycle_is_an_error() {
        let doc = tiny_gltf(&data_uri()).replace(
            r#"{"scale":[2,2,2],"mesh":0}"#,
            r#"{"scale":[2,2,2],"mesh":0,"children":[0]}"#,
        );
        assert!(matches!(
            load(doc.as_bytes(), Some(Format::Gltf)),
            Err(Error::Malformed { .. })
        ));
    }

    #[test]
    fn a_node_with_two_parents_is_an_error() {
        let doc = tiny_gltf(&data_uri()).replace(r#""children":[1]"#, r#""children":[1,1]"#);
        let e = load(doc.as_bytes(), Some(Format::Gltf)).unwrap_err();
        assert!(e.to_string().contains("reached twice"), "{e}");
    }

    #[test]
    fn a_glb_length_below_its_header_is_an_error() {
        // Found by the load_gltf fuzz target (fuzz/regressions).
        for length in [0u32, 11, 1000] {
            let mut glb = b"glTF\x02\0\0\0".to_vec();
            glb.extend_from_slice(&length.to_le_bytes());
            let e = load(&glb, None).unwrap_err();
            assert!(e.to_string().contains("GLB header"), "{e}");
        }
        assert!(load(b"glTF\x02\0", Some(Format::Gltf)).is_err());
    }

    #[test]
    fn strips_and_fans() {
        assert_eq!(
            assemble(Mode::TriangleStrip, &[0, 1, 2, 3]).unwrap(),
            vec![[0, 1, 2], [2, 1, 3]]
        );
        assert_eq!(
            assemble(Mode::TriangleFan, &[0, 1, 2, 3]).unwrap(),
            vec![[0, 1, 2], [0, 2, 3]]
        );
        assert!(assemble(Mode::Triangles, &[0, 1]).is_err());
    }

    use crate::math::Vec3;
    use crate::mesh::io::fixtures;

    #[test]
    fn every_truncation_of_a_glb_is_an_error() {
        let glb = fixtures::INSTANCES_GLB;
        for cut in 0..glb.len() {
            let r = load(&glb[..cut], None);
            assert!(r.is_err(), "prefix of {cut} bytes parsed");
        }
        assert!(load(glb, None).is_ok());
    }

    #[test]
    fn garbage_inside_a_glb_is_an_error() {
        let mut glb = fixtures::INSTANCES_GLB.to_vec();
        // Break the JSON chunk.
        for b in &mut glb[20..60] {
            *b = b'#';
        }
        assert!(matches!(load(&glb, None), Err(Error::Malformed { .. })));
    }

    #[test]
    fn a_glb_places_its_mesh_once_per_node() {
        let m = load(fixtures::INSTANCES_GLB, None).unwrap();
        assert_eq!(m.triangles().len(), 3 * fixtures::TRIANGLES);
        assert_eq!(m.positions().len(), 3 * fixtures::VERTICES);
        assert_eq!(m.parts().len(), 3);
        assert!(m.parts().iter().all(|p| p.source == m.parts()[0].source));
        // Each instance: (centre, radius, where the mesh's first vertex
        // (-0.526, 0.851, 0) lands).
        let v0 = Vec3::new(-0.525_731_1, 0.850_650_8, 0.0);
        let expected = [
            (
                Vec3::new(6.0, 0.0, 0.0),
                2.0,
                Vec3::new(6.0, 0.0, 0.0) + v0 * 2.0,
            ),
            (
                Vec3::new(-6.0, 0.0, 0.0),
                2.0,
                Vec3::new(-6.0 - 2.0 * v0.y, 2.0 * v0.x, 0.0),
            ),
            (Vec3::ZERO, 1.0, v0),
        ];
        let mut found = [false; 3];
        for part in m.parts() {
            assert_eq!(part.vertex_count as usize, fixtures::VERTICES);
            assert_eq!(part.triangle_count as usize, fixtures::TRIANGLES);
            let vertices = part.first_vertex..part.first_vertex + part.vertex_count;
            let first = m.vertex(part.first_vertex);
            let k = expected
                .iter()
                .position(|&(_, _, at)| first.distance(at) < 1e-5)
                .unwrap_or_else(|| panic!("no instance has its first vertex at {first:?}"));
            let (centre, radius, _) = expected[k];
            for v in vertices {
                let r = m.vertex(v).distance(centre);
                assert!((r - radius).abs() < 1e-5, "instance {k}: vertex {v} at {r}");
            }
            assert!(!found[k], "instance {k} twice");
            found[k] = true;
        }
    }

    #[test]
    fn a_shared_scene_loads_with_its_instances() {
        // A real scene from the benchmark, against its known size.
        let glb = crate::shared_bytes("scenes/zoo-bunny/scene.glb");
        let m = load(&glb, None).unwrap();
        assert_eq!(m.triangles().len() + m.degenerate_dropped(), 334_962);
    }
}
