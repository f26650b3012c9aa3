//! fast-reject: find every occurrence of a template shape in a 3D scene.

pub mod cascade;
pub mod clock;
pub mod descriptor;
pub mod error;
pub mod exec;
pub mod instances;
pub mod math;
pub mod mesh;
pub mod scene;
pub mod search;
pub mod template;
pub mod voxel;

pub use error::{Error, Format, Result};
