//! ASCII elements, one per non-blank line.

use super::*;

/// Non-blank ASCII data lines with their file line numbers.
pub(super) struct Lines<'a> {
    pub(super) rest: &'a [u8],
    pub(super) number: usize,
}

impl<'a> Lines<'a> {
    pub(super) fn next(&mut self) -> Option<&'a [u8]> {
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

pub(super) fn ascii_element(
    lines: &mut Lines,
    element: &Element,
    role: Role,
    out: &mut Output,
) -> Result<()> {
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
            Role::Face(_) => out.end_face()?,
            Role::Skip => {}
        }
    }
    Ok(())
}
