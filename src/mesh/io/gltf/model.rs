//! A glTF read as a [`Model`]: what the search reads (the placed
//! triangles, in the loader's order) with what a viewer draws besides
//! (every vertex attribute, the materials and their images), to be written
//! back changed.

use std::collections::HashMap;

use gltf::accessor::Dimensions;
use gltf::json::Value;
use gltf::mesh::Mode;

use super::accessor::component_to_f32;
use super::{Loader, assemble, read_document};
use crate::error::{Error, Format, Result};
use crate::mesh::io::model::{
    Attribute, Image, ImageData, MaterialTable, Matrix, Model, ModelMesh, ModelNode, Primitive,
};
use crate::mesh::io::{ResourceError, ResourcePath, ResourceResolver, SizeLimit};

/// Extensions that concern the geometry as the file stores it, which a
/// model read here no longer uses: its attributes are floats, its
/// placements nodes.
const STORAGE_EXTENSIONS: &[&str] = &[
    "KHR_mesh_quantization",
    "KHR_draco_mesh_compression",
    "EXT_meshopt_compression",
    "EXT_mesh_gpu_instancing",
];

/// The most bytes an external image may have.
const MAX_IMAGE_BYTES: usize = 1 << 29;

/// Reads `bytes` (a glTF or GLB) as a model: its default scene's placed
/// meshes, one node per placement, with every attribute but the skinning
/// ones (skins are not applied), and its materials.
pub(crate) fn read_model(
    bytes: &[u8],
    resources: &dyn ResourceResolver,
    limit: SizeLimit,
) -> Result<Model> {
    let gltf = read_document(bytes)?;
    let mut loader = Loader::new(&gltf, bytes.len(), limit, resources);
    loader.visit_scene(&gltf, bytes)?;
    let mut meshes = Vec::new();
    let mut mesh_of: HashMap<usize, usize> = HashMap::new();
    let mut nodes = Vec::new();
    for (world, mesh, node) in std::mem::take(&mut loader.placements) {
        let index = match mesh_of.get(&mesh) {
            Some(&m) => m,
            None => {
                let source = gltf.meshes().nth(mesh).expect("a placed mesh exists");
                meshes.push(loader.read_mesh(&source)?);
                mesh_of.insert(mesh, meshes.len() - 1);
                meshes.len() - 1
            }
        };
        let row_major: Matrix = std::array::from_fn(|r| std::array::from_fn(|c| world[c][r]));
        nodes.push(ModelNode {
            name: gltf
                .nodes()
                .nth(node)
                .and_then(|n| n.name().map(str::to_string)),
            mesh: index,
            placements: vec![row_major],
        });
    }
    let materials = loader.material_table(bytes, &gltf)?;
    Ok(Model {
        meshes,
        nodes,
        materials,
    })
}

impl Loader<'_> {
    /// A mesh's triangle primitives with all their attributes.
    fn read_mesh(&mut self, mesh: &gltf::Mesh) -> Result<ModelMesh> {
        let mut primitives = Vec::new();
        for prim in mesh.primitives() {
            let at = format!("mesh {} primitive {}", mesh.index(), prim.index());
            let mode = prim.mode();
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                continue;
            }
            let Some(position) = prim.get(&gltf::Semantic::Positions) else {
                return Err(Error::malformed(
                    Format::Gltf,
                    at,
                    "primitive has no POSITION",
                ));
            };
            let positions = self.read_positions(&position, &at)?;
            let mut attributes = vec![Attribute {
                semantic: "POSITION".to_string(),
                width: 3,
                values: positions.iter().flatten().copied().collect(),
            }];
            for (semantic, accessor) in prim.attributes() {
                let name = semantic.to_string();
                if name == "POSITION" || name.starts_with("JOINTS_") || name.starts_with("WEIGHTS_")
                {
                    continue;
                }
                let Some(width) = width_of(accessor.dimensions()) else {
                    continue;
                };
                if accessor.count() != positions.len() {
                    return Err(Error::malformed(
                        Format::Gltf,
                        &at,
                        format!(
                            "{name} has {} values, POSITION {}",
                            accessor.count(),
                            positions.len()
                        ),
                    ));
                }
                let (kind, normalized) = (accessor.data_type(), accessor.normalized());
                let size = kind.size();
                let values = self
                    .read_elements(&accessor, &at)?
                    .chunks_exact(size)
                    .map(|c| component_to_f32(c, kind, normalized))
                    .collect();
                attributes.push(Attribute {
                    semantic: name,
                    width,
                    values,
                });
            }
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
            let triangles =
                assemble(mode, &indices).map_err(|m| Error::malformed(Format::Gltf, &at, m))?;
            primitives.push(Primitive {
                attributes,
                triangles,
                material: prim.material().index().map(|m| m as u32),
            });
        }
        Ok(ModelMesh {
            name: mesh.name().map(str::to_string),
            primitives,
        })
    }

    /// The file's materials, textures, samplers and images as its JSON has
    /// them, each image's bytes read from wherever they are.
    fn material_table(&mut self, bytes: &[u8], gltf: &gltf::Gltf) -> Result<MaterialTable> {
        let json: std::borrow::Cow<[u8]> = if bytes.starts_with(b"glTF") {
            gltf::binary::Glb::from_slice(bytes)
                .map_err(|e| Error::malformed(Format::Gltf, "GLB", e.to_string()))?
                .json
        } else {
            bytes.into()
        };
        let root: Value = gltf::json::deserialize::from_slice(&json)
            .map_err(|e| Error::malformed(Format::Gltf, "document", e.to_string()))?;
        let list = |key: &str| -> Vec<Value> {
            root.get(key)
                .and_then(Value::as_array)
                .cloned()
                .unwrap_or_default()
        };
        let names = |key: &str| -> Vec<String> {
            list(key)
                .iter()
                .filter_map(Value::as_str)
                .filter(|n| !STORAGE_EXTENSIONS.contains(n))
                .map(str::to_string)
                .collect()
        };
        let mut images = Vec::new();
        // An image file several images name is read once.
        let mut files: HashMap<String, ImageData> = HashMap::new();
        for (i, mut image) in list("images").into_iter().enumerate() {
            let at = format!("image {i}");
            let view = image.get("bufferView").and_then(Value::as_u64);
            let uri = image.get("uri").and_then(Value::as_str).map(str::to_string);
            let data = match (view, uri) {
                (Some(v), _) => {
                    let view = gltf.views().nth(v as usize).ok_or_else(|| {
                        Error::malformed(Format::Gltf, &at, "its buffer view does not exist")
                    })?;
                    ImageData::Bytes(self.view_bytes(&view, &at)?.to_vec().into())
                }
                (None, Some(uri)) if uri.starts_with("data:") => ImageData::DataUri(uri),
                (None, Some(uri)) => match files.get(&uri) {
                    Some(data) => data.clone(),
                    None => {
                        let data = self.image_file(&uri);
                        files.insert(uri, data.clone());
                        data
                    }
                },
                (None, None) => {
                    return Err(Error::malformed(
                        Format::Gltf,
                        at,
                        "has neither a buffer view nor a uri",
                    ));
                }
            };
            if let Some(object) = image.as_object_mut() {
                object.remove("bufferView");
                object.remove("uri");
                if let ImageData::Bytes(bytes) = &data {
                    if !object.contains_key("mimeType") {
                        let mime = mime_of(bytes).ok_or_else(|| {
                            Error::malformed(
                                Format::Gltf,
                                &at,
                                "its bytes are of no image type glTF knows",
                            )
                        })?;
                        object.insert("mimeType".to_string(), Value::from(mime));
                    }
                }
            }
            images.push(Image { json: image, data });
        }
        let (materials, textures, samplers) =
            (list("materials"), list("textures"), list("samplers"));
        // Only what the kept objects name: a light or a camera is not
        // written, so its extension is not used, and must not be required.
        let mut named = std::collections::HashSet::new();
        for value in materials.iter().chain(&textures).chain(&samplers) {
            extensions_named(value, &mut named);
        }
        for image in &images {
            extensions_named(&image.json, &mut named);
        }
        let kept = |key| -> Vec<String> {
            names(key)
                .into_iter()
                .filter(|n| named.contains(n.as_str()))
                .collect()
        };
        Ok(MaterialTable {
            extensions_used: kept("extensionsUsed"),
            extensions_required: kept("extensionsRequired"),
            materials,
            textures,
            samplers,
            images,
        })
    }

    /// An external image's bytes, through the resolver; one that cannot
    /// be read whole is kept as its reference: the geometry does not need
    /// it, and a search or a listing of repeats goes on without it.
    fn image_file(&mut self, uri: &str) -> ImageData {
        let unread = |reason: String| ImageData::Unread {
            uri: uri.to_string(),
            reason,
        };
        let path = match ResourcePath::parse(uri) {
            Ok(path) => path,
            Err(reason) => return unread(reason),
        };
        // One byte past the limit tells a larger file from one that fits.
        match self.resources.resolve(&path, MAX_IMAGE_BYTES + 1) {
            Ok(bytes) if bytes.len() > MAX_IMAGE_BYTES => {
                unread(format!("it is larger than {} MiB", MAX_IMAGE_BYTES >> 20))
            }
            Ok(bytes) => ImageData::Bytes(bytes.into()),
            Err(ResourceError::Missing) => unread("it was not found".into()),
            Err(ResourceError::Refused(reason)) => unread(reason),
        }
    }
}

/// Every key of an `extensions` object within `value`, at any depth.
fn extensions_named<'a>(value: &'a Value, named: &mut std::collections::HashSet<&'a str>) {
    match value {
        Value::Object(object) => {
            for (key, inner) in object {
                if let ("extensions", Value::Object(extensions)) = (key.as_str(), inner) {
                    named.extend(extensions.keys().map(String::as_str));
                }
                extensions_named(inner, named);
            }
        }
        Value::Array(items) => items.iter().for_each(|v| extensions_named(v, named)),
        _ => {}
    }
}

fn width_of(dimensions: Dimensions) -> Option<usize> {
    match dimensions {
        Dimensions::Scalar => Some(1),
        Dimensions::Vec2 => Some(2),
        Dimensions::Vec3 => Some(3),
        Dimensions::Vec4 => Some(4),
        _ => None,
    }
}

/// The image type of `bytes` by their first bytes, as glTF names it.
fn mime_of(bytes: &[u8]) -> Option<&'static str> {
    if bytes.starts_with(b"\x89PNG") {
        Some("image/png")
    } else if bytes.starts_with(&[0xff, 0xd8]) {
        Some("image/jpeg")
    } else if bytes.starts_with(b"RIFF") && bytes.get(8..12) == Some(b"WEBP") {
        Some("image/webp")
    } else if bytes.starts_with(b"\xabKTX 20") {
        Some("image/ktx2")
    } else {
        None
    }
}
