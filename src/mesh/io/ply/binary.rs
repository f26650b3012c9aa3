//! Binary elements, little- or big-endian, read with a bounds-checked cursor.

use super::*;

/// Binary data with a cursor; offsets in messages are from the file start.
pub(super) struct Reader<'a> {
    pub(super) data: &'a [u8],
    pub(super) pos: usize,
    pub(super) base: usize,
    pub(super) big_endian: bool,
}

impl<'a> Reader<'a> {
    pub(super) fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.pos.checked_add(n)?;
        let bytes = self.data.get(self.pos..end)?;
        self.pos = end;
        Some(bytes)
    }

    pub(super) fn scalar(&mut self, ty: Scalar) -> Option<f64> {
        let big_endian = self.big_endian;
        self.take(ty.size()).map(|b| ty.decode(b, big_endian))
    }

    pub(super) fn remaining(&self) -> usize {
        self.data.len().saturating_sub(self.pos)
    }

    pub(super) fn location(&self) -> String {
        self.location_at(self.pos)
    }

    pub(super) fn location_at(&self, pos: usize) -> String {
        format!("byte {}", self.base.saturating_add(pos))
    }
}

pub(super) fn binary_element(
    r: &mut Reader,
    element: &Element,
    role: Role,
    out: &mut Output,
) -> Result<()> {
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
            Role::Face(_) => out.end_face()?,
            Role::Skip => {}
        }
    }
    Ok(())
}

/// Elements without lists have one size: check the whole run once, then read
/// the coordinates straight from each record.
pub(super) fn binary_fixed(
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

pub(super) fn scalar_size(p: &Property) -> usize {
    match p.kind {
        Kind::Scalar(s) => s.size(),
        Kind::List { .. } => 0,
    }
}
