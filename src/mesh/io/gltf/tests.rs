use super::*;
use crate::mesh::io::{NoResources, load};
use base64::Engine as _;

/// A minimal .gltf with one triangle in an embedded buffer, placed by a
/// translated parent node and a scaled child.
fn tiny_gltf(uri: &str) -> String {
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
        "nodes":[{{"translation":[10,0,0],"children":[1]}},{{"scale":[2,2,2],"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
        "buffers":[{{"byteLength":42,"uri":"{uri}"}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":6}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}},
                     {{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}}]}}"#
    )
}

fn tiny_buffer() -> Vec<u8> {
    let mut b = Vec::new();
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    for i in [0u16, 1, 2] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b
}

fn data_uri() -> String {
    format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(tiny_buffer())
    )
}

#[test]
fn node_transforms_compose() {
    let m = load(tiny_gltf(&data_uri()).as_bytes(), Some(Format::Gltf)).unwrap();
    assert_eq!(
        m.positions(),
        &[[10.0, 0.0, 0.0], [12.0, 0.0, 0.0], [10.0, 2.0, 0.0]]
    );
    assert_eq!(m.triangles(), &[[0, 1, 2]]);
}

#[test]
fn external_buffers_come_from_the_resolver() {
    let doc = tiny_gltf("tri.bin");
    let e = parse(doc.as_bytes(), &NoResources, SizeLimit::new(u64::MAX)).unwrap_err();
    assert!(
        matches!(&e, Error::MissingResource { uri } if uri == "tri.bin"),
        "{e}"
    );
    let resolver = |uri: &str| (uri == "tri.bin").then(tiny_buffer);
    let m = parse(doc.as_bytes(), &resolver, SizeLimit::new(u64::MAX)).unwrap();
    assert_eq!(m.triangles().len(), 1);
    // A short external buffer is reported, not read past.
    let short = |_: &str| Some(tiny_buffer()[..20].to_vec());
    assert!(matches!(
        parse(doc.as_bytes(), &short, SizeLimit::new(u64::MAX)),
        Err(Error::Malformed { .. })
    ));
}

#[test]
fn a_position_accessor_out_of_range_is_an_error_not_a_panic() {
    // Regression: gltf-json 1.4.1 indexes accessors with this value
    // before validating it.
    let doc = tiny_gltf(&data_uri()).replace(r#""POSITION":0"#, r#""POSITION":7"#);
    let e = load(doc.as_bytes(), Some(Format::Gltf)).unwrap_err();
    assert!(e.to_string().contains("accessor 7"), "{e}");
}

#[test]
fn a_node_cycle_is_an_error() {
    let doc = tiny_gltf(&data_uri()).replace(
        r#"{"scale":[2,2,2],"mesh":0}"#,
        r#"{"scale":[2,2,2],"mesh":0,"children":[0]}"#,
    );
    assert!(matches!(
        load(doc.as_bytes(), Some(Format::Gltf)),
        Err(Error::Malformed { .. })
    ));
}

#[test]
fn a_node_with_two_parents_is_an_error() {
    let doc = tiny_gltf(&data_uri()).replace(r#""children":[1]"#, r#""children":[1,1]"#);
    let e = load(doc.as_bytes(), Some(Format::Gltf)).unwrap_err();
    assert!(e.to_string().contains("reached twice"), "{e}");
}

#[test]
fn a_glb_length_below_its_header_is_an_error() {
    // Found by the load_gltf fuzz target (fuzz/regressions).
    for length in [0u32, 11, 1000] {
        let mut glb = b"glTF\x02\0\0\0".to_vec();
        glb.extend_from_slice(&length.to_le_bytes());
        let e = load(&glb, None).unwrap_err();
        assert!(e.to_string().contains("GLB header"), "{e}");
    }
    assert!(load(b"glTF\x02\0", Some(Format::Gltf)).is_err());
}

#[test]
fn strips_and_fans() {
    assert_eq!(
        assemble(Mode::TriangleStrip, &[0, 1, 2, 3]).unwrap(),
        vec![[0, 1, 2], [2, 1, 3]]
    );
    assert_eq!(
        assemble(Mode::TriangleFan, &[0, 1, 2, 3]).unwrap(),
        vec![[0, 1, 2], [0, 2, 3]]
    );
    assert!(assemble(Mode::Triangles, &[0, 1]).is_err());
}

use crate::math::Vec3;
use crate::mesh::io::fixtures;

#[test]
fn every_truncation_of_a_glb_is_an_error() {
    let glb = fixtures::INSTANCES_GLB;
    for cut in 0..glb.len() {
        let r = load(&glb[..cut], None);
        assert!(r.is_err(), "prefix of {cut} bytes parsed");
    }
    assert!(load(glb, None).is_ok());
    // Cut after its header, it says so.
    let message = load(&glb[..glb.len() / 2], None).unwrap_err().to_string();
    assert!(message.contains("truncated"), "{message}");
}

#[test]
fn garbage_inside_a_glb_is_an_error() {
    let mut glb = fixtures::INSTANCES_GLB.to_vec();
    // Break the JSON chunk.
    for b in &mut glb[20..60] {
        *b = b'#';
    }
    assert!(matches!(load(&glb, None), Err(Error::Malformed { .. })));
}

#[test]
fn a_glb_places_its_mesh_once_per_node() {
    let m = load(fixtures::INSTANCES_GLB, None).unwrap();
    assert_eq!(m.triangles().len(), 3 * fixtures::TRIANGLES);
    assert_eq!(m.positions().len(), 3 * fixtures::VERTICES);
    assert_eq!(m.parts().len(), 3);
    assert!(m.parts().iter().all(|p| p.source == m.parts()[0].source));
    // Each instance: (centre, radius, where the mesh's first vertex
    // (-0.526, 0.851, 0) lands).
    let v0 = Vec3::new(-0.525_731_1, 0.850_650_8, 0.0);
    let expected = [
        (
            Vec3::new(6.0, 0.0, 0.0),
            2.0,
            Vec3::new(6.0, 0.0, 0.0) + v0 * 2.0,
        ),
        (
            Vec3::new(-6.0, 0.0, 0.0),
            2.0,
            Vec3::new(-6.0 - 2.0 * v0.y, 2.0 * v0.x, 0.0),
        ),
        (Vec3::ZERO, 1.0, v0),
    ];
    let mut found = [false; 3];
    for part in m.parts() {
        assert_eq!(part.vertex_count as usize, fixtures::VERTICES);
        assert_eq!(part.triangle_count as usize, fixtures::TRIANGLES);
        let vertices = part.first_vertex..part.first_vertex + part.vertex_count;
        let first = m.vertex(part.first_vertex);
        let k = expected
            .iter()
            .position(|&(_, _, at)| first.distance(at) < 1e-5)
            .unwrap_or_else(|| panic!("no instance has its first vertex at {first:?}"));
        let (centre, radius, _) = expected[k];
        for v in vertices {
            let r = m.vertex(v).distance(centre);
            assert!((r - radius).abs() < 1e-5, "instance {k}: vertex {v} at {r}");
        }
        assert!(!found[k], "instance {k} twice");
        found[k] = true;
    }
}

#[test]
fn a_shared_scene_loads_with_its_instances() {
    // A real scene from the benchmark, against its known size.
    let glb = crate::shared_bytes("scenes/zoo-bunny/scene.glb");
    let m = load(&glb, None).unwrap();
    assert_eq!(m.triangles().len() + m.degenerate_dropped(), 334_962);
}
