//! The PLY header: the encoding, and each element's count and typed properties.

use super::*;

/// The scalar types a property can have.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Scalar {
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
    pub(super) fn from_name(name: &[u8]) -> Option<Scalar> {
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

    pub(super) fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    pub(super) fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// Decodes the value at the start of `b` (zero when `b` is too short,
    /// which the callers rule out by taking exactly `size()` bytes).
    ///
    /// Every type fits an f64 exactly, so integers come back exact too.
    pub(super) fn decode(self, b: &[u8], big_endian: bool) -> f64 {
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
pub(super) fn bytes_of<const N: usize>(b: &[u8], big_endian: bool) -> [u8; N] {
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
pub(super) enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

pub(super) struct Property {
    pub(super) name: String,
    pub(super) kind: Kind,
}

pub(super) struct Element {
    pub(super) name: String,
    pub(super) count: u64,
    pub(super) properties: Vec<Property>,
}

impl Element {
    /// The fewest bytes one binary instance can take (lists empty): caps
    /// pre-allocation by what the remaining data could hold.
    pub(super) fn min_binary_size(&self) -> usize {
        self.properties
            .iter()
            .map(|p| match p.kind {
                Kind::Scalar(s) => s.size(),
                Kind::List { count, .. } => count.size(),
            })
            .sum()
    }

    /// The size of every binary instance when there is no list.
    pub(super) fn fixed_size(&self) -> Option<usize> {
        self.properties
            .iter()
            .try_fold(0usize, |sum, p| match p.kind {
                Kind::Scalar(s) => sum.checked_add(s.size()),
                Kind::List { .. } => None,
            })
    }

    /// Words for messages: "vertices", "faces", "'edge' elements".
    pub(super) fn plural(&self) -> String {
        match self.name.as_str() {
            "vertex" => "vertices".to_string(),
            "face" => "faces".to_string(),
            name => format!("'{name}' elements"),
        }
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Encoding {
    Ascii,
    Binary { big_endian: bool },
}

pub(super) struct Header {
    pub(super) encoding: Encoding,
    pub(super) elements: Vec<Element>,
    /// Offset of the first data byte.
    pub(super) data_start: usize,
    /// Lines the header takes, so ASCII data errors name file lines.
    pub(super) lines: usize,
}

pub(super) fn parse_header(bytes: &[u8]) -> Result<Header> {
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
pub(super) fn parse_property<'a>(
    words: &mut impl Iterator<Item = &'a [u8]>,
    at: &str,
) -> Result<Property> {
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
