//! The hostile inputs of the reliability issue, built in code so that each
//! regression test states what its file is. `cargo run --example
//! hostile_files DIR` writes them out (fuzz seeds, the npm package's test).

#![allow(dead_code)]

use base64::Engine as _;

/// A one-triangle glTF whose buffer is at `uri`, declared `byte_length` long.
pub fn gltf_with_buffer(uri: &str, byte_length: u64) -> String {
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
        "nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
        "buffers":[{{"byteLength":{byte_length},"uri":"{uri}"}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":6}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}},
                     {{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}}]}}"#
    )
}

/// The 42 bytes [`gltf_with_buffer`] expects: a right triangle and its indices.
pub fn triangle_buffer() -> Vec<u8> {
    let mut b = Vec::new();
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    for i in [0u16, 1, 2] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b
}

fn data_uri(bytes: &[u8]) -> String {
    format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

/// Case 2: a POSITION accessor with no buffer view and `count` elements,
/// one of them set by a sparse substitution (566 bytes for 10^15).
pub fn sparse_without_view(count: u64) -> String {
    let buffer = data_uri(&triangle_buffer());
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
        "buffers":[{{"byteLength":42,"uri":"{buffer}"}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":6}}],
        "accessors":[{{"componentType":5126,"count":{count},"type":"VEC3",
          "sparse":{{"count":1,"indices":{{"bufferView":1,"componentType":5123}},"values":{{"bufferView":0}}}}}}]}}"#
    )
}

/// Case 3: one mesh, a strip of `strip` triangles over 64 points of a unit
/// cube's surface, placed by `nodes` nodes side by side along x.
pub fn instanced(nodes: usize, strip: usize) -> String {
    let mut bytes = Vec::new();
    for i in 0..64u32 {
        // Points on a sphere of radius 0.4 around (0.5, 0.5, 0.5).
        let (t, p) = (i as f32 * 0.7, i as f32 * 0.37);
        let d = [t.cos() * p.sin(), t.sin() * p.sin(), p.cos()];
        for c in d {
            bytes.extend_from_slice(&(0.5 + 0.4 * c).to_le_bytes());
        }
    }
    let positions = bytes.len();
    for k in 0..strip + 2 {
        bytes.extend_from_slice(&((k * 7 % 64) as u16).to_le_bytes());
    }
    let indices = bytes.len() - positions;
    let node_list: Vec<String> = (0..nodes).map(|i| i.to_string()).collect();
    let node_objects: Vec<String> = (0..nodes)
        .map(|i| format!(r#"{{"mesh":0,"translation":[{},0,0]}}"#, i as f64 * 1.5))
        .collect();
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[{}]}}],"nodes":[{}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"mode":5}}]}}],
        "buffers":[{{"byteLength":{},"uri":"{}"}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{positions}}},{{"buffer":0,"byteOffset":{positions},"byteLength":{indices}}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":64,"type":"VEC3"}},
                     {{"bufferView":1,"componentType":5123,"count":{},"type":"SCALAR"}}]}}"#,
        node_list.join(","),
        node_objects.join(","),
        bytes.len(),
        data_uri(&bytes),
        strip + 2
    )
}

/// A binary STL of `triangles`.
pub fn stl(triangles: &[[[f32; 3]; 3]]) -> Vec<u8> {
    let mut out = vec![0u8; 80];
    out.extend_from_slice(&(triangles.len() as u32).to_le_bytes());
    for t in triangles {
        out.extend_from_slice(&[0u8; 12]);
        for p in t {
            for c in p {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
        out.extend_from_slice(&[0, 0]);
    }
    out
}

/// A unit tetrahedron (corner at the origin) scaled by `scale`.
pub fn tetrahedron(scale: f32) -> Vec<u8> {
    let [o, x, y, z] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0f32],
    ]
    .map(|p| p.map(|c| c * scale));
    stl(&[[o, y, x], [o, x, z], [o, z, y], [x, y, z]])
}

/// Case 6: `n` triangles with random corners in a 200-wide cube.
pub fn random_triangles(n: usize, seed: u64) -> Vec<u8> {
    let mut state = seed | 1;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let triangles: Vec<[[f32; 3]; 3]> = (0..n)
        .map(|_| [0; 3].map(|_| [0; 3].map(|_| (next() * 200.0 - 100.0) as f32)))
        .collect();
    stl(&triangles)
}

/// Case 7: a tiny tetrahedron (1e-6) beside a triangle a million units
/// away: no resolution makes the tetrahedron's voxels fine enough.
pub fn tiny_part_in_a_wide_scene() -> Vec<u8> {
    let t = 1e-6f32;
    stl(&[
        [[0.0, 0.0, 0.0], [0.0, t, 0.0], [t, 0.0, 0.0]],
        [[0.0, 0.0, 0.0], [t, 0.0, 0.0], [0.0, 0.0, t]],
        [[0.0, 0.0, 0.0], [0.0, 0.0, t], [0.0, t, 0.0]],
        [[t, 0.0, 0.0], [0.0, t, 0.0], [0.0, 0.0, t]],
        [[1e6, 0.0, 0.0], [1e6 + 1.0, 0.0, 0.0], [1e6, 1.0, 0.0]],
    ])
}

/// `n` pairs of triangles spanning a 200-wide cube corner to corner: a
/// small file whose surface is hundreds of millions of voxel faces.
pub fn cube_spanning_tents(n: usize) -> Vec<u8> {
    let c = |i: usize| {
        let b = [i & 1, (i >> 1) & 1, (i >> 2) & 1];
        b.map(|v| if v == 1 { 100.0 } else { -100.0f32 })
    };
    let triangles: Vec<[[f32; 3]; 3]> = (0..n)
        .flat_map(|k| {
            let (a, b) = (c(k % 8), c(7 - k % 8));
            let (p, q) = (c((k + 1) % 8), c((k + 3) % 8));
            [[a, b, p], [b, a, q]]
        })
        .collect();
    stl(&triangles)
}
