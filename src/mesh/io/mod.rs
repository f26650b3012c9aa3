//! Mesh loaders: bytes in, [`TriMesh`] out.
//!
//! Each format has its own module; this one picks the loader from an explicit
//! [`Format`] or, when none is given, from the content itself. Loaders never
//! touch the file system: a `.gltf` that refers to an external `.bin` asks a
//! [`ResourceResolver`] for it, by a [`ResourcePath`] that cannot leave the
//! model's folder (the CLI reads names inside the file's folder; the browser
//! passes dropped files).
//!
//! Every loader fails with [`Error::Malformed`] on content it cannot parse,
//! including truncated files, and never panics.

mod gltf;
pub mod model;
mod obj;
mod ply;
mod resource;
mod stl;

pub use model::Model;
pub use resource::{NoResources, ResourceError, ResourcePath, ResourceResolver};

use super::TriMesh;
use crate::error::{Error, FileText, Format, Result};

/// The most vertices a loaded mesh may have: 2^25 (about 33 million,
/// 400 MB of positions). A glTF file can place one mesh on many nodes, so a
/// small file could otherwise expand to any size; the other formats store
/// every vertex and stay within their input's size.
pub const MAX_VERTICES: usize = 1 << 25;

/// The most triangles a loaded mesh may have: 2^25, as [`MAX_VERTICES`].
pub const MAX_TRIANGLES: usize = 1 << 25;

/// The loaders' limit on the mesh they build, checked before it grows: a
/// file's declared counts and its compact encodings (a PLY face of 255
/// one-byte corners is 253 triangles, twelve times its bytes; a glTF node
/// placing a mesh again) may ask for far more than the file's size.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SizeLimit {
    max_bytes: u64,
}

impl SizeLimit {
    /// At most [`MAX_VERTICES`], [`MAX_TRIANGLES`], and `max_bytes` for
    /// both (12 bytes a vertex and 12 a triangle).
    pub(crate) fn new(max_bytes: u64) -> SizeLimit {
        SizeLimit { max_bytes }
    }

    /// Fails when a mesh of `vertices` and `triangles` would pass the limit.
    pub(crate) fn check(&self, vertices: usize, triangles: usize) -> Result<()> {
        let bytes = 12 * (vertices as u64).saturating_add(triangles as u64);
        if vertices > MAX_VERTICES || triangles > MAX_TRIANGLES || bytes > self.max_bytes {
            return Err(Error::MeshTooLarge {
                limit: MAX_VERTICES as u64,
                vertices: vertices as u64,
                triangles: triangles as u64,
                max_bytes: self
                    .max_bytes
                    .min(12 * (MAX_VERTICES + MAX_TRIANGLES) as u64),
            });
        }
        Ok(())
    }

    /// The most triangles a mesh of `vertices` may have.
    pub(crate) fn triangles_beside(&self, vertices: usize) -> usize {
        let by_bytes = (self.max_bytes / 12).saturating_sub(vertices as u64);
        MAX_TRIANGLES.min(usize::try_from(by_bytes).unwrap_or(usize::MAX))
    }
}

/// The most bytes loading a file of `len` bytes that starts with `head`
/// may hold at once, its own copy included, when the loaders refuse a mesh
/// over `max_mesh_bytes` (see [`load_within`]): for a host that must check
/// before it copies the file in, such as a wasm module, where a failed
/// allocation cannot be caught.
pub fn peak_load_bytes(head: &[u8], len: u64, max_mesh_bytes: u64) -> u64 {
    // Per format: mesh bytes per file byte at most, for its densest
    // encoding, and whether the mesh grows by doubling (twice its size for
    // a moment) or is allocated at its final size.
    // A binary STL is known by its length, which `head` alone lacks.
    let format = if is_binary_stl_of(head, len) && !is_glb_of(head, len) {
        Some(Format::Stl)
    } else {
        sniff(head)
    };
    let (per_byte, doubling) = match format {
        // A binary face of 255 one-byte corners (256 bytes) is 253
        // triangles (3036 bytes); vertices take at least 3 bytes for 12.
        Some(Format::Ply) => (12, true),
        // A corner takes two bytes ("1 ") for a 12-byte triangle.
        Some(Format::Obj) => (6, true),
        // 50 bytes a triangle: 36 of corners, then ids, vertices and
        // triangles when they are welded, each allocated once.
        Some(Format::Stl) => (2, false),
        // Buffers as large as the file (data URIs decode to 3/4 of their
        // text), then the placed mesh, counted before it is allocated once:
        // any size up to the limit, since a node may place a mesh again.
        Some(Format::Gltf) | None => {
            return len.saturating_mul(2).saturating_add(max_mesh_bytes);
        }
    };
    let mesh = len.saturating_mul(per_byte).min(max_mesh_bytes);
    len.saturating_add(mesh.saturating_mul(if doubling { 2 } else { 1 }))
}

/// Loads a model from bytes, with what a viewer draws besides the
/// triangles (a glTF's attributes, materials and images), to be written
/// back changed ([`write_glb`]); the other formats give their positions.
/// [`Model::placed`] is the mesh [`load_with_resources`] gives.
pub fn load_model(
    bytes: &[u8],
    format: Option<Format>,
    resources: &dyn ResourceResolver,
) -> Result<Model> {
    load_model_within(bytes, format, resources, u64::MAX)
}

/// Like [`load_model`], refusing a model whose placed mesh would need more
/// than `max_mesh_bytes` (see [`load_within`]).
pub fn load_model_within(
    bytes: &[u8],
    format: Option<Format>,
    resources: &dyn ResourceResolver,
    max_mesh_bytes: u64,
) -> Result<Model> {
    match format.or_else(|| sniff(bytes)) {
        Some(Format::Gltf) => gltf::read_model(bytes, resources, SizeLimit::new(max_mesh_bytes)),
        _ => Ok(Model::of_mesh(&load_within(
            bytes,
            format,
            resources,
            max_mesh_bytes,
        )?)),
    }
}

/// `model` as a binary glTF: a node per [`model::ModelNode`], one that
/// places its mesh more than once with `EXT_mesh_gpu_instancing`.
pub fn write_glb(model: &Model) -> Result<Vec<u8>> {
    gltf::write_glb(model)
}

/// Loads a mesh from bytes; `format` `None` means: recognize it from the content.
pub fn load(bytes: &[u8], format: Option<Format>) -> Result<TriMesh> {
    load_with_resources(bytes, format, &NoResources)
}

/// Like [`load`], with a resolver for external glTF buffers.
pub fn load_with_resources(
    bytes: &[u8],
    format: Option<Format>,
    resources: &dyn ResourceResolver,
) -> Result<TriMesh> {
    load_within(bytes, format, resources, u64::MAX)
}

/// Like [`load_with_resources`], refusing a mesh that would need more than
/// `max_mesh_bytes` (12 bytes a vertex and 12 a triangle) before it is
/// built (a glTF's placed instances, a PLY's or OBJ's polygons): for a
/// host with little memory, such as a wasm module, where a failed
/// allocation cannot be caught.
pub fn load_within(
    bytes: &[u8],
    format: Option<Format>,
    resources: &dyn ResourceResolver,
    max_mesh_bytes: u64,
) -> Result<TriMesh> {
    let format = match format {
        Some(f) => f,
        None => sniff(bytes).ok_or_else(|| Error::UnknownFormat {
            len: bytes.len(),
            start: FileText::new(&describe_start(bytes)),
        })?,
    };
    if bytes.is_empty() {
        return Err(Error::malformed(format, "start", "the input is empty"));
    }
    // A format named for content whose magic names another (a .glb saved
    // as .obj, bytes handed over with the wrong format) would otherwise
    // fail deep in the wrong parser, with a message about that parser.
    if let Some((other, magic)) = magic(bytes).filter(|&(other, _)| other != format) {
        return Err(Error::malformed(
            format,
            "start",
            format!(
                "the content is {other} (it starts with '{magic}'), not {format}: name the format it is, or leave it to be recognized"
            ),
        ));
    }
    let limit = SizeLimit::new(max_mesh_bytes);
    match format {
        Format::Gltf => gltf::parse(bytes, resources, limit),
        Format::Obj => obj::parse(bytes, limit),
        Format::Ply => ply::parse(bytes, limit),
        Format::Stl => stl::parse(bytes, limit),
    }
}

/// Whether the length is what a binary STL's triangle count makes it.
fn is_binary_stl(bytes: &[u8]) -> bool {
    is_binary_stl_of(bytes, bytes.len() as u64)
}

/// Whether a file of `len` bytes starting with `head` has the length its
/// binary STL triangle count makes it.
fn is_binary_stl_of(head: &[u8], len: u64) -> bool {
    match head.get(80..84) {
        Some(&[a, b, c, d]) => 84 + 50 * u64::from(u32::from_le_bytes([a, b, c, d])) == len,
        _ => false,
    }
}

/// Whether this is a GLB whose header declares the file's own length.
fn is_glb(bytes: &[u8]) -> bool {
    is_glb_of(bytes, bytes.len() as u64)
}

/// Whether a file of `len` bytes starting with `head` is a GLB whose header
/// declares that length.
fn is_glb_of(head: &[u8], len: u64) -> bool {
    match head.get(..12) {
        Some(&[b'g', b'l', b'T', b'F', _, _, _, _, a, b, c, d]) => {
            u64::from(u32::from_le_bytes([a, b, c, d])) == len
        }
        _ => false,
    }
}

/// The format that a file's magic bytes name, with the magic: only the
/// signatures no other format can start with. A binary STL's 80-byte
/// header is free text that may start with any of them, so a file whose
/// length fits its triangle count is an STL, not what its header says
/// (unless it is a GLB that declares its own length).
fn magic(bytes: &[u8]) -> Option<(Format, &'static str)> {
    if is_binary_stl(bytes) && !is_glb(bytes) {
        return None;
    }
    if bytes.starts_with(b"glTF") {
        Some((Format::Gltf, "glTF"))
    } else if bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r\n") {
        Some((Format::Ply, "ply"))
    } else {
        None
    }
}

/// Recognizes a format from the first bytes (and, for binary STL, the length).
pub fn sniff(bytes: &[u8]) -> Option<Format> {
    if is_glb(bytes) {
        return Some(Format::Gltf);
    }
    // A binary STL's length is fixed by its triangle count: check it before
    // the magic of other formats and the ASCII "solid" keyword, which its
    // free-text header may carry.
    if is_binary_stl(bytes) {
        return Some(Format::Stl);
    }
    if bytes.starts_with(b"glTF") {
        return Some(Format::Gltf);
    }
    if bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r\n") {
        return Some(Format::Ply);
    }
    let text = trim_start(bytes);
    if text.starts_with(b"{") {
        return Some(Format::Gltf);
    }
    if text.len() >= 5 && text[..5].eq_ignore_ascii_case(b"solid") {
        return Some(Format::Stl);
    }
    if looks_like_obj(text) {
        return Some(Format::Obj);
    }
    None
}

/// What `bytes` start with, for a message about content no loader
/// recognizes: a file's first line where it is text (a README saved as
/// `.glb`), else its first bytes in hex. Escaped and bounded by the
/// [`FileText`] that shows it.
pub(crate) fn describe_start(bytes: &[u8]) -> String {
    const SHOWN: usize = 48;
    let head = &bytes[..bytes.len().min(SHOWN)];
    let text = match std::str::from_utf8(head) {
        Ok(t) => Some(t),
        // A character cut at the edge of the head is still text.
        Err(e) if e.error_len().is_none() => std::str::from_utf8(&head[..e.valid_up_to()]).ok(),
        Err(_) => None,
    };
    let printable = |t: &str| {
        !t.is_empty()
            && t.chars()
                .all(|c| !c.is_control() || matches!(c, '\t' | '\n' | '\r'))
    };
    match text.map(|t| t.trim_start_matches('\u{feff}').trim_start()) {
        Some(t) if printable(t) => {
            let line = t.lines().next().unwrap_or_default().trim_end();
            let more = if line.len() < t.trim_end().len() || bytes.len() > SHOWN {
                "..."
            } else {
                ""
            };
            format!("text \"{line}{more}\"")
        }
        _ => {
            let hex: Vec<String> = head.iter().take(8).map(|b| format!("{b:02x}")).collect();
            format!("binary data (bytes {})", hex.join(" "))
        }
    }
}

/// Skips a UTF-8 byte order mark and leading whitespace.
fn trim_start(bytes: &[u8]) -> &[u8] {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let start = bytes
        .iter()
        .position(|b| !b.is_ascii_whitespace())
        .unwrap_or(bytes.len());
    &bytes[start..]
}

/// OBJ has no magic: accept text whose first statements are OBJ keywords.
fn looks_like_obj(text: &[u8]) -> bool {
    const KEYWORDS: [&[u8]; 12] = [
        b"v", b"vn", b"vt", b"vp", b"f", b"o", b"g", b"s", b"mtllib", b"usemtl", b"l", b"p",
    ];
    let head = &text[..text.len().min(4096)];
    let mut statements = 0;
    for line in head.split(|&b| b == b'\n') {
        let line = trim_start(line);
        if line.is_empty() || line[0] == b'#' {
            continue;
        }
        let word = line
            .split(|b| b.is_ascii_whitespace())
            .next()
            .unwrap_or_default();
        if !KEYWORDS.contains(&word) {
            return false;
        }
        statements += 1;
        if word == b"v" || word == b"f" || statements >= 8 {
            return true;
        }
    }
    statements > 0
}

/// The loader tests' fixtures, written by `tests/fixtures/make_fixtures.py`:
/// one unit icosphere (42 vertices, 80 triangles, every vertex at distance 1
/// from the origin) in each format, compiled in so that the tests need
/// neither `../shared` nor a file system (wasmtime).
#[cfg(test)]
pub(crate) mod fixtures {
    /// Vertices and triangles of the icosphere.
    pub const VERTICES: usize = 42;
    pub const TRIANGLES: usize = 80;
    /// With texture coordinates and normals: `f v/vt/vn`.
    pub const OBJ: &[u8] = include_bytes!("../../../tests/fixtures/icosphere.obj");
    /// Binary little-endian, with normals and colours on the vertices.
    pub const PLY: &[u8] = include_bytes!("../../../tests/fixtures/icosphere.ply");
    /// Binary, with facet normals.
    pub const STL: &[u8] = include_bytes!("../../../tests/fixtures/icosphere.stl");
    /// The icosphere on three nodes: radius 2 at (6, 0, 0), radius 2 at
    /// (-6, 0, 0) turned 90 degrees about z (both under a root scaled 2),
    /// radius 1 at the origin.
    pub const INSTANCES_GLB: &[u8] =
        include_bytes!("../../../tests/fixtures/icosphere-instances.glb");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sniffs_each_format() {
        assert_eq!(sniff(b"glTF\x02\0\0\0"), Some(Format::Gltf));
        assert_eq!(sniff(b"  {\"asset\":{}}"), Some(Format::Gltf));
        assert_eq!(sniff(b"ply\nformat ascii 1.0\n"), Some(Format::Ply));
        assert_eq!(sniff(b"solid x\nendsolid x\n"), Some(Format::Stl));
        assert_eq!(sniff(b"# comment\nv 0 0 0\n"), Some(Format::Obj));
        let mut binary_stl = vec![0u8; 84 + 50];
        binary_stl[..5].copy_from_slice(b"solid");
        binary_stl[80] = 1;
        assert_eq!(sniff(&binary_stl), Some(Format::Stl));
        assert_eq!(sniff(b"hello world"), None);
        assert_eq!(sniff(b""), None);
    }

    #[test]
    fn unknown_and_empty_inputs_are_typed_errors() {
        assert!(matches!(
            load(b"", None),
            Err(Error::UnknownFormat { len: 0, .. })
        ));
        let e = load(&[0xde, 0xad, 0xbe, 0xef], None).unwrap_err();
        assert!(matches!(e, Error::UnknownFormat { .. }), "{e}");
        assert!(
            e.to_string().ends_with("binary data (bytes de ad be ef)"),
            "{e}"
        );
        let e = load(b"hello world\nsecond line", None).unwrap_err();
        assert!(e.to_string().ends_with("text \"hello world...\""), "{e}");
        for f in [Format::Gltf, Format::Obj, Format::Ply, Format::Stl] {
            assert!(matches!(load(b"", Some(f)), Err(Error::Malformed { .. })));
        }
    }

    #[test]
    fn content_that_is_not_gltf_is_named_when_gltf_is_asked_for() {
        // What a text file or an archive saved as .glb reaches the loader as.
        let e = load(b"hello world", Some(Format::Gltf)).unwrap_err();
        assert!(
            e.to_string()
                .ends_with("it starts with text \"hello world\""),
            "{e}"
        );
        let e = load(b"PK\x03\x04rest", Some(Format::Gltf)).unwrap_err();
        assert!(e.to_string().contains("bytes 50 4b 03 04"), "{e}");
        // A terminal escape is shown as bytes, never written raw.
        let e = load(b"\x1b[2Jcleared", None).unwrap_err();
        assert!(!e.to_string().contains('\x1b'), "{e}");
        // JSON that is not glTF still reaches the JSON reader.
        let e = load(b"  {\"not\": 1", Some(Format::Gltf)).unwrap_err();
        assert!(e.to_string().contains("(document)"), "{e}");
    }

    #[test]
    fn content_of_another_format_than_the_one_named_says_which_it_is() {
        for (bytes, named, is) in [
            (fixtures::INSTANCES_GLB, Format::Obj, "glTF"),
            (fixtures::INSTANCES_GLB, Format::Stl, "glTF"),
            (fixtures::PLY, Format::Gltf, "PLY"),
        ] {
            let message = load(bytes, Some(named)).unwrap_err().to_string();
            assert!(
                message.contains(&format!("the content is {is}"))
                    && message.contains(&format!("not {named}")),
                "{message}"
            );
        }
        // Named rightly, or not named, they load.
        assert!(load(fixtures::INSTANCES_GLB, Some(Format::Gltf)).is_ok());
        assert!(load(fixtures::PLY, Some(Format::Ply)).is_ok());
    }

    /// The triangles as sorted corner coordinates, each triangle turned to
    /// start at its smallest corner: the same for any vertex order.
    fn triangle_set(m: &TriMesh) -> Vec<[[u32; 3]; 3]> {
        let mut set: Vec<[[u32; 3]; 3]> = m
            .triangles()
            .iter()
            .map(|t| {
                let c = t.map(|i| m.positions()[i as usize].map(f32::to_bits));
                let first = (0..3).min_by_key(|&k| c[k]).unwrap();
                [c[first], c[(first + 1) % 3], c[(first + 2) % 3]]
            })
            .collect();
        set.sort_unstable();
        set
    }

    #[test]
    fn the_icosphere_fixtures_hold_the_same_mesh_in_every_format() {
        let obj = load(fixtures::OBJ, None).unwrap();
        assert_eq!(obj.positions().len(), fixtures::VERTICES);
        assert_eq!(obj.triangles().len(), fixtures::TRIANGLES);
        for p in obj.positions() {
            let r = p.map(f64::from).iter().map(|c| c * c).sum::<f64>().sqrt();
            assert!((r - 1.0).abs() < 1e-6, "{p:?} at {r}");
        }
        let expected = triangle_set(&obj);
        for (format, bytes) in [(Format::Ply, fixtures::PLY), (Format::Stl, fixtures::STL)] {
            assert_eq!(sniff(bytes), Some(format));
            let m = load(bytes, None).unwrap();
            assert_eq!(m.positions().len(), fixtures::VERTICES, "{format}");
            assert_eq!(triangle_set(&m), expected, "{format}");
        }
        // The glTF's untransformed instance is the same icosphere.
        let glb = load(fixtures::INSTANCES_GLB, None).unwrap();
        let origin = glb
            .parts()
            .iter()
            .find(|p| glb.vertex(p.first_vertex).length() < 1.5)
            .unwrap();
        let part = glb
            .filter_triangles(|t| {
                (origin.first_triangle..origin.first_triangle + origin.triangle_count)
                    .contains(&(t as u32))
            })
            .unwrap();
        assert_eq!(triangle_set(&part), expected);
    }
}
