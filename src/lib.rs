//! fast-reject: find every occurrence of a template shape in a 3D scene.

pub mod error;
pub mod math;
pub mod mesh;

pub use error::{Error, Format, Result};
pub mod exec;
pub mod voxel;
