//! Buffers, views and accessors, read with every offset checked against the
//! bytes actually there.

use std::rc::Rc;

use base64::Engine as _;
use gltf::accessor::{DataType, Dimensions};

use super::Loader;
use crate::error::{Error, Format, Result};
use crate::mesh::io::{ResourceError, ResourcePath};

/// An accessor without a buffer view is zeros except for its sparse values:
/// its elements are not stored anywhere, so a few bytes could declare 10^15
/// of them. It may have at most this many elements per byte of the file.
const UNSTORED_ELEMENTS_PER_BYTE: usize = 1;

impl Loader<'_> {
    pub(super) fn buffer(&mut self, buffer: &gltf::Buffer) -> Result<&[u8]> {
        let i = buffer.index();
        let length = buffer.length();
        if self.buffers[i].is_none() {
            let data: Rc<[u8]> = match buffer.source() {
                gltf::buffer::Source::Bin => self
                    .blob
                    .ok_or_else(|| {
                        Error::malformed(
                            Format::Gltf,
                            format!("buffer {i}"),
                            "refers to the GLB binary chunk, which is missing",
                        )
                    })?
                    .into(),
                gltf::buffer::Source::Uri(uri) => match uri.strip_prefix("data:") {
                    Some(rest) => decode_data_uri(rest)
                        .map_err(|m| Error::malformed(Format::Gltf, format!("buffer {i}"), m))?
                        .into(),
                    None => self.resource(uri, length)?,
                },
            };
            if data.len() < length {
                return Err(Error::malformed(
                    Format::Gltf,
                    format!("buffer {i}"),
                    format!(
                        "declares {length} bytes but only {} are present (truncated file?)",
                        data.len()
                    ),
                ));
            }
            self.buffers[i] = Some(data);
        }
        Ok(self.buffers[i]
            .as_deref()
            .and_then(|data| data.get(..length))
            .unwrap_or_default())
    }

    /// An external resource's bytes, read once for every buffer naming it.
    fn resource(&mut self, uri: &str, length: usize) -> Result<Rc<[u8]>> {
        let refused = |reason: String| Error::ResourceRefused {
            uri: uri.into(),
            reason: reason.into(),
        };
        let path = ResourcePath::parse(uri).map_err(refused)?;
        if let Some(read) = self.resources_read.get(&path) {
            return Ok(Rc::clone(read));
        }
        let most = self.resource_lengths.get(&path).copied().unwrap_or(length);
        let mut bytes = match self.resources.resolve(&path, most.max(length)) {
            Ok(bytes) => bytes,
            Err(ResourceError::Missing) => {
                return Err(Error::MissingResource { uri: uri.into() });
            }
            Err(ResourceError::Refused(reason)) => return Err(refused(reason)),
        };
        bytes.truncate(most.max(length));
        let read: Rc<[u8]> = bytes.into();
        self.resources_read.insert(path, Rc::clone(&read));
        Ok(read)
    }

    /// The bytes of a buffer view, checked against the buffer.
    pub(super) fn view_bytes(&mut self, view: &gltf::buffer::View, at: &str) -> Result<&[u8]> {
        let (offset, length) = (view.offset(), view.length());
        let data = self.buffer(&view.buffer())?;
        offset
            .checked_add(length)
            .and_then(|end| data.get(offset..end))
            .ok_or_else(|| {
                Error::malformed(
                    Format::Gltf,
                    at,
                    format!(
                        "buffer view {} (bytes {offset}..+{length}) lies outside its buffer of {} bytes",
                        view.index(),
                        data.len()
                    ),
                )
            })
    }

    /// Reads every element of an accessor as raw component bytes, honouring
    /// byte strides and sparse substitution. Returns `count` elements of
    /// `elem` bytes each, packed.
    pub(super) fn read_elements(&mut self, acc: &gltf::Accessor, at: &str) -> Result<Vec<u8>> {
        let elem = acc.size();
        let count = acc.count();
        if acc.view().is_none() {
            if acc.sparse().is_none() {
                return Err(Error::malformed(
                    Format::Gltf,
                    at,
                    format!(
                        "accessor {} has neither a buffer view nor sparse values",
                        acc.index()
                    ),
                ));
            }
            let most = self.input_len.saturating_mul(UNSTORED_ELEMENTS_PER_BYTE);
            if count > most {
                return Err(Error::malformed(
                    Format::Gltf,
                    at,
                    format!(
                        "accessor {} has no buffer view but declares {count} elements, more than the {most} a file of {} bytes may leave unstored",
                        acc.index(),
                        self.input_len
                    ),
                ));
            }
        }
        let total = count
            .checked_mul(elem)
            .filter(|&t| t <= isize::MAX as usize / 2)
            .ok_or_else(|| Error::malformed(Format::Gltf, at, "accessor is impossibly large"))?;
        let mut out = match acc.view() {
            None => {
                // No view: zeros, unless sparse values fill some in.
                vec![0u8; total]
            }
            Some(view) => {
                let stride = view.stride().unwrap_or(elem);
                let offset = acc.offset();
                let bytes = self.view_bytes(&view, at)?;
                let needed = if count == 0 {
                    Some(offset)
                } else {
                    stride
                        .checked_mul(count - 1)
                        .and_then(|s| s.checked_add(offset))
                        .and_then(|s| s.checked_add(elem))
                };
                if stride < elem || needed.is_none_or(|n| n > bytes.len()) {
                    return Err(Error::malformed(
                        Format::Gltf,
                        at,
                        format!(
                            "accessor {} ({count} elements of {elem} bytes, stride {stride}, offset {offset}) does not fit its buffer view of {} bytes",
                            acc.index(),
                            bytes.len()
                        ),
                    ));
                }
                let mut out = Vec::with_capacity(total);
                for k in 0..count {
                    let s = offset + k * stride;
                    out.extend_from_slice(&bytes[s..s + elem]);
                }
                out
            }
        };
        if let Some(sparse) = acc.sparse() {
            let n = sparse.count();
            let idx_view = sparse.indices().view();
            let idx_size = match sparse.indices().index_type() {
                gltf::accessor::sparse::IndexType::U8 => 1,
                gltf::accessor::sparse::IndexType::U16 => 2,
                gltf::accessor::sparse::IndexType::U32 => 4,
            };
            let idx_off = sparse.indices().offset();
            let idx_bytes = self.view_bytes(&idx_view, at)?.to_vec();
            let val_view = sparse.values().view();
            let val_off = sparse.values().offset();
            let val_bytes = self.view_bytes(&val_view, at)?.to_vec();
            let idx_end = n.checked_mul(idx_size).and_then(|b| b.checked_add(idx_off));
            let val_end = n.checked_mul(elem).and_then(|b| b.checked_add(val_off));
            if idx_end.is_none_or(|e| e > idx_bytes.len())
                || val_end.is_none_or(|e| e > val_bytes.len())
            {
                return Err(Error::malformed(
                    Format::Gltf,
                    at,
                    "sparse accessor data exceeds its buffer views",
                ));
            }
            for k in 0..n {
                let b = &idx_bytes[idx_off + k * idx_size..idx_off + (k + 1) * idx_size];
                let target = match idx_size {
                    1 => b[0] as usize,
                    2 => u16::from_le_bytes([b[0], b[1]]) as usize,
                    _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize,
                };
                if target >= count {
                    return Err(Error::malformed(
                        Format::Gltf,
                        at,
                        format!("sparse index {target} is past the accessor's {count} elements"),
                    ));
                }
                out[target * elem..(target + 1) * elem]
                    .copy_from_slice(&val_bytes[val_off + k * elem..val_off + (k + 1) * elem]);
            }
        }
        Ok(out)
    }

    pub(super) fn read_positions(
        &mut self,
        acc: &gltf::Accessor,
        at: &str,
    ) -> Result<Vec<[f32; 3]>> {
        if acc.dimensions() != Dimensions::Vec3 {
            return Err(Error::malformed(
                Format::Gltf,
                at,
                "POSITION is not a VEC3 accessor",
            ));
        }
        let data_type = acc.data_type();
        let normalized = acc.normalized();
        let raw = self.read_elements(acc, at)?;
        let c = data_type.size();
        Ok(raw
            .chunks_exact(3 * c)
            .map(|e| {
                [0, 1, 2].map(|k| component_to_f32(&e[k * c..(k + 1) * c], data_type, normalized))
            })
            .collect())
    }

    pub(super) fn read_indices(&mut self, acc: &gltf::Accessor, at: &str) -> Result<Vec<u32>> {
        if acc.dimensions() != Dimensions::Scalar {
            return Err(Error::malformed(
                Format::Gltf,
                at,
                "indices are not a SCALAR accessor",
            ));
        }
        let data_type = acc.data_type();
        if !matches!(data_type, DataType::U8 | DataType::U16 | DataType::U32) {
            return Err(Error::malformed(
                Format::Gltf,
                at,
                "indices are not unsigned integers",
            ));
        }
        let raw = self.read_elements(acc, at)?;
        Ok(raw
            .chunks_exact(data_type.size())
            .map(|b| match b.len() {
                1 => b[0] as u32,
                2 => u16::from_le_bytes([b[0], b[1]]) as u32,
                _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            })
            .collect())
    }
}

/// One little-endian component as f32 (integer positions come from
/// KHR_mesh_quantization; normalized ones map to [-1, 1] or [0, 1]).
pub(super) fn component_to_f32(b: &[u8], t: DataType, normalized: bool) -> f32 {
    match t {
        DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        DataType::I8 => {
            let v = b[0] as i8 as f32;
            if normalized { (v / 127.0).max(-1.0) } else { v }
        }
        DataType::U8 => {
            let v = b[0] as f32;
            if normalized { v / 255.0 } else { v }
        }
        DataType::I16 => {
            let v = i16::from_le_bytes([b[0], b[1]]) as f32;
            if normalized {
                (v / 32767.0).max(-1.0)
            } else {
                v
            }
        }
        DataType::U16 => {
            let v = u16::from_le_bytes([b[0], b[1]]) as f32;
            if normalized { v / 65535.0 } else { v }
        }
        DataType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
    }
}

/// Decodes the part of a `data:` URI after the scheme; only base64 payloads
/// carry binary buffers.
fn decode_data_uri(rest: &str) -> std::result::Result<Vec<u8>, String> {
    let Some((meta, payload)) = rest.split_once(',') else {
        return Err("data URI has no ',' before its payload".into());
    };
    if !meta.ends_with(";base64") {
        return Err("data URI is not base64-encoded".into());
    }
    base64::engine::general_purpose::STANDARD
        .decode(payload.trim())
        .map_err(|e| format!("data URI is not valid base64: {e}"))
}
