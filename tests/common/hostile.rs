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
    stl(&tetrahedron_faces(scale))
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

/// Case 16: a cylinder of radius 1 and height 2 whose side is `segments`
/// slivers two units long and whose caps are fans of `segments` slivers
/// about their centres: every vertex's ball holds thousands of triangles,
/// and the curvature descriptor's work grows with the square of
/// `segments`.
pub fn fanned_cylinder(segments: usize) -> Vec<u8> {
    let ring = |z: f32| -> Vec<[f32; 3]> {
        (0..segments)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / segments as f64;
                [a.cos() as f32, a.sin() as f32, z]
            })
            .collect()
    };
    let (bottom, top) = (ring(0.0), ring(2.0));
    let mut triangles = Vec::with_capacity(4 * segments);
    for i in 0..segments {
        let j = (i + 1) % segments;
        triangles.push([bottom[i], bottom[j], top[j]]);
        triangles.push([bottom[i], top[j], top[i]]);
        triangles.push([[0.0, 0.0, 2.0], top[i], top[j]]);
        triangles.push([[0.0, 0.0, 0.0], bottom[j], bottom[i]]);
    }
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

// Round two.

/// A binary STL of `triangles` whose free-text header starts with `header`.
pub fn stl_with_header(header: &[u8], triangles: &[[[f32; 3]; 3]]) -> Vec<u8> {
    let mut out = stl(triangles);
    out[..header.len()].copy_from_slice(header);
    out
}

/// The four faces of the unit tetrahedron [`tetrahedron`] writes.
pub fn tetrahedron_faces(scale: f32) -> [[[f32; 3]; 3]; 4] {
    let [o, x, y, z] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0f32],
    ]
    .map(|p| p.map(|c| c * scale));
    [[o, y, x], [o, x, z], [o, z, y], [x, y, z]]
}

/// A binary PLY of 256 one-byte vertices and `faces` faces of 255 one-byte
/// corners: each 256-byte face is 253 triangles, twelve times its bytes.
pub fn ply_of_wide_faces(faces: usize) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex 256\n\
         property uchar x\nproperty uchar y\nproperty uchar z\n\
         element face {faces}\nproperty list uchar uchar vertex_indices\nend_header\n"
    )
    .into_bytes();
    for i in 0..=255u8 {
        out.extend_from_slice(&[i % 7, i / 7 % 7, i / 49]);
    }
    let mut face = vec![255u8];
    face.extend(0..255u8);
    out.reserve(faces * face.len());
    for _ in 0..faces {
        out.extend_from_slice(&face);
    }
    out
}

/// An axis-aligned cube of side `size` centred at the origin, 12 triangles.
pub fn cube(size: f32) -> Vec<u8> {
    let h = size / 2.0;
    let v = |i: usize| [i & 1, (i >> 1) & 1, (i >> 2) & 1].map(|b| if b == 1 { h } else { -h });
    let faces = [
        [0, 2, 1],
        [1, 2, 3],
        [4, 5, 6],
        [5, 7, 6],
        [0, 1, 4],
        [1, 5, 4],
        [2, 6, 3],
        [3, 6, 7],
        [0, 4, 2],
        [2, 4, 6],
        [1, 3, 5],
        [3, 7, 5],
    ];
    stl(&faces.map(|f| f.map(v)))
}

/// `n` x `n` separate unit squares on the floor, 0.5 apart.
pub fn flat_tiles(n: usize) -> Vec<u8> {
    let mut triangles = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (x, y) = (i as f32 * 1.5, j as f32 * 1.5);
            let [a, b, c, d] =
                [[x, y], [x + 1.0, y], [x + 1.0, y + 1.0], [x, y + 1.0]].map(|[x, y]| [x, y, 0.0]);
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    stl(&triangles)
}

/// A glTF of the unit tetrahedron scaled by 100 with `KHR_mesh_quantization`
/// required: positions as 16-bit integers (normalized to [-1, 1] when
/// `normalized`, with the node scaling them back), `extras` on the root,
/// the node and the mesh.
pub fn quantized_tetrahedron(normalized: bool, extras: &str) -> String {
    let q: i16 = if normalized { 32767 } else { 100 };
    let mut bytes = Vec::new();
    for p in [[0, 0, 0], [q, 0, 0], [0, q, 0], [0, 0, q]] {
        for c in p {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
        bytes.extend_from_slice(&[0, 0]);
    }
    bytes.extend_from_slice(&[0u8, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3]);
    let scale = if normalized { 100.0 } else { 1.0 };
    format!(
        r#"{{"asset":{{"version":"2.0"}},"extras":{extras},
        "extensionsUsed":["KHR_mesh_quantization"],"extensionsRequired":["KHR_mesh_quantization"],
        "scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0,"scale":[{scale},{scale},{scale}],"extras":{extras}}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}],"extras":{extras}}}],
        "buffers":[{{"byteLength":44,"uri":"{}"}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":32,"byteStride":8}},{{"buffer":0,"byteOffset":32,"byteLength":12}}],
        "accessors":[{{"bufferView":0,"componentType":5122,"normalized":{normalized},"count":4,"type":"VEC3","min":[0,0,0],"max":[{q},{q},{q}]}},
                     {{"bufferView":1,"componentType":5121,"count":12,"type":"SCALAR"}}]}}"#,
        data_uri(&bytes)
    )
}

/// `buffers` glTF buffers that all name `uri`, each `byte_length` long, and
/// a triangle read from the first.
pub fn gltf_with_buffers_naming_one_file(uri: &str, buffers: usize, byte_length: u64) -> String {
    let list = vec![format!(r#"{{"byteLength":{byte_length},"uri":"{uri}"}}"#); buffers].join(",");
    let views: Vec<String> = (0..buffers)
        .map(|b| format!(r#"{{"buffer":{b},"byteOffset":0,"byteLength":36}}"#))
        .collect();
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{prims}]}}],
        "buffers":[{list}],"bufferViews":[{views}],
        "accessors":[{accessors}]}}"#,
        prims = (0..buffers)
            .map(|b| format!(r#"{{"attributes":{{"POSITION":{b}}}}}"#))
            .collect::<Vec<_>>()
            .join(","),
        views = views.join(","),
        accessors = (0..buffers)
            .map(|b| format!(
                r#"{{"bufferView":{b},"componentType":5126,"count":3,"type":"VEC3"}}"#
            ))
            .collect::<Vec<_>>()
            .join(","),
    )
}

/// Text that would take over a terminal if printed raw: clear the screen,
/// home the cursor, print a false verdict, and set the clipboard (OSC 52).
pub const TERMINAL_ATTACK: &str =
    "\u{1b}[2J\u{1b}[Hall good: 3 instances found\u{1b}]52;c;ZWNobyBwd25lZA==\u{7}";

/// A right tetrahedron with legs `legs` along x, y and z from `at`.
pub fn right_tetrahedron(legs: [f32; 3], at: [f32; 3]) -> Vec<[[f32; 3]; 3]> {
    let [x, y, z] = at;
    let v = [
        [x, y, z],
        [x + legs[0], y, z],
        [x, y + legs[1], z],
        [x, y, z + legs[2]],
    ];
    [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]
        .map(|t: [usize; 3]| t.map(|i| v[i]))
        .to_vec()
}

/// Case 17: `count` right tetrahedra on a lattice, each apart, with legs
/// of 0.5 times 1 +- 0.25 drawn from `seed`: as many distinct near twins
/// of a tetrahedron as there are parts.
pub fn jittered_tetrahedra(count: usize, seed: u64) -> Vec<u8> {
    let mut state = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let mut draw = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let side = (count as f64).cbrt().ceil() as usize;
    let mut triangles = Vec::with_capacity(4 * count);
    for i in 0..count {
        let at = [i % side, i / side % side, i / side / side].map(|k| k as f32);
        let legs = [0; 3].map(|_| 0.5 * (1.0 + 0.25 * (2.0 * draw() - 1.0)));
        triangles.extend(right_tetrahedron(legs, at));
    }
    stl(&triangles)
}

/// A box 1 by 0.6 by 0.3 (8 corners, 12 triangles facing out), then three
/// instance translations and rotations, in one buffer: the bytes of
/// [`placed_boxes`].
fn box_and_instances() -> (Vec<u8>, [usize; 4]) {
    let mut b = Vec::new();
    for k in 0..8 {
        for (axis, size) in [1.0f32, 0.6, 0.3].into_iter().enumerate() {
            let v = if k >> axis & 1 == 1 { size } else { 0.0 };
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    let positions = b.len();
    // Two triangles a face, counter-clockwise seen from outside.
    let faces: [[u16; 4]; 6] = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    for [a, b2, c, d] in faces {
        for i in [a, b2, c, a, c, d] {
            b.extend_from_slice(&i.to_le_bytes());
        }
    }
    let indices = b.len();
    for x in [0.0f32, 3.0, 0.0, 0.0, 6.0, 1.0, 0.0, 0.0, 9.0] {
        b.extend_from_slice(&x.to_le_bytes());
    }
    let translations = b.len();
    use std::f32::consts::FRAC_1_SQRT_2;
    for q in [
        0.0f32,
        0.0,
        0.0,
        1.0,
        0.0,
        0.0,
        FRAC_1_SQRT_2,
        FRAC_1_SQRT_2,
        0.5,
        0.5,
        0.5,
        0.5,
    ] {
        b.extend_from_slice(&q.to_le_bytes());
    }
    (b, [positions, indices, translations, 0])
}

/// The box of [`box_and_instances`] placed by `nodes` (JSON objects; mesh
/// 0 is the box, accessors 2 and 3 three instances' translations and
/// rotations), the scene's roots `roots`.
pub fn placed_boxes(nodes: &str, roots: &str, extensions: &str) -> String {
    let (bytes, [positions, indices, translations, _]) = box_and_instances();
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[{roots}]}}],"nodes":[{nodes}],{extensions}
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
        "buffers":[{{"byteLength":{},"uri":"{}"}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{positions}}},
          {{"buffer":0,"byteOffset":{positions},"byteLength":{}}},
          {{"buffer":0,"byteOffset":{indices},"byteLength":{}}},
          {{"buffer":0,"byteOffset":{translations},"byteLength":{}}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":8,"type":"VEC3","min":[0,0,0],"max":[1,0.6,0.3]}},
          {{"bufferView":1,"componentType":5123,"count":36,"type":"SCALAR"}},
          {{"bufferView":2,"componentType":5126,"count":3,"type":"VEC3"}},
          {{"bufferView":3,"componentType":5126,"count":3,"type":"VEC4"}}]}}"#,
        bytes.len(),
        data_uri(&bytes),
        indices - positions,
        translations - indices,
        bytes.len() - translations,
    )
}

/// Issue 86's invalid output: boxes placed three times plainly, once
/// scaled to nothing (hidden), once flattened, and once under a parent
/// with a non-uniform scale over a turned child (a shear).
pub fn hidden_flat_and_sheared_boxes() -> String {
    placed_boxes(
        r#"{"mesh":0},{"mesh":0,"translation":[3,0,0],"rotation":[0,0,0.7071068,0.7071068]},
        {"mesh":0,"translation":[6,0,0],"rotation":[0.5,0.5,0.5,0.5]},
        {"mesh":0,"translation":[9,0,0],"scale":[0,0,0]},
        {"mesh":0,"translation":[12,0,0],"scale":[1,1,0],"rotation":[0.5,0.5,0.5,0.5]},
        {"translation":[15,0,0],"scale":[2,1,1],"children":[6]},
        {"mesh":0,"rotation":[0,0,0.247404,0.968912]}"#,
        "0,1,2,3,4,5",
        "",
    )
}

/// The box placed three times by one node with `EXT_mesh_gpu_instancing`.
pub fn gpu_instanced_boxes() -> String {
    placed_boxes(
        r#"{"mesh":0,"extensions":{"EXT_mesh_gpu_instancing":{"attributes":{"TRANSLATION":2,"ROTATION":3}}}}"#,
        "0",
        r#""extensionsUsed":["EXT_mesh_gpu_instancing"],"extensionsRequired":["EXT_mesh_gpu_instancing"],"#,
    )
}
