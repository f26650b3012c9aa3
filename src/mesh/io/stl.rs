//! STL, binary or ASCII, with vertices welded.
//!
//! Binary: an 80-byte header, a little-endian u32 triangle count and 50 bytes
//! per triangle. ASCII: `solid` ... `facet normal` / `outer loop` / three
//! `vertex x y z` / `endloop` / `endfacet` ... `endsolid`, in any case and
//! layout of whitespace, with or without names, several solids per file (a loop
//! with more than 3 vertices becomes a fan). A file is binary when its length
//! matches its triangle count, since binary headers often start with `solid`
//! too. STL repeats every vertex in every triangle; exactly equal positions are
//! merged so the mesh has the shared vertices later stages need.

use crate::error::{Error, Format, Result};
use crate::mesh::io::SizeLimit;
use crate::mesh::{TriMesh, weld_vertices};

const HEADER: usize = 80;
const RECORD: usize = 50;

pub(super) fn parse(bytes: &[u8], limit: SizeLimit) -> Result<TriMesh> {
    let declared = bytes
        .get(HEADER..HEADER + 4)
        .and_then(|b| <[u8; 4]>::try_from(b).ok())
        .map(u32::from_le_bytes);
    if let Some(count) = declared {
        if binary_size(count) == bytes.len() as u64 {
            return binary(bytes, limit);
        }
    }
    let text = trim_start(bytes);
    let is_ascii = text
        .get(..5)
        .is_some_and(|w| w.eq_ignore_ascii_case(b"solid"));
    match (is_ascii, declared) {
        (true, Some(count)) => ascii(bytes, limit).map_err(|e| {
            // A binary file whose header says "solid" but whose length is off
            // fails as text: the size is the useful thing to report then.
            if looks_binary(bytes) {
                size_mismatch(count, bytes.len())
            } else {
                e
            }
        }),
        (true, None) => ascii(bytes, limit),
        (false, Some(count)) => Err(size_mismatch(count, bytes.len())),
        (false, None) => Err(Error::malformed(
            Format::Stl,
            "header",
            format!(
                "the file has {} bytes, too few for a binary STL (at least 84), and does not start with 'solid' like an ASCII STL",
                bytes.len()
            ),
        )),
    }
}

fn binary_size(count: u32) -> u64 {
    (HEADER + 4) as u64 + RECORD as u64 * count as u64
}

fn size_mismatch(count: u32, len: usize) -> Error {
    let expected = binary_size(count);
    let hint = if (len as u64) < expected {
        " (truncated?)"
    } else {
        ""
    };
    Error::malformed(
        Format::Stl,
        "byte 80",
        format!(
            "binary STL declares {count} triangles ({expected} bytes) but the file has {len} bytes{hint}"
        ),
    )
}

/// Text has no control bytes other than whitespace; binary floats almost
/// always do.
fn looks_binary(bytes: &[u8]) -> bool {
    bytes
        .iter()
        .any(|&b| b < 0x20 && !matches!(b, b'\t' | b'\n' | b'\r' | 0x0b | 0x0c))
}

fn trim_start(bytes: &[u8]) -> &[u8] {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    bytes.trim_ascii_start()
}

/// Reads a binary STL whose length the caller has checked.
fn binary(bytes: &[u8], limit: SizeLimit) -> Result<TriMesh> {
    let records = bytes.get(HEADER + 4..).unwrap_or_default();
    // Welded, a closed surface has about half as many vertices as
    // triangles; the welded mesh is checked again below.
    let count = records.len() / RECORD;
    limit.check(count / 2, count)?;
    let mut corners = Vec::with_capacity(records.len() / RECORD * 3);
    for record in records.chunks_exact(RECORD) {
        // Skip the normal (recomputed from the corners when needed) and the
        // attribute word.
        let coords = record.get(12..48).unwrap_or_default();
        let mut floats = coords
            .chunks_exact(4)
            .filter_map(|b| <[u8; 4]>::try_from(b).ok())
            .map(f32::from_le_bytes);
        for _ in 0..3 {
            let mut p = [0.0f32; 3];
            for c in &mut p {
                *c = floats.next().unwrap_or(0.0);
            }
            corners.push(p);
        }
    }
    weld(corners, "header", limit)
}

/// Whitespace-separated words with the line each starts on.
struct Words<'a> {
    bytes: &'a [u8],
    pos: usize,
    line: usize,
}

impl<'a> Words<'a> {
    fn next(&mut self) -> Option<&'a [u8]> {
        while let Some(&b) = self.bytes.get(self.pos) {
            if !b.is_ascii_whitespace() {
                break;
            }
            if b == b'\n' {
                self.line += 1;
            }
            self.pos += 1;
        }
        let start = self.pos;
        while let Some(&b) = self.bytes.get(self.pos) {
            if b.is_ascii_whitespace() {
                break;
            }
            self.pos += 1;
        }
        self.bytes.get(start..self.pos).filter(|w| !w.is_empty())
    }

    /// Skips a solid's name, which runs to the end of the line.
    fn skip_line(&mut self) {
        while let Some(&b) = self.bytes.get(self.pos) {
            if b == b'\n' {
                break;
            }
            self.pos += 1;
        }
    }

    fn error(&self, message: impl Into<String>) -> Error {
        Error::malformed(Format::Stl, format!("line {}", self.line), message)
    }

    /// The next word, which must be `keyword` (any case).
    fn expect(&mut self, keyword: &str) -> Result<()> {
        match self.next() {
            Some(w) if w.eq_ignore_ascii_case(keyword.as_bytes()) => Ok(()),
            Some(w) => Err(self.error(format!("expected '{keyword}', found '{}'", show(w)))),
            None => Err(self.error(format!(
                "the file ends where '{keyword}' was expected (truncated?)"
            ))),
        }
    }

    fn number(&mut self, what: &str) -> Result<f32> {
        match self.next() {
            Some(w) => std::str::from_utf8(w)
                .ok()
                .and_then(|t| t.parse().ok())
                .ok_or_else(|| self.error(format!("{what} '{}' is not a number", show(w)))),
            None => Err(self.error(format!(
                "the file ends where a {what} was expected (truncated?)"
            ))),
        }
    }
}

fn ascii(bytes: &[u8], limit: SizeLimit) -> Result<TriMesh> {
    let mut words = Words {
        bytes,
        pos: 0,
        line: 1,
    };
    if bytes.starts_with(b"\xEF\xBB\xBF") {
        words.pos = 3;
    }
    let mut corners = Vec::new();
    let mut loop_corners: Vec<[f32; 3]> = Vec::new();
    while let Some(word) = words.next() {
        if word.eq_ignore_ascii_case(b"solid") || word.eq_ignore_ascii_case(b"endsolid") {
            words.skip_line();
        } else if word.eq_ignore_ascii_case(b"facet") {
            facet(&mut words, &mut loop_corners)?;
            let triangles = corners.len() / 3 + loop_corners.len().saturating_sub(2);
            limit.check(triangles / 2, triangles)?;
            // A fan over the loop; STL loops are triangles, but be lenient.
            if let Some((&first, rest)) = loop_corners.split_first() {
                for pair in rest.windows(2) {
                    if let [b, c] = *pair {
                        corners.extend_from_slice(&[first, b, c]);
                    }
                }
            }
        } else {
            return Err(words.error(format!(
                "expected 'facet' or 'endsolid', found '{}'",
                show(word)
            )));
        }
    }
    weld(corners, "end of file", limit)
}

/// Reads one facet after its `facet` keyword, leaving its corners in `corners`.
fn facet(words: &mut Words, corners: &mut Vec<[f32; 3]>) -> Result<()> {
    corners.clear();
    words.expect("normal")?;
    for _ in 0..3 {
        // Some writers print broken normals such as `1.#QNAN`; they are not
        // used, so only a missing value (the next keyword) is an error.
        match words.next() {
            Some(w) if w.first().is_some_and(u8::is_ascii_alphabetic) && !is_number(w) => {
                return Err(words.error(format!(
                    "a facet normal needs 3 numbers, found '{}'",
                    show(w)
                )));
            }
            Some(_) => {}
            None => {
                return Err(words.error("the file ends inside a facet (truncated?)"));
            }
        }
    }
    words.expect("outer")?;
    words.expect("loop")?;
    loop {
        match words.next() {
            Some(w) if w.eq_ignore_ascii_case(b"vertex") => {
                let mut p = [0.0f32; 3];
                for c in &mut p {
                    *c = words.number("vertex coordinate")?;
                }
                corners.push(p);
            }
            Some(w) if w.eq_ignore_ascii_case(b"endloop") => break,
            Some(w) => {
                return Err(words.error(format!(
                    "expected 'vertex' or 'endloop', found '{}'",
                    show(w)
                )));
            }
            None => return Err(words.error("the file ends inside a facet (truncated?)")),
        }
    }
    if corners.len() < 3 {
        return Err(words.error(format!(
            "a facet needs 3 vertices, this one has {}",
            corners.len()
        )));
    }
    words.expect("endfacet")
}

fn is_number(word: &[u8]) -> bool {
    std::str::from_utf8(word).is_ok_and(|t| t.parse::<f32>().is_ok())
}

/// Merges exactly equal corners into shared vertices.
fn weld(corners: Vec<[f32; 3]>, location: &str, limit: SizeLimit) -> Result<TriMesh> {
    if corners.len() > u32::MAX as usize {
        return Err(Error::malformed(
            Format::Stl,
            location,
            format!(
                "the file has {} triangles; at most {} are supported",
                corners.len() / 3,
                u32::MAX / 3
            ),
        ));
    }
    let (ids, count) = weld_vertices(&corners);
    limit.check(count, corners.len() / 3)?;
    let mut positions = Vec::with_capacity(count);
    // Ids are dense in order of first use: a new id is the next position.
    for (p, &id) in corners.iter().zip(&ids) {
        if id as usize == positions.len() {
            positions.push(*p);
        }
    }
    drop(corners);
    let triangles = ids
        .chunks_exact(3)
        .filter_map(|t| <[u32; 3]>::try_from(t).ok())
        .collect();
    TriMesh::new(positions, triangles)
}

/// A word for a message: escaped, and cut short if it is long garbage.
fn show(word: &[u8]) -> crate::error::FileText {
    crate::error::FileText::word(word)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(bytes: &[u8]) -> Result<TriMesh> {
        super::parse(bytes, SizeLimit::new(u64::MAX))
    }
    use crate::mesh::io::fixtures;

    /// A binary STL of the given triangles, with `header` at the start.
    fn binary_stl(header: &[u8], triangles: &[[[f32; 3]; 3]]) -> Vec<u8> {
        let mut file = vec![b' '; HEADER];
        file[..header.len()].copy_from_slice(header);
        file.extend_from_slice(&(triangles.len() as u32).to_le_bytes());
        for t in triangles {
            for _ in 0..3 {
                file.extend_from_slice(&0.5f32.to_le_bytes());
            }
            for c in t.iter().flatten() {
                file.extend_from_slice(&c.to_le_bytes());
            }
            file.extend_from_slice(&[0x12, 0x34]);
        }
        file
    }

    /// Two triangles sharing an edge, the first written with -0.0.
    const SQUARE: [[[f32; 3]; 3]; 2] = [
        [[-0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]],
        [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
    ];

    #[test]
    fn binary_is_welded() {
        for header in [&b"made by a test"[..], b"solid square"] {
            let m = parse(&binary_stl(header, &SQUARE)).unwrap();
            assert_eq!(m.positions().len(), 4);
            assert_eq!(m.triangles(), &[[0, 1, 2], [0, 2, 3]]);
            assert_eq!(m.positions()[3], [0.0, 1.0, 0.0]);
        }
    }

    #[test]
    fn ascii_is_welded_and_tolerant() {
        let text = b"  solid Square Part 1\r\n\
            facet normal 0 0 1\r\n outer loop\r\n\
            vertex 0 0 0\r\n vertex 1 0 0\r\n vertex 1 1 0\r\n\
            endloop\r\n endfacet\r\n\
            endsolid Square Part 1\r\n\
            SOLID\n\
            FACET NORMAL 0 0 1.#QNAN OUTER LOOP\n\
            \tVERTEX 0.0e0 0 -0 VERTEX 1 1 0\n\tvertex 0 1 0 ENDLOOP ENDFACET\n\
            facet normal -nan 0 0\n  outer   loop\n vertex 5 5 5\n vertex 6 5 5\n vertex 6 6 5\n vertex 5 6 5\n endloop\n endfacet\n\
            endsolid";
        let m = parse(text).unwrap();
        assert_eq!(m.positions().len(), 8);
        assert_eq!(m.triangles(), &[[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]]);
    }

    #[test]
    fn ascii_without_endsolid_and_names() {
        let m = parse(b"solid\nfacet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n").unwrap();
        assert_eq!(m.triangles(), &[[0, 1, 2]]);
    }

    #[test]
    fn ascii_errors_name_the_line() {
        let e = parse(b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 zero 0\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 5") && e.contains("'zero' is not a number"),
            "{e}"
        );
        let e = parse(b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("ends inside a facet"), "{e}");
        let e = parse(b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("needs 3 vertices, this one has 2"), "{e}");
        let e = parse(b"solid x\nfacet normal outer loop\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("normal needs 3 numbers"), "{e}");
        let e = parse(b"solid x\nfacets\n").unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("'facets'"), "{e}");
        assert!(matches!(
            parse(b"solid empty\nendsolid empty\n"),
            Err(Error::EmptyMesh { .. })
        ));
    }

    #[test]
    fn every_truncation_of_a_binary_file_is_an_error() {
        for header in [&b"made by a test"[..], b"solid square"] {
            let file = binary_stl(header, &SQUARE);
            for len in 0..file.len() {
                assert!(parse(&file[..len]).is_err(), "prefix of {len} bytes parsed");
            }
            let e = parse(&file[..file.len() - 1]).unwrap_err().to_string();
            assert!(
                e.contains(
                    "binary STL declares 2 triangles (184 bytes) but the file has 183 bytes"
                ),
                "{e}"
            );
        }
    }

    #[test]
    fn size_mismatch_and_garbage_are_errors() {
        let mut file = binary_stl(b"x", &SQUARE);
        file[80..84].copy_from_slice(&4_000_000_000u32.to_le_bytes());
        let e = parse(&file).unwrap_err().to_string();
        assert!(e.contains("declares 4000000000 triangles"), "{e}");
        assert!(parse(b"").is_err());
        assert!(parse(&[0xde, 0xad, 0xbe, 0xef]).is_err());
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for len in 0..300 {
            let mut bytes: Vec<u8> = (0..len)
                .map(|_| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    (state >> 24) as u8
                })
                .collect();
            let _ = parse(&bytes);
            if len >= 5 {
                bytes[..5].copy_from_slice(b"solid");
                let _ = parse(&bytes);
            }
        }
    }

    #[test]
    fn corrupted_bytes_never_panic() {
        let ascii = b"solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
        let binary = binary_stl(b"solid t", &SQUARE);
        for file in [&ascii[..], &binary] {
            for i in 0..file.len() {
                for value in [0u8, b' ', b'\n', b'9', 0x80, 0xff] {
                    let mut bad = file.to_vec();
                    bad[i] = value;
                    let _ = parse(&bad);
                }
            }
        }
    }

    #[test]
    fn an_exported_binary_file_is_welded_to_its_vertices() {
        let m = parse(fixtures::STL).unwrap();
        assert_eq!(m.positions().len(), fixtures::VERTICES);
        assert_eq!(m.triangles().len(), fixtures::TRIANGLES);
    }

    #[test]
    fn a_closed_mesh_round_trips_through_binary_stl() {
        // Every vertex is written once per triangle using it (six times,
        // or five at the icosahedron's corners); welding finds each once.
        let obj = super::super::load(fixtures::OBJ, Some(Format::Obj)).unwrap();
        let triangles: Vec<[[f32; 3]; 3]> = obj
            .triangles()
            .iter()
            .map(|t| t.map(|i| obj.positions()[i as usize]))
            .collect();
        let m = parse(&binary_stl(b"solid icosphere", &triangles)).unwrap();
        assert_eq!(m.triangles().len(), obj.triangles().len());
        assert_eq!(m.positions().len(), fixtures::VERTICES);
        for (t, corners) in m.triangles().iter().zip(&triangles) {
            assert_eq!(t.map(|i| m.positions()[i as usize]), *corners);
        }
    }
}
