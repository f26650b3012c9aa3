//! Stanford PLY: ASCII, binary little-endian and binary big-endian.
//!
//! Reads `x`, `y`, `z` of the `vertex` element (any scalar type) and the
//! `vertex_indices` (or `vertex_index`) list of the `face` element, splitting
//! polygons into triangle fans and skipping faces with fewer than 3 corners.
//! Every other property and element (normals, colours, edges, materials, ...)
//! is skipped by its declared type, so files with extra data load unchanged.
//! Counts in the header are never trusted for allocation: a truncated or lying
//! file is an error that says so.

use crate::error::{Error, Format, Result};
use crate::mesh::TriMesh;
use crate::mesh::io::SizeLimit;
use ascii::{Lines, ascii_element};
use binary::{Reader, binary_element};
use header::{Element, Encoding, Kind, Property, Scalar, parse_header};

mod ascii;
mod binary;
mod header;
#[cfg(test)]
mod tests;

pub(super) fn parse(bytes: &[u8], limit: SizeLimit) -> Result<TriMesh> {
    let header = parse_header(bytes)?;
    let plan = Plan::new(&header.elements)?;
    let data = bytes.get(header.data_start..).unwrap_or_default();
    // Checked before anything is allocated; the triangles as they come,
    // since a face's corner count is known only when it is read.
    // A vertex takes at least 3 bytes (x, y, z as chars): a lying count is
    // left for the reader to report as a truncated file.
    let vertices = capacity(u64::from(plan.vertex_count), data.len(), 3);
    limit.check(vertices, 0)?;
    let mut out = Output {
        positions: Vec::new(),
        triangles: Vec::new(),
        corners: Vec::new(),
        vertex_count: plan.vertex_count,
        max_triangles: limit.triangles_beside(vertices),
        limit,
    };
    match header.encoding {
        Encoding::Ascii => {
            let mut lines = Lines {
                rest: data,
                number: header.lines,
            };
            for (index, element) in header.elements.iter().enumerate() {
                ascii_element(&mut lines, element, plan.role(index), &mut out)?;
            }
        }
        Encoding::Binary { big_endian } => {
            let mut reader = Reader {
                data,
                pos: 0,
                base: header.data_start,
                big_endian,
            };
            for (index, element) in header.elements.iter().enumerate() {
                binary_element(&mut reader, element, plan.role(index), &mut out)?;
            }
        }
    }
    TriMesh::new(out.positions, out.triangles)
}

/// What to take from each element.
#[derive(Clone, Copy)]
enum Role {
    /// Property indices of x, y, z.
    Vertex([usize; 3]),
    /// Property index of the corner list.
    Face(usize),
    Skip,
}

struct Plan {
    vertex: usize,
    xyz: [usize; 3],
    face: usize,
    list: usize,
    vertex_count: u32,
}

impl Plan {
    fn new(elements: &[Element]) -> Result<Plan> {
        let unique = |name: &str, missing: &str| {
            let mut found = elements.iter().enumerate().filter(|(_, e)| e.name == name);
            match (found.next(), found.next()) {
                (Some(first), None) => Ok(first),
                (None, _) => Err(malformed("header", missing)),
                (Some(_), Some(_)) => Err(malformed(
                    "header",
                    format!("the header declares the '{name}' element twice"),
                )),
            }
        };
        let (vertex, vertices) = unique(
            "vertex",
            "the header declares no 'vertex' element: there is nothing to load",
        )?;
        let (face, faces) = unique(
            "face",
            "the header declares no 'face' element: the file holds points, not a surface",
        )?;
        let mut xyz = [0; 3];
        for (slot, axis) in xyz.iter_mut().zip(["x", "y", "z"]) {
            let (index, property) = vertices
                .properties
                .iter()
                .enumerate()
                .find(|(_, p)| p.name == axis)
                .ok_or_else(|| {
                    malformed(
                        "header",
                        format!("the vertex element has no '{axis}' property"),
                    )
                })?;
            if matches!(property.kind, Kind::List { .. }) {
                return Err(malformed(
                    "header",
                    format!("the vertex property '{axis}' is a list, not a number"),
                ));
            }
            *slot = index;
        }
        let (list, property) = faces
            .properties
            .iter()
            .enumerate()
            .find(|(_, p)| p.name == "vertex_indices" || p.name == "vertex_index")
            .ok_or_else(|| {
                malformed(
                    "header",
                    "the face element has no 'vertex_indices' (or 'vertex_index') list",
                )
            })?;
        match property.kind {
            Kind::List { item, .. } if item.is_integer() => {}
            Kind::List { .. } => {
                return Err(malformed(
                    "header",
                    format!("the face list '{}' must hold integers", property.name),
                ));
            }
            Kind::Scalar(_) => {
                return Err(malformed(
                    "header",
                    format!("the face property '{}' must be a list", property.name),
                ));
            }
        }
        let vertex_count = u32::try_from(vertices.count).map_err(|_| {
            malformed(
                "header",
                format!(
                    "the header declares {} vertices; at most {} are supported",
                    vertices.count,
                    u32::MAX
                ),
            )
        })?;
        Ok(Plan {
            vertex,
            xyz,
            face,
            list,
            vertex_count,
        })
    }

    fn role(&self, element: usize) -> Role {
        if element == self.vertex {
            Role::Vertex(self.xyz)
        } else if element == self.face {
            Role::Face(self.list)
        } else {
            Role::Skip
        }
    }
}

struct Output {
    positions: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
    /// Scratch for the current face's corners.
    corners: Vec<u32>,
    vertex_count: u32,
    /// The most triangles the size limit leaves beside the vertices.
    max_triangles: usize,
    limit: SizeLimit,
}

impl Output {
    /// Checks a face corner against the declared vertex count.
    fn corner(&mut self, index: f64, face: u64, at: impl FnOnce() -> String) -> Result<()> {
        // `index` is an integer (the list's type is): the range check is exact.
        if index >= 0.0 && index < self.vertex_count as f64 {
            self.corners.push(index as u32);
            Ok(())
        } else {
            Err(malformed(
                at(),
                format!(
                    "face {face} refers to vertex {index} but the file declares only {} vertices",
                    self.vertex_count
                ),
            ))
        }
    }

    /// Adds the current face as a fan; fewer than 3 corners add nothing.
    fn end_face(&mut self) -> Result<()> {
        let adds = self.corners.len().saturating_sub(2);
        if self.triangles.len() + adds > self.max_triangles {
            return self
                .limit
                .check(self.vertex_count as usize, self.triangles.len() + adds);
        }
        if let Some((&first, rest)) = self.corners.split_first() {
            for pair in rest.windows(2) {
                if let [b, c] = *pair {
                    self.triangles.push([first, b, c]);
                }
            }
        }
        self.corners.clear();
        Ok(())
    }
}

/// How many instances to pre-allocate for: the count, capped by what the
/// remaining data could hold.
fn capacity(count: u64, remaining: usize, min_size: usize) -> usize {
    let fits = remaining / min_size.max(1);
    usize::try_from(count).map_or(fits, |c| c.min(fits))
}

fn truncated(at: String, done: u64, element: &Element) -> Error {
    malformed(
        at,
        format!(
            "the file ends after {done} of {} declared {} (truncated?)",
            element.count,
            element.plural()
        ),
    )
}

fn words(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(u8::is_ascii_whitespace)
        .filter(|w| !w.is_empty())
}

fn text(word: &[u8]) -> Option<&str> {
    std::str::from_utf8(word).ok()
}

fn integer(word: &[u8]) -> Option<i64> {
    text(word)?.parse().ok()
}

/// A word for a message: escaped, and cut short if it is long garbage.
fn show(word: &[u8]) -> crate::error::FileText {
    crate::error::FileText::word(word)
}

fn malformed(location: impl Into<String>, message: impl Into<String>) -> Error {
    Error::malformed(Format::Ply, location, message)
}
