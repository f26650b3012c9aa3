//! Wavefront OBJ, geometry only.
//!
//! Reads `v x y z [w]` (a `w` or trailing vertex colours are ignored) and `f`
//! faces whose corners are written `i`, `i/t`, `i//n` or `i/t/n`, with positive
//! or negative (relative) indices; polygons become triangle fans. Handles `#`
//! comments, `\r\n` line ends and `\` line continuations. Every other statement
//! (`vt`, `vn`, `o`, `g`, `s`, `usemtl`, `mtllib`, `l`, `p`, ...) is skipped:
//! matching needs only the surface.

use crate::error::{Error, Format, Result};
use crate::mesh::TriMesh;
use crate::mesh::io::SizeLimit;

pub(super) fn parse(bytes: &[u8], limit: SizeLimit) -> Result<TriMesh> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let mut obj = Obj {
        positions: Vec::new(),
        triangles: Vec::new(),
        corners: Vec::new(),
        limit,
    };
    // A statement continued with `\` is gathered here; errors name its first line.
    let mut joined = Vec::new();
    let mut joined_from: Option<usize> = None;
    for (i, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let number = i + 1;
        let line = raw.strip_suffix(b"\r").unwrap_or(raw);
        // A comment ending in `\` (a Windows path, say) must not swallow the
        // next statement.
        let head = line
            .strip_suffix(b"\\")
            .filter(|_| joined_from.is_some() || !line.trim_ascii_start().starts_with(b"#"));
        match (head, joined_from) {
            (Some(head), _) => {
                joined_from.get_or_insert(number);
                joined.extend_from_slice(head);
                joined.push(b' ');
            }
            (None, Some(first)) => {
                joined.extend_from_slice(line);
                obj.statement(&joined, first)?;
                joined.clear();
                joined_from = None;
            }
            (None, None) => obj.statement(line, number)?,
        }
    }
    if let Some(first) = joined_from {
        obj.statement(&joined, first)?;
    }
    TriMesh::new(obj.positions, obj.triangles)
}

struct Obj {
    positions: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
    /// Scratch for the corners of the current face, reused to avoid an
    /// allocation per face.
    corners: Vec<u32>,
    /// Checked before the mesh grows: a polygon of short indices makes
    /// six times its bytes of triangles.
    limit: SizeLimit,
}

impl Obj {
    /// Handles one logical line (continuations already joined).
    fn statement(&mut self, line: &[u8], number: usize) -> Result<()> {
        let line = line.trim_ascii_start();
        let (keyword, rest) = match line.iter().position(u8::is_ascii_whitespace) {
            Some(end) => line.split_at(end),
            None => (line, &[][..]),
        };
        let what = match keyword {
            b"v" => "vertex",
            b"f" => "face",
            _ => return Ok(()),
        };
        // A comment may trail the statement.
        let rest = rest.split(|&b| b == b'#').next().unwrap_or(rest);
        let text = std::str::from_utf8(rest).map_err(|_| {
            malformed(
                number,
                format!("the {what} statement contains bytes that are not valid UTF-8 text"),
            )
        })?;
        if keyword == b"v" {
            self.vertex(text, number)
        } else {
            self.face(text, number)
        }
    }

    fn vertex(&mut self, text: &str, number: usize) -> Result<()> {
        let mut words = text.split_ascii_whitespace();
        let mut p = [0.0f32; 3];
        for (given, c) in p.iter_mut().enumerate() {
            let word = words.next().ok_or_else(|| {
                malformed(
                    number,
                    format!("a vertex needs x, y and z coordinates, but only {given} are given"),
                )
            })?;
            *c = word.parse().map_err(|_| {
                malformed(
                    number,
                    format!("vertex coordinate '{}' is not a number", shorten(word)),
                )
            })?;
        }
        // A `w` or vertex colours may follow; they do not affect the shape.
        self.limit
            .check(self.positions.len() + 1, self.triangles.len())?;
        self.positions.push(p);
        Ok(())
    }

    fn face(&mut self, text: &str, number: usize) -> Result<()> {
        let defined = self.positions.len();
        self.corners.clear();
        for word in text.split_ascii_whitespace() {
            let index = parse_index(word).ok_or_else(|| {
                malformed(
                    number,
                    format!(
                        "face corner '{}' does not start with a vertex index (an integer)",
                        shorten(word)
                    ),
                )
            })?;
            let resolved = resolve(index, defined).ok_or_else(|| {
                let message = if index == 0 {
                    "face refers to vertex 0, but OBJ vertex indices start at 1".to_string()
                } else if index < 0 {
                    format!(
                        "face refers to vertex {index} (counting back from the last), but only {defined} vertices are defined so far"
                    )
                } else {
                    format!(
                        "face refers to vertex {index} but only {defined} vertices are defined so far"
                    )
                };
                malformed(number, message)
            })?;
            let resolved = u32::try_from(resolved).map_err(|_| {
                malformed(
                    number,
                    format!(
                        "face refers to vertex {index}: more than {} vertices are not supported",
                        u32::MAX
                    ),
                )
            })?;
            self.corners.push(resolved);
        }
        // A fan; faces with fewer than 3 corners add nothing.
        let adds = self.corners.len().saturating_sub(2);
        self.limit
            .check(self.positions.len(), self.triangles.len() + adds)?;
        if let Some((&first, rest)) = self.corners.split_first() {
            for pair in rest.windows(2) {
                if let [b, c] = *pair {
                    self.triangles.push([first, b, c]);
                }
            }
        }
        Ok(())
    }
}

/// The vertex index of a face corner (`i`, `i/t`, `i//n` or `i/t/n`; texture
/// and normal indices are not needed). Hand-rolled: faces hold most of the
/// numbers in a file.
fn parse_index(word: &str) -> Option<i64> {
    let bytes = word.as_bytes();
    let end = bytes.iter().position(|&b| b == b'/').unwrap_or(bytes.len());
    let digits = bytes.get(..end)?;
    let (negative, digits) = match digits.split_first() {
        Some((b'-', rest)) => (true, rest),
        Some((b'+', rest)) => (false, rest),
        _ => (false, digits),
    };
    if digits.is_empty() {
        return None;
    }
    let mut value: i64 = 0;
    for &d in digits {
        if !d.is_ascii_digit() {
            return None;
        }
        value = value.checked_mul(10)?.checked_add(i64::from(d - b'0'))?;
    }
    Some(if negative { -value } else { value })
}

/// The 0-based vertex an OBJ index names (1-based, or negative counting back
/// from the last vertex defined so far), if it exists.
fn resolve(index: i64, defined: usize) -> Option<usize> {
    let defined = i64::try_from(defined).ok()?;
    let zero_based = if index > 0 {
        index - 1
    } else if index < 0 {
        defined.checked_add(index)?
    } else {
        return None;
    };
    if (0..defined).contains(&zero_based) {
        usize::try_from(zero_based).ok()
    } else {
        None
    }
}

fn malformed(line: usize, message: impl Into<String>) -> Error {
    Error::malformed(Format::Obj, format!("line {line}"), message)
}

/// Keeps messages readable when a token is a long run of garbage.
/// A word for a message: escaped, and cut short if it is long garbage.
fn shorten(word: &str) -> crate::error::FileText {
    crate::error::FileText::word(word.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(bytes: &[u8]) -> Result<TriMesh> {
        super::parse(bytes, SizeLimit::new(u64::MAX))
    }

    fn message(e: Error) -> String {
        e.to_string()
    }

    #[test]
    fn quads_negative_indices_and_slashes() {
        let text = b"# a unit cube's bottom and one side\n\
            mtllib cube.mtl\n\
            o cube\n\
            v 0 0 0\n\
            v 1 0 0 1.0\n\
            v 1 1 0 0.5 0.2 0.1\n\
            v 0 1 0\n\
            vt 0 0\n\
            vt 1 0\n\
            vn 0 0 1\n\
            g bottom\n\
            usemtl red\n\
            s off\n\
            f 1/1/1 2/2/1 3//1 4\n\
            v 0 0 1\n\
            v 1 0 1\n\
            f -6 -5 -1 -2   # a quad with relative indices\n\
            l 1 2\n\
            p 1\n";
        let m = parse(text).unwrap();
        assert_eq!(m.positions().len(), 6);
        assert_eq!(m.positions()[2], [1.0, 1.0, 0.0]);
        assert_eq!(m.triangles(), &[[0, 1, 2], [0, 2, 3], [0, 1, 5], [0, 5, 4]]);
    }

    #[test]
    fn crlf_continuations_and_comments() {
        let text = b"v 0 0 0\r\nv 1 \\\r\n 0 0\r\n# C:\\models\\\r\nv 0 1 0\r\nf 1 \\\n2 3\r\n";
        let m = parse(text).unwrap();
        assert_eq!(
            m.positions(),
            &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
        );
        assert_eq!(m.triangles(), &[[0, 1, 2]]);
    }

    #[test]
    fn bom_tabs_and_missing_final_newline() {
        let m = parse(b"\xEF\xBB\xBFv\t0 0 0\nv 1 0 0\n  v 0 1 0\nf\t1 2 3").unwrap();
        assert_eq!(m.triangles(), &[[0, 1, 2]]);
    }

    #[test]
    fn faces_with_fewer_than_three_corners_add_nothing() {
        let m = parse(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\nf\nf 1 2 3\n").unwrap();
        assert_eq!(m.triangles(), &[[0, 1, 2]]);
    }

    #[test]
    fn out_of_range_indices_are_errors() {
        let e = parse(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n").unwrap_err();
        let text = message(e);
        assert!(text.contains("line 4"), "{text}");
        assert!(
            text.contains("face refers to vertex 9 but only 3 vertices are defined so far"),
            "{text}"
        );
        let e = message(parse(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n").unwrap_err());
        assert!(e.contains("start at 1"), "{e}");
        let e = message(parse(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n").unwrap_err());
        assert!(e.contains("vertex -4"), "{e}");
        // A face may only use vertices defined before it.
        let e = message(parse(b"f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n").unwrap_err());
        assert!(e.contains("only 0 vertices"), "{e}");
        let e = message(parse(b"v 0 0 0\nf 1 1 99999999999999999999999\n").unwrap_err());
        assert!(e.contains("does not start with a vertex index"), "{e}");
    }

    #[test]
    fn bad_vertices_are_errors() {
        let e = message(parse(b"v 0 0\n").unwrap_err());
        assert!(e.contains("only 2 are given"), "{e}");
        let e = message(parse(b"v 0 zero 0\n").unwrap_err());
        assert!(e.contains("'zero' is not a number"), "{e}");
        let e = message(parse(b"v 0 0 0\nv 1 \xff 0\n").unwrap_err());
        assert!(e.contains("line 2") && e.contains("UTF-8"), "{e}");
        assert!(matches!(
            parse(b"v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n"),
            Err(Error::NonFiniteCoordinate { vertex: 2, .. })
        ));
    }

    #[test]
    fn non_utf8_in_ignored_statements_is_fine() {
        let m = parse(b"# caf\xe9\nusemtl \xff\xfe\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 # \xff\n");
        assert_eq!(m.unwrap().triangles().len(), 1);
    }

    #[test]
    fn garbage_is_an_error_not_a_panic() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for len in 0..400 {
            let bytes: Vec<u8> = (0..len)
                .map(|_| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    // Bias towards characters OBJ statements are made of.
                    b"vf 0123-/#\\\n\r.e\xff"[(state % 16) as usize]
                })
                .collect();
            let _ = parse(&bytes);
        }
        assert!(parse(&[0xde, 0xad, 0xbe, 0xef, 0, 1, 2]).is_err());
        assert!(parse(b"").is_err());
    }

    #[test]
    fn an_exported_file_with_texture_coordinates_and_normals() {
        let m = parse(crate::mesh::io::fixtures::OBJ).unwrap();
        assert_eq!(m.positions().len(), crate::mesh::io::fixtures::VERTICES);
        assert_eq!(m.triangles().len(), crate::mesh::io::fixtures::TRIANGLES);
    }

    #[test]
    fn real_file_cow() {
        let m = parse(&crate::shared_bytes("models/cow.obj")).unwrap();
        assert_eq!(m.positions().len(), 2903);
        assert_eq!(m.triangles().len(), 5804);
    }
}
