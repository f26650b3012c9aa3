//! Placeholder: being written.

use crate::error::{Error, Format, Result};
use crate::mesh::TriMesh;

pub(super) fn parse(_bytes: &[u8]) -> Result<TriMesh> {
    Err(Error::malformed(Format::Obj, "start", "not implemented yet"))
}
