//! `EXT_mesh_gpu_instancing`: a node that places its mesh many times, each
//! instance by a translation, a rotation and a scale read from accessors.
//! Read so that every instance is a placement, as if each were a node: a
//! file this crate writes with `--gpu-instancing` reads back whole.

use std::collections::HashMap;

use gltf::accessor::Dimensions;
use gltf::json::Value;

use super::accessor::component_to_f32;
use super::{Loader, Mat4, mul};
use crate::error::{Error, Format, Result};

pub(super) const INSTANCING: &str = "EXT_mesh_gpu_instancing";

impl Loader<'_> {
    /// Each instanced node's instances, as local transforms (the node's
    /// own applied after them), where the file uses the extension.
    pub(super) fn read_instancing(
        &mut self,
        gltf: &gltf::Gltf,
        bytes: &[u8],
    ) -> Result<HashMap<usize, Instances>> {
        let mut out = HashMap::new();
        if !gltf.extensions_used().any(|e| e == INSTANCING) {
            return Ok(out);
        }
        let json: std::borrow::Cow<[u8]> = match gltf::binary::Glb::from_slice(bytes) {
            Ok(glb) => glb.json,
            Err(_) => bytes.into(),
        };
        let root: Value = gltf::json::deserialize::from_slice(&json)
            .map_err(|e| Error::malformed(Format::Gltf, "document", e.to_string()))?;
        let Some(nodes) = root.get("nodes").and_then(Value::as_array) else {
            return Ok(out);
        };
        for (n, node) in nodes.iter().enumerate() {
            let Some(attributes) = node.pointer(&format!("/extensions/{INSTANCING}/attributes"))
            else {
                continue;
            };
            let at = format!("node {n} {INSTANCING}");
            let mut columns: [Option<Vec<f32>>; 3] = [None, None, None];
            for (k, (name, width)) in [("TRANSLATION", 3), ("ROTATION", 4), ("SCALE", 3)]
                .into_iter()
                .enumerate()
            {
                if let Some(index) = attributes.get(name) {
                    columns[k] = Some(self.instance_values(gltf, index, width, &at)?);
                }
            }
            let counts: Vec<usize> = [(0, 3), (1, 4), (2, 3)]
                .iter()
                .filter_map(|&(k, w)| columns[k].as_ref().map(|c| c.len() / w))
                .collect();
            let Some(&count) = counts.first() else {
                continue;
            };
            if counts.iter().any(|&c| c != count) {
                return Err(Error::malformed(
                    Format::Gltf,
                    at,
                    "its attributes have different counts of instances",
                ));
            }
            let instances = Instances { columns, count };
            out.insert(n, instances);
        }
        Ok(out)
    }

    /// The floats of accessor `index`, `width` a value, checked.
    fn instance_values(
        &mut self,
        gltf: &gltf::Gltf,
        index: &Value,
        width: usize,
        at: &str,
    ) -> Result<Vec<f32>> {
        let accessor = index
            .as_u64()
            .and_then(|i| gltf.accessors().nth(i as usize))
            .ok_or_else(|| Error::malformed(Format::Gltf, at, "an attribute names no accessor"))?;
        let dimensions = match width {
            3 => Dimensions::Vec3,
            _ => Dimensions::Vec4,
        };
        if accessor.dimensions() != dimensions {
            return Err(Error::malformed(
                Format::Gltf,
                at,
                format!("accessor {} is not a VEC{width}", accessor.index()),
            ));
        }
        let (kind, normalized) = (accessor.data_type(), accessor.normalized());
        let values: Vec<f32> = self
            .read_elements(&accessor, at)?
            .chunks_exact(kind.size())
            .map(|c| component_to_f32(c, kind, normalized))
            .collect();
        if values.iter().any(|v| !v.is_finite()) {
            return Err(Error::malformed(
                Format::Gltf,
                at,
                "an instance's transform is not finite",
            ));
        }
        Ok(values)
    }
}

/// A node's instances as the file stores them: translations, rotations
/// and scales, each column optional; the matrices are made one by one, as
/// the loader's size limit lets them be placed.
pub(super) struct Instances {
    columns: [Option<Vec<f32>>; 3],
    pub(super) count: usize,
}

impl Instances {
    /// Instance `i`'s transform, relative to its node.
    pub(super) fn matrix(&self, i: usize) -> Mat4 {
        let value = |k: usize, width: usize, or: [f32; 4]| -> [f64; 4] {
            let mut v = or.map(f64::from);
            if let Some(c) = &self.columns[k] {
                for (j, x) in c[i * width..][..width].iter().enumerate() {
                    v[j] = f64::from(*x);
                }
            }
            v
        };
        let t = value(0, 3, [0.0; 4]);
        let r = value(1, 4, [0.0, 0.0, 0.0, 1.0]);
        let s = value(2, 3, [1.0; 4]);
        trs_matrix(t, r, s)
    }
}

/// The column-major matrix T R S of a translation, a quaternion (x, y, z,
/// w; normalised here) and a scale.
fn trs_matrix(t: [f64; 4], r: [f64; 4], s: [f64; 4]) -> Mat4 {
    let n = r.iter().map(|x| x * x).sum::<f64>().sqrt();
    let [x, y, z, w] = match n > 0.0 {
        true => r.map(|v| v / n),
        false => [0.0, 0.0, 0.0, 1.0],
    };
    let rotation = [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y + z * w),
            2.0 * (x * z - y * w),
            0.0,
        ],
        [
            2.0 * (x * y - z * w),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z + x * w),
            0.0,
        ],
        [
            2.0 * (x * z + y * w),
            2.0 * (y * z - x * w),
            1.0 - 2.0 * (x * x + y * y),
            0.0,
        ],
        [t[0], t[1], t[2], 1.0],
    ];
    let scale: Mat4 = std::array::from_fn(|c| {
        std::array::from_fn(|r| match (r == c, c) {
            (true, 3) => 1.0,
            (true, _) => s[c],
            _ => 0.0,
        })
    });
    mul(&rotation, &scale)
}
