//! A [`Model`] written as one binary glTF (GLB): every attribute as floats,
//! indices as the smallest unsigned type that holds them, a node per
//! placed node (one placing its mesh several times with
//! `EXT_mesh_gpu_instancing`), the materials and their images as the model
//! has them.

use serde_json::{Map, Value, json};

use crate::error::{Error, Result};
use crate::mesh::io::model::{IDENTITY, ImageData, Matrix, Model, Trs, trs};

/// glTF's component types and buffer targets.
const FLOAT: u32 = 5126;
const UNSIGNED_SHORT: u32 = 5123;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

use super::instancing::INSTANCING;

/// `model` as GLB bytes.
pub(crate) fn write_glb(model: &Model) -> Result<Vec<u8>> {
    let mut out = Writer::default();
    let mut meshes = Vec::with_capacity(model.meshes.len());
    for (m, mesh) in model.meshes.iter().enumerate() {
        let mut primitives = Vec::new();
        for primitive in &mesh.primitives {
            if primitive.triangles.is_empty() {
                continue;
            }
            let vertices = primitive.vertex_count();
            let mut attributes = Map::new();
            for attribute in &primitive.attributes {
                let values = match attribute.semantic.as_str() {
                    // Unit length as the specification asks, after any
                    // dequantization or transform.
                    "NORMAL" => unit_vectors(&attribute.values, 3),
                    "TANGENT" => unit_vectors(&attribute.values, 4),
                    _ => attribute.values.clone(),
                };
                let bounds = attribute.semantic == "POSITION";
                let accessor = out.floats(&values, attribute.width, Some(ARRAY_BUFFER), bounds);
                attributes.insert(attribute.semantic.clone(), json!(accessor));
            }
            let indices = out.indices(&primitive.triangles, vertices);
            let mut object = json!({ "attributes": attributes, "indices": indices });
            if let Some(material) = primitive.material {
                object["material"] = json!(material);
            }
            primitives.push(object);
        }
        if primitives.is_empty() {
            return Err(unwritable(format!("mesh {m} has no triangles to write")));
        }
        let mut object = json!({ "primitives": primitives });
        if let Some(name) = &mesh.name {
            object["name"] = json!(name);
        }
        meshes.push(object);
    }
    let mut nodes = Vec::new();
    let mut instanced = false;
    for node in &model.nodes {
        let named = |mut object: Value| {
            if let Some(name) = &node.name {
                object["name"] = json!(name);
            }
            object
        };
        // glTF places by translation, rotation and scale only: a shear
        // written as a matrix is invalid, and drawn otherwise by readers
        // that decompose it.
        let placements = node
            .placements
            .iter()
            .map(|m| trs(m).ok_or_else(|| sheared(node.name.as_deref())))
            .collect::<Result<Vec<Trs>>>()?;
        if node.placements.len() > 1 {
            instanced = true;
            let attributes = out.instances(&placements);
            nodes.push(named(json!({
                "mesh": node.mesh,
                "extensions": { INSTANCING: { "attributes": attributes } },
            })));
            continue;
        }
        for (placement, trs) in node.placements.iter().zip(&placements) {
            let mut object = json!({ "mesh": node.mesh });
            // A scale of zero (a hidden or flattened part) has no matrix
            // form a validator accepts: it is written as properties.
            if trs.is_singular() {
                object["translation"] = json!(trs.translation);
                object["rotation"] = json!(trs.rotation);
                object["scale"] = json!(trs.scale);
            } else if *placement != IDENTITY {
                object["matrix"] = json!(column_major(placement));
            }
            nodes.push(named(object));
        }
    }
    let table = &model.materials;
    let mut images = Vec::with_capacity(table.images.len());
    // Bytes several images share are stored once.
    let mut views: std::collections::HashMap<*const Vec<u8>, usize> = Default::default();
    for image in &table.images {
        let mut object = image.json.clone();
        match &image.data {
            ImageData::Bytes(bytes) => {
                let view = *views
                    .entry(std::sync::Arc::as_ptr(bytes))
                    .or_insert_with(|| out.view(bytes, None));
                object["bufferView"] = json!(view);
            }
            ImageData::DataUri(uri) | ImageData::Unread { uri, .. } => object["uri"] = json!(uri),
        }
        images.push(object);
    }
    let mut used = table.extensions_used.clone();
    let mut required = table.extensions_required.clone();
    if instanced {
        used.push(INSTANCING.to_string());
        required.push(INSTANCING.to_string());
    }
    let mut root = json!({
        "asset": { "version": "2.0", "generator": concat!("fast-reject ", env!("CARGO_PKG_VERSION")) },
        "scene": 0,
        "scenes": [{ "nodes": (0..nodes.len()).collect::<Vec<_>>() }],
        "nodes": nodes,
        "meshes": meshes,
    });
    for (key, list) in [
        ("materials", table.materials.clone()),
        ("textures", table.textures.clone()),
        ("samplers", table.samplers.clone()),
        ("images", images),
    ] {
        if !list.is_empty() {
            root[key] = Value::Array(list);
        }
    }
    for (key, names) in [("extensionsUsed", used), ("extensionsRequired", required)] {
        if !names.is_empty() {
            root[key] = json!(names);
        }
    }
    if !out.bin.is_empty() {
        root["buffers"] = json!([{ "byteLength": out.bin.len() }]);
        root["bufferViews"] = Value::Array(out.views);
        root["accessors"] = Value::Array(out.accessors);
    }
    let text =
        serde_json::to_vec(&root).map_err(|e| unwritable(format!("cannot write its JSON: {e}")))?;
    glb(text, out.bin)
}

/// The binary buffer and the views and accessors into it, built together.
#[derive(Default)]
struct Writer {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Writer {
    /// A buffer view of `bytes`, four-byte aligned.
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut view =
            json!({ "buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len() });
        if let Some(target) = target {
            view["target"] = json!(target);
        }
        self.bin.extend_from_slice(bytes);
        self.views.push(view);
        self.views.len() - 1
    }

    /// An accessor of `width` floats a vertex; `bounds` adds its min and
    /// max (required of POSITION).
    fn floats(&mut self, values: &[f32], width: usize, target: Option<u32>, bounds: bool) -> usize {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes, target);
        let kind = ["SCALAR", "VEC2", "VEC3", "VEC4"][width - 1];
        let mut accessor = json!({
            "bufferView": view,
            "componentType": FLOAT,
            "count": values.len() / width,
            "type": kind,
        });
        if bounds {
            let (mut lo, mut hi) = (vec![f32::INFINITY; width], vec![f32::NEG_INFINITY; width]);
            for v in values.chunks_exact(width) {
                for k in 0..width {
                    lo[k] = lo[k].min(v[k]);
                    hi[k] = hi[k].max(v[k]);
                }
            }
            accessor["min"] = json!(lo);
            accessor["max"] = json!(hi);
        }
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    /// The triangles' indices: unsigned shorts where every vertex fits
    /// below 65535 (the primitive restart value), else unsigned ints.
    fn indices(&mut self, triangles: &[[u32; 3]], vertices: usize) -> usize {
        let flat = triangles.iter().flatten();
        let (bytes, kind): (Vec<u8>, u32) = if vertices < 65535 {
            (
                flat.flat_map(|&i| (i as u16).to_le_bytes()).collect(),
                UNSIGNED_SHORT,
            )
        } else {
            (flat.flat_map(|&i| i.to_le_bytes()).collect(), UNSIGNED_INT)
        };
        let view = self.view(&bytes, Some(ELEMENT_ARRAY_BUFFER));
        self.accessors.push(json!({
            "bufferView": view,
            "componentType": kind,
            "count": 3 * triangles.len(),
            "type": "SCALAR",
        }));
        self.accessors.len() - 1
    }

    /// The instancing attributes of `placements`: translation, rotation
    /// (a unit quaternion) and scale, whose x is negative for a mirror
    /// image.
    fn instances(&mut self, placements: &[Trs]) -> Value {
        let (mut t, mut r, mut s) = (Vec::new(), Vec::new(), Vec::new());
        for p in placements {
            t.extend(p.translation.map(|x| x as f32));
            r.extend(p.rotation.map(|x| x as f32));
            s.extend(p.scale.map(|x| x as f32));
        }
        json!({
            "TRANSLATION": self.floats(&t, 3, None, false),
            "ROTATION": self.floats(&r, 4, None, false),
            "SCALE": self.floats(&s, 3, None, false),
        })
    }
}

/// Each `width`-wide vector's first three values scaled to unit length
/// (a tangent's fourth, its sign, kept); zero vectors as they are.
fn unit_vectors(values: &[f32], width: usize) -> Vec<f32> {
    let mut out = values.to_vec();
    for v in out.chunks_exact_mut(width) {
        let length = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if length > 0.0 {
            for x in &mut v[..3] {
                *x /= length;
            }
        }
    }
    out
}

/// The error for a placement glTF cannot hold: the model's producer
/// should have moved the part's vertices instead.
fn sheared(node: Option<&str>) -> Error {
    let node = node.map_or(String::new(), |n| format!(" '{n}'"));
    unwritable(format!(
        "node{node} is placed by a shear, which a glTF node cannot hold"
    ))
}

fn unwritable(reason: String) -> Error {
    Error::Unwritable {
        reason: crate::error::FileText::new(&reason),
    }
}

/// `m` as glTF stores a node's matrix: sixteen values, column by column.
fn column_major(m: &Matrix) -> [f64; 16] {
    std::array::from_fn(|i| m[i % 4][i / 4])
}

/// A GLB of `json` and `bin`: the header, then each chunk padded to four
/// bytes (the JSON with spaces, the buffer with zeros).
fn glb(mut json: Vec<u8>, mut bin: Vec<u8>) -> Result<Vec<u8>> {
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let bin_chunk = if bin.is_empty() { 0 } else { 8 + bin.len() };
    let total = 12 + 8 + json.len() + bin_chunk;
    if u32::try_from(total).is_err() {
        return Err(unwritable(format!(
            "it would take {total} bytes, more than a GLB's 4 GiB"
        )));
    }
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    if !bin.is_empty() {
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
    }
    Ok(out)
}
