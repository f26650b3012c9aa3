//! Placeholder: being written.

use super::ResourceResolver;
use crate::error::{Error, Format, Result};
use crate::mesh::TriMesh;

pub(super) fn parse(_bytes: &[u8], _resources: &dyn ResourceResolver) -> Result<TriMesh> {
    Err(Error::malformed(Format::Gltf, "start", "not implemented yet"))
}
