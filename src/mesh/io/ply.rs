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

pub(super) fn parse(bytes: &[u8]) -> Result<TriMesh> {
    let header = parse_header(bytes)?;
    let plan = Plan::new(&header.elements)?;
    let data = bytes.get(header.data_start..).unwrap_or_default();
    let mut out = Output {
        positions: Vec::new(),
        triangles: Vec::new(),
        corners: Vec::new(),
        vertex_count: plan.vertex_count,
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

/// The scalar types a property can have.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn from_name(name: &[u8]) -> Option<Scalar> {
        Some(match name {
            b"char" | b"int8" => Scalar::I8,
            b"uchar" | b"uint8" => Scalar::U8,
            b"short" | b"int16" => Scalar::I16,
            b"ushort" | b"uint16" => Scalar::U16,
            b"int" | b"int32" => Scalar::I32,
            b"uint" | b"uint32" => Scalar::U32,
            b"float" | b"float32" => Scalar::F32,
            b"double" | b"float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// Decodes the value at the start of `b` (zero when `b` is too short,
    /// which the callers rule out by taking exactly `size()` bytes).
    ///
    /// Every type fits an f64 exactly, so integers come back exact too.
    fn decode(self, b: &[u8], big_endian: bool) -> f64 {
        match self {
            Scalar::I8 => i8::from_le_bytes(bytes_of(b, big_endian)) as f64,
            Scalar::U8 => u8::from_le_bytes(bytes_of(b, big_endian)) as f64,
            Scalar::I16 => i16::from_le_bytes(bytes_of(b, big_endian)) as f64,
            Scalar::U16 => u16::from_le_bytes(bytes_of(b, big_endian)) as f64,
            Scalar::I32 => i32::from_le_bytes(bytes_of(b, big_endian)) as f64,
            Scalar::U32 => u32::from_le_bytes(bytes_of(b, big_endian)) as f64,
            Scalar::F32 => f32::from_le_bytes(bytes_of(b, big_endian)) as f64,
            Scalar::F64 => f64::from_le_bytes(bytes_of(b, big_endian)),
        }
    }
}

/// The first `N` bytes of `b` in little-endian order.
fn bytes_of<const N: usize>(b: &[u8], big_endian: bool) -> [u8; N] {
    let mut a = [0u8; N];
    if let Some(s) = b.get(..N) {
        a.copy_from_slice(s);
    }
    if big_endian {
        a.reverse();
    }
    a
}

#[derive(Clone, Copy, Debug)]
enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

struct Property {
    name: String,
    kind: Kind,
}

struct Element {
    name: String,
    count: u64,
    properties: Vec<Property>,
}

impl Element {
    /// The fewest bytes one binary instance can take (lists empty): caps
    /// pre-allocation by what the remaining data could hold.
    fn min_binary_size(&self) -> usize {
        self.properties
            .iter()
            .map(|p| match p.kind {
                Kind::Scalar(s) => s.size(),
                Kind::List { count, .. } => count.size(),
            })
            .sum()
    }

    /// The size of every binary instance when there is no list.
    fn fixed_size(&self) -> Option<usize> {
        self.properties
            .iter()
            .try_fold(0usize, |sum, p| match p.kind {
                Kind::Scalar(s) => sum.checked_add(s.size()),
                Kind::List { .. } => None,
            })
    }

    /// Words for messages: "vertices", "faces", "'edge' elements".
    fn plural(&self) -> String {
        match self.name.as_str() {
            "vertex" => "vertices".to_string(),
            "face" => "faces".to_string(),
            name => format!("'{name}' elements"),
        }
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Encoding {
    Ascii,
    Binary { big_endian: bool },
}

struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    /// Offset of the first data byte.
    data_start: usize,
    /// Lines the header takes, so ASCII data errors name file lines.
    lines: usize,
}

fn parse_header(bytes: &[u8]) -> Result<Header> {
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut pos = 0;
    let mut number = 0;
    loop {
        let rest = bytes.get(pos..).unwrap_or_default();
        let (raw, next) = match rest.iter().position(|&b| b == b'\n') {
            Some(end) => (rest.split_at(end).0, pos + end + 1),
            None if !rest.is_empty() => (rest, bytes.len()),
            None => {
                return Err(malformed(
                    "header",
                    "the header has no 'end_header' line (is the file cut short?)",
                ));
            }
        };
        pos = next;
        number += 1;
        let line = raw.strip_suffix(b"\r").unwrap_or(raw);
        let at = format!("line {number}");
        if number == 1 {
            if line.trim_ascii() != b"ply" {
                return Err(malformed(
                    at,
                    "not a PLY file: the first line must be 'ply'",
                ));
            }
            continue;
        }
        let mut words = words(line);
        let Some(keyword) = words.next() else {
            continue;
        };
        match keyword {
            b"comment" | b"obj_info" => {}
            b"format" => {
                if encoding.is_some() {
                    return Err(malformed(at, "the header has two 'format' lines"));
                }
                encoding = Some(match words.next() {
                    Some(b"ascii") => Encoding::Ascii,
                    Some(b"binary_little_endian") => Encoding::Binary { big_endian: false },
                    Some(b"binary_big_endian") => Encoding::Binary { big_endian: true },
                    other => {
                        return Err(malformed(
                            at,
                            format!(
                                "unknown format '{}': expected ascii, binary_little_endian or binary_big_endian",
                                show(other.unwrap_or_default())
                            ),
                        ));
                    }
                });
            }
            b"element" => {
                let (Some(name), Some(count)) = (words.next(), words.next()) else {
                    return Err(malformed(at, "an element line needs a name and a count"));
                };
                let count = text(count)
                    .and_then(|c| c.parse::<u64>().ok())
                    .ok_or_else(|| {
                        malformed(
                            &at,
                            format!(
                                "element count '{}' is not a non-negative integer",
                                show(count)
                            ),
                        )
                    })?;
                elements.push(Element {
                    name: String::from_utf8_lossy(name).into_owned(),
                    count,
                    properties: Vec::new(),
                });
            }
            b"property" => {
                let Some(element) = elements.last_mut() else {
                    return Err(malformed(at, "a property appears before any element"));
                };
                let property = parse_property(&mut words, &at)?;
                element.properties.push(property);
            }
            b"end_header" => break,
            other => {
                return Err(malformed(
                    at,
                    format!("unknown header keyword '{}'", show(other)),
                ));
            }
        }
    }
    let encoding =
        encoding.ok_or_else(|| malformed("header", "the header has no 'format' line"))?;
    Ok(Header {
        encoding,
        elements,
        data_start: pos,
        lines: number,
    })
}

/// Parses what follows `property`: `<type> <name>` or `list <count type> <item type> <name>`.
fn parse_property<'a>(words: &mut impl Iterator<Item = &'a [u8]>, at: &str) -> Result<Property> {
    let scalar = |word: Option<&[u8]>| {
        let word = word.unwrap_or_default();
        Scalar::from_name(word).ok_or_else(|| {
            malformed(
                at,
                format!(
                    "unknown property type '{}': expected char, uchar, short, ushort, int, uint, float, double (or int8 ... float64)",
                    show(word)
                ),
            )
        })
    };
    let first = words.next();
    let kind = if first == Some(b"list") {
        let count = scalar(words.next())?;
        let item = scalar(words.next())?;
        if !count.is_integer() {
            return Err(malformed(at, "a list's count type must be an integer type"));
        }
        Kind::List { count, item }
    } else {
        Kind::Scalar(scalar(first)?)
    };
    let name = words
        .next()
        .ok_or_else(|| malformed(at, "the property has no name"))?;
    Ok(Property {
        name: String::from_utf8_lossy(name).into_owned(),
        kind,
    })
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
    fn end_face(&mut self) {
        if let Some((&first, rest)) = self.corners.split_first() {
            for pair in rest.windows(2) {
                if let [b, c] = *pair {
                    self.triangles.push([first, b, c]);
                }
            }
        }
        self.corners.clear();
    }
}

/// How many instances to pre-allocate for: the count, capped by what the
/// remaining data could hold.
fn capacity(count: u64, remaining: usize, min_size: usize) -> usize {
    let fits = remaining / min_size.max(1);
    usize::try_from(count).map_or(fits, |c| c.min(fits))
}

/// Binary data with a cursor; offsets in messages are from the file start.
struct Reader<'a> {
    data: &'a [u8],
    pos: usize,
    base: usize,
    big_endian: bool,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.pos.checked_add(n)?;
        let bytes = self.data.get(self.pos..end)?;
        self.pos = end;
        Some(bytes)
    }

    fn scalar(&mut self, ty: Scalar) -> Option<f64> {
        let big_endian = self.big_endian;
        self.take(ty.size()).map(|b| ty.decode(b, big_endian))
    }

    fn remaining(&self) -> usize {
        self.data.len().saturating_sub(self.pos)
    }

    fn location(&self) -> String {
        self.location_at(self.pos)
    }

    fn location_at(&self, pos: usize) -> String {
        format!("byte {}", self.base.saturating_add(pos))
    }
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

fn binary_element(r: &mut Reader, element: &Element, role: Role, out: &mut Output) -> Result<()> {
    if let Some(size) = element.fixed_size() {
        return binary_fixed(r, element, size, role, out);
    }
    let min_size = element.min_binary_size();
    match role {
        Role::Vertex(_) => out
            .positions
            .reserve(capacity(element.count, r.remaining(), min_size)),
        Role::Face(list) => {
            // Only faces with at least 3 corners make triangles.
            let corners = match element.properties.get(list).map(|p| p.kind) {
                Some(Kind::List { item, .. }) => 3 * item.size(),
                _ => 0,
            };
            out.triangles
                .reserve(capacity(element.count, r.remaining(), min_size + corners));
        }
        Role::Skip => {}
    }
    for i in 0..element.count {
        let mut p = [0.0f32; 3];
        for (pi, property) in element.properties.iter().enumerate() {
            match property.kind {
                Kind::Scalar(ty) => {
                    let value = r
                        .scalar(ty)
                        .ok_or_else(|| truncated(r.location(), i, element))?;
                    if let Role::Vertex(xyz) = role {
                        for (c, &axis) in p.iter_mut().zip(&xyz) {
                            if axis == pi {
                                *c = value as f32;
                            }
                        }
                    }
                }
                Kind::List { count, item } => {
                    // Locations are formatted only on error: this loop is hot.
                    let start = r.pos;
                    let n = r
                        .scalar(count)
                        .ok_or_else(|| truncated(r.location(), i, element))?;
                    if n < 0.0 {
                        return Err(malformed(
                            r.location_at(start),
                            format!("list '{}' has a negative length {n}", property.name),
                        ));
                    }
                    // An integer of at most 32 bits: exact.
                    let n = n as u64;
                    if matches!(role, Role::Face(list) if list == pi) {
                        for _ in 0..n {
                            let start = r.pos;
                            let index = r
                                .scalar(item)
                                .ok_or_else(|| truncated(r.location(), i, element))?;
                            out.corner(index, i, || r.location_at(start))?;
                        }
                    } else {
                        let skip = n
                            .checked_mul(item.size() as u64)
                            .and_then(|b| usize::try_from(b).ok());
                        if skip.and_then(|b| r.take(b)).is_none() {
                            return Err(truncated(r.location(), i, element));
                        }
                    }
                }
            }
        }
        match role {
            Role::Vertex(_) => out.positions.push(p),
            Role::Face(_) => out.end_face(),
            Role::Skip => {}
        }
    }
    Ok(())
}

/// Elements without lists have one size: check the whole run once, then read
/// the coordinates straight from each record.
fn binary_fixed(
    r: &mut Reader,
    element: &Element,
    size: usize,
    role: Role,
    out: &mut Output,
) -> Result<()> {
    let needed = (size as u64).checked_mul(element.count);
    let needed = needed.and_then(|n| usize::try_from(n).ok());
    let Some(records) = needed.and_then(|n| r.take(n)) else {
        let done = (r.remaining() / size.max(1)) as u64;
        let at = format!(
            "byte {}",
            r.base
                .saturating_add(r.pos)
                .saturating_add(done as usize * size)
        );
        return Err(truncated(at, done, element));
    };
    if size == 0 {
        // Nothing to read, nothing to keep.
        return Ok(());
    }
    match role {
        Role::Vertex(xyz) => {
            // Byte offset and type of each coordinate within a record.
            let mut fields = [(0usize, Scalar::F32); 3];
            for (field, &axis) in fields.iter_mut().zip(&xyz) {
                let offset = element.properties.iter().take(axis).map(scalar_size).sum();
                let ty = match element.properties.get(axis).map(|p| p.kind) {
                    Some(Kind::Scalar(ty)) => ty,
                    _ => Scalar::F32,
                };
                *field = (offset, ty);
            }
            out.positions.reserve(records.len() / size);
            for record in records.chunks_exact(size) {
                out.positions.push(fields.map(|(offset, ty)| {
                    let b = record.get(offset..).unwrap_or_default();
                    ty.decode(b, r.big_endian) as f32
                }));
            }
        }
        // A face element without a list cannot happen (the plan checks it);
        // any other element is skipped whole.
        Role::Face(_) | Role::Skip => {}
    }
    Ok(())
}

fn scalar_size(p: &Property) -> usize {
    match p.kind {
        Kind::Scalar(s) => s.size(),
        Kind::List { .. } => 0,
    }
}

/// Non-blank ASCII data lines with their file line numbers.
struct Lines<'a> {
    rest: &'a [u8],
    number: usize,
}

impl<'a> Lines<'a> {
    fn next(&mut self) -> Option<&'a [u8]> {
        while !self.rest.is_empty() {
            let (line, rest) = match self.rest.iter().position(|&b| b == b'\n') {
                Some(end) => {
                    let (line, rest) = self.rest.split_at(end);
                    (line, rest.get(1..).unwrap_or_default())
                }
                None => (self.rest, &[][..]),
            };
            self.rest = rest;
            self.number += 1;
            if !line.trim_ascii().is_empty() {
                return Some(line);
            }
        }
        None
    }
}

fn ascii_element(lines: &mut Lines, element: &Element, role: Role, out: &mut Output) -> Result<()> {
    if element.properties.is_empty() {
        // Nothing is stored for such an element, in ASCII as in binary.
        return Ok(());
    }
    let remaining = lines.rest.len();
    // Every value takes at least one character and one separator.
    let min_size = 2 * element.properties.len();
    match role {
        Role::Vertex(_) => out
            .positions
            .reserve(capacity(element.count, remaining, min_size)),
        // Only faces with at least 3 corners make triangles.
        Role::Face(_) => out
            .triangles
            .reserve(capacity(element.count, remaining, min_size + 6)),
        Role::Skip => {}
    }
    let singular = match element.name.as_str() {
        "vertex" | "face" => element.name.clone(),
        name => format!("'{name}' element"),
    };
    for i in 0..element.count {
        let line = lines
            .next()
            .ok_or_else(|| truncated(format!("line {}", lines.number), i, element))?;
        let at = || format!("line {}", lines.number);
        let too_few = || {
            malformed(
                at(),
                format!(
                    "{singular} {i} has too few values for the {} properties the header declares",
                    element.properties.len()
                ),
            )
        };
        let mut words = words(line);
        let mut p = [0.0f32; 3];
        for (pi, property) in element.properties.iter().enumerate() {
            let word = words.next().ok_or_else(too_few)?;
            match property.kind {
                Kind::Scalar(_) => {
                    if let Role::Vertex(xyz) = role {
                        if xyz.contains(&pi) {
                            let value = text(word).and_then(|t| t.parse::<f32>().ok());
                            let value = value.ok_or_else(|| {
                                malformed(
                                    at(),
                                    format!("vertex coordinate '{}' is not a number", show(word)),
                                )
                            })?;
                            for (c, &axis) in p.iter_mut().zip(&xyz) {
                                if axis == pi {
                                    *c = value;
                                }
                            }
                        }
                    }
                }
                Kind::List { .. } => {
                    let n = integer(word).filter(|&n| n >= 0).ok_or_else(|| {
                        malformed(
                            at(),
                            format!(
                                "list length '{}' of '{}' is not a non-negative integer",
                                show(word),
                                property.name
                            ),
                        )
                    })?;
                    let keep = matches!(role, Role::Face(list) if list == pi);
                    for _ in 0..n {
                        let word = words.next().ok_or_else(too_few)?;
                        if keep {
                            let index = integer(word).ok_or_else(|| {
                                malformed(
                                    at(),
                                    format!("vertex index '{}' is not an integer", show(word)),
                                )
                            })?;
                            out.corner(index as f64, i, at)?;
                        }
                    }
                }
            }
        }
        if words.next().is_some() {
            return Err(malformed(
                at(),
                format!(
                    "{singular} {i} has more values than the {} properties the header declares",
                    element.properties.len()
                ),
            ));
        }
        match role {
            Role::Vertex(_) => out.positions.push(p),
            Role::Face(_) => out.end_face(),
            Role::Skip => {}
        }
    }
    Ok(())
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

/// A word for a message, cut short if it is long garbage.
fn show(word: &[u8]) -> String {
    const MAX: usize = 32;
    let text = String::from_utf8_lossy(word.get(..MAX).unwrap_or(word)).into_owned();
    if word.len() > MAX { text + "..." } else { text }
}

fn malformed(location: impl Into<String>, message: impl Into<String>) -> Error {
    Error::malformed(Format::Ply, location, message)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Clone, Copy, PartialEq)]
    enum Out {
        Ascii,
        Little,
        Big,
    }

    /// A value as a test file stores it.
    fn put(buf: &mut Vec<u8>, out: Out, ty: Scalar, v: f64) {
        macro_rules! bytes {
            ($t:ty) => {
                match out {
                    Out::Big => buf.extend_from_slice(&(v as $t).to_be_bytes()),
                    _ => buf.extend_from_slice(&(v as $t).to_le_bytes()),
                }
            };
        }
        if out == Out::Ascii {
            if !buf.is_empty() && !buf.ends_with(b"\n") {
                buf.push(b' ');
            }
            buf.extend_from_slice(v.to_string().as_bytes());
            return;
        }
        match ty {
            Scalar::I8 => bytes!(i8),
            Scalar::U8 => bytes!(u8),
            Scalar::I16 => bytes!(i16),
            Scalar::U16 => bytes!(u16),
            Scalar::I32 => bytes!(i32),
            Scalar::U32 => bytes!(u32),
            Scalar::F32 => bytes!(f32),
            Scalar::F64 => bytes!(f64),
        }
    }

    fn end_record(buf: &mut Vec<u8>, out: Out) {
        if out == Out::Ascii {
            buf.push(b'\n');
        }
    }

    /// A file with a camera element before the vertices, normals and colours
    /// (and optionally a list) on the vertices, extra lists on the faces and an
    /// edge element at the end: everything the loader must skip.
    fn sample(out: Out, vertex_list: bool) -> Vec<u8> {
        use Scalar::*;
        let format = match out {
            Out::Ascii => "ascii",
            Out::Little => "binary_little_endian",
            Out::Big => "binary_big_endian",
        };
        let mut header = format!(
            "ply\nformat {format} 1.0\ncomment made by hand\nobj_info test\n\
             element camera 1\nproperty float view_px\nproperty float64 view_py\n\
             element vertex 5\nproperty float x\nproperty int16 y\nproperty double z\n\
             property float nx\nproperty float ny\nproperty float nz\n\
             property uchar red\nproperty uchar green\nproperty uint8 blue\n"
        );
        if vertex_list {
            header += "property list uchar float extra\n";
        }
        header += "element face 4\nproperty uchar flags\n\
             property list uchar int vertex_indices\nproperty list ushort float texcoord\n\
             element edge 2\nproperty int vertex1\nproperty int32 vertex2\nproperty char crease\n\
             end_header\n";
        let mut data = Vec::new();
        put(&mut data, out, F32, 1.5);
        put(&mut data, out, F64, -2.0);
        end_record(&mut data, out);
        let vertices = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.0, 1.25],
        ];
        for (i, v) in vertices.iter().enumerate() {
            put(&mut data, out, F32, v[0]);
            put(&mut data, out, I16, v[1]);
            put(&mut data, out, F64, v[2]);
            for n in [0.0, 0.0, 1.0] {
                put(&mut data, out, F32, n);
            }
            for c in [255.0, 128.0, 0.0] {
                put(&mut data, out, U8, c);
            }
            if vertex_list {
                put(&mut data, out, U8, i as f64);
                for k in 0..i {
                    put(&mut data, out, F32, k as f64 * 0.25);
                }
            }
            end_record(&mut data, out);
        }
        let faces: [&[f64]; 4] = [
            &[0.0, 1.0, 2.0, 3.0],
            &[0.0, 1.0, 4.0],
            &[0.0, 1.0],
            &[1.0, 2.0, 4.0],
        ];
        for (i, face) in faces.iter().enumerate() {
            put(&mut data, out, U8, 7.0);
            put(&mut data, out, U8, face.len() as f64);
            for &c in *face {
                put(&mut data, out, I32, c);
            }
            put(&mut data, out, U16, (2 * i) as f64);
            for k in 0..2 * i {
                put(&mut data, out, F32, k as f64 / 8.0);
            }
            end_record(&mut data, out);
        }
        for edge in [[0.0, 1.0, 1.0], [1.0, 2.0, -1.0]] {
            put(&mut data, out, I32, edge[0]);
            put(&mut data, out, I32, edge[1]);
            put(&mut data, out, I8, edge[2]);
            end_record(&mut data, out);
        }
        let mut file = header.into_bytes();
        file.extend_from_slice(&data);
        file
    }

    fn check_sample(m: &TriMesh) {
        assert_eq!(
            m.positions(),
            &[
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.5, 0.0, 1.25]
            ]
        );
        assert_eq!(m.triangles(), &[[0, 1, 2], [0, 2, 3], [0, 1, 4], [1, 2, 4]]);
    }

    #[test]
    fn ascii_and_both_binary_byte_orders() {
        for out in [Out::Ascii, Out::Little, Out::Big] {
            for vertex_list in [false, true] {
                let file = sample(out, vertex_list);
                let m = parse(&file).unwrap_or_else(|e| panic!("{e}"));
                check_sample(&m);
            }
        }
    }

    fn to_crlf(bytes: &[u8]) -> Vec<u8> {
        bytes
            .iter()
            .flat_map(|&b| {
                if b == b'\n' {
                    vec![b'\r', b'\n']
                } else {
                    vec![b]
                }
            })
            .collect()
    }

    #[test]
    fn crlf_header_and_ascii_data() {
        let file = sample(Out::Ascii, false);
        check_sample(&parse(&to_crlf(&file)).unwrap());
        let binary = sample(Out::Little, true);
        let split = binary
            .windows(11)
            .position(|w| w == b"end_header\n")
            .unwrap()
            + 11;
        let mut crlf = to_crlf(&binary[..split]);
        crlf.extend_from_slice(&binary[split..]);
        check_sample(&parse(&crlf).unwrap());
    }

    #[test]
    fn every_truncation_of_binary_files_is_an_error() {
        for out in [Out::Little, Out::Big] {
            for vertex_list in [false, true] {
                let file = sample(out, vertex_list);
                for len in 0..file.len() {
                    assert!(parse(&file[..len]).is_err(), "prefix of {len} bytes parsed");
                }
            }
        }
        let file = sample(Out::Little, false);
        let e = parse(&file[..file.len() - 3]).unwrap_err().to_string();
        assert!(
            e.contains("ends after 1 of 2 declared 'edge' elements (truncated?)"),
            "{e}"
        );
    }

    #[test]
    fn ascii_truncation_says_so() {
        let file = sample(Out::Ascii, false);
        let text = String::from_utf8(file).unwrap();
        let cut = text.find("7 3 0 1 4").unwrap();
        let e = parse(&text.as_bytes()[..cut]).unwrap_err().to_string();
        assert!(e.contains("ends after 1 of 4 declared faces"), "{e}");
    }

    #[test]
    fn corrupted_bytes_never_panic() {
        for out in [Out::Ascii, Out::Little, Out::Big] {
            let file = sample(out, true);
            for i in 0..file.len() {
                for value in [0u8, b' ', b'\n', b'9', 0x80, 0xff] {
                    let mut bad = file.clone();
                    bad[i] = value;
                    let _ = parse(&bad);
                }
            }
        }
    }

    #[test]
    fn garbage_is_an_error() {
        assert!(parse(b"").is_err());
        assert!(parse(b"ply").is_err());
        assert!(parse(b"ply\n").is_err());
        assert!(parse(&[0xde, 0xad, 0xbe, 0xef, 0, 1, 2, 3]).is_err());
        assert!(parse(b"ply\nformat ascii 1.0\nelement vertex 3\n").is_err());
    }

    fn ascii(body: &str) -> Result<TriMesh> {
        parse(format!("ply\nformat ascii 1.0\n{body}").as_bytes())
    }

    const TRIANGLE_HEADER: &str = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
         element face 1\nproperty list uchar uint vertex_index\nend_header\n";

    #[test]
    fn vertex_index_alias_and_blank_lines() {
        let m = ascii(&format!(
            "{TRIANGLE_HEADER}0 0 0\n\n1 0 0\n0 1 0\n3 0 1 2\n\n"
        ))
        .unwrap();
        assert_eq!(m.triangles(), &[[0, 1, 2]]);
    }

    #[test]
    fn out_of_range_indices_are_errors() {
        let e = ascii(&format!("{TRIANGLE_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 13"), "{e}");
        assert!(
            e.contains("face 0 refers to vertex 7 but the file declares only 3 vertices"),
            "{e}"
        );
        let e = ascii(&format!("{TRIANGLE_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("vertex -1"), "{e}");
        let mut file = b"ply\nformat binary_big_endian 1.0\n".to_vec();
        file.extend_from_slice(TRIANGLE_HEADER.as_bytes());
        for v in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
            file.extend_from_slice(&v.to_be_bytes());
        }
        file.push(3);
        for i in [0u32, 3, 1] {
            file.extend_from_slice(&i.to_be_bytes());
        }
        let e = parse(&file).unwrap_err().to_string();
        assert!(e.contains("face 0 refers to vertex 3"), "{e}");
        assert!(e.contains(&format!("byte {}", file.len() - 8)), "{e}");
    }

    #[test]
    fn header_errors_are_specific() {
        let e = ascii("element vertex 3\nproperty float x\nproperty float y\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("no 'z' property"), "{e}");
        let e = ascii(
            "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("no 'face' element"), "{e}");
        let e = ascii("element vertex 0\nproperty float x\nproperty float y\nproperty float z\nelement face 0\nproperty uchar flags\nend_header\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("no 'vertex_indices'"), "{e}");
        let e = ascii("element vertex 3\nproperty real x\nend_header\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("unknown property type 'real'") && e.contains("line 4"),
            "{e}"
        );
        let e = parse(b"ply\nformat binary_middle_endian 1.0\nend_header\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown format"), "{e}");
        let e = parse(b"ply\nformat ascii 1.0\nelement vertex 3\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("no 'end_header'"), "{e}");
    }

    #[test]
    fn huge_declared_counts_fail_without_allocating() {
        for format in ["ascii", "binary_little_endian"] {
            let header = format!(
                "ply\nformat {format} 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\n\
                 element face 4000000000\nproperty list uint uint vertex_indices\nend_header\n"
            );
            let mut file = header.into_bytes();
            file.extend_from_slice(&b"1 1 1\n".repeat(4));
            let e = parse(&file).unwrap_err().to_string();
            assert!(e.contains("of 4000000000 declared vertices"), "{e}");
        }
        // A face list claiming 4 billion corners.
        let mut file = b"ply\nformat binary_little_endian 1.0\n".to_vec();
        file.extend_from_slice(
            b"element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
              element face 1\nproperty list uint uint vertex_indices\nend_header\n",
        );
        for v in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
            file.extend_from_slice(&v.to_le_bytes());
        }
        file.extend_from_slice(&u32::MAX.to_le_bytes());
        file.extend_from_slice(&[0; 12]);
        let e = parse(&file).unwrap_err().to_string();
        assert!(e.contains("ends after 0 of 1 declared faces"), "{e}");
        let e = ascii("element vertex 5000000000\nproperty float x\nproperty float y\nproperty float z\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("at most 4294967295"), "{e}");
    }

    #[test]
    fn ascii_value_count_must_match_the_header() {
        let e = ascii(&format!("{TRIANGLE_HEADER}0 0 0\n1 0\n0 1 0\n3 0 1 2\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("vertex 1 has too few values"), "{e}");
        let e = ascii(&format!(
            "{TRIANGLE_HEADER}0 0 0\n1 0 0 5\n0 1 0\n3 0 1 2\n"
        ))
        .unwrap_err()
        .to_string();
        assert!(e.contains("vertex 1 has more values"), "{e}");
        let e = ascii(&format!(
            "{TRIANGLE_HEADER}0 0 0\n1 0 0\n0 one 0\n3 0 1 2\n"
        ))
        .unwrap_err()
        .to_string();
        assert!(e.contains("'one' is not a number"), "{e}");
    }

    #[test]
    fn an_exported_binary_file_with_normals_and_colours() {
        let m = parse(crate::mesh::io::fixtures::PLY).unwrap();
        assert_eq!(m.positions().len(), crate::mesh::io::fixtures::VERTICES);
        assert_eq!(m.triangles().len(), crate::mesh::io::fixtures::TRIANGLES);
    }

    #[test]
    fn real_file_horse() {
        let m = parse(&crate::shared_bytes("models/horse.ply")).unwrap();
        assert_eq!(m.positions().len(), 48485);
        assert_eq!(m.triangles().len(), 96966);
    }
}
