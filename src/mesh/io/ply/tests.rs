use super::*;

fn parse(bytes: &[u8]) -> Result<TriMesh> {
    super::parse(bytes, SizeLimit::new(u64::MAX))
}

#[derive(Clone, Copy, PartialEq)]
enum Out {
    Ascii,
    Little,
    Big,
}

/// A value as a test file stores it.
fn put(buf: &mut Vec<u8>, out: Out, ty: Scalar, v: f64) {
    macro_rules! bytes {
        ($t:ty) => {
            match out {
                Out::Big => buf.extend_from_slice(&(v as $t).to_be_bytes()),
                _ => buf.extend_from_slice(&(v as $t).to_le_bytes()),
            }
        };
    }
    if out == Out::Ascii {
        if !buf.is_empty() && !buf.ends_with(b"\n") {
            buf.push(b' ');
        }
        buf.extend_from_slice(v.to_string().as_bytes());
        return;
    }
    match ty {
        Scalar::I8 => bytes!(i8),
        Scalar::U8 => bytes!(u8),
        Scalar::I16 => bytes!(i16),
        Scalar::U16 => bytes!(u16),
        Scalar::I32 => bytes!(i32),
        Scalar::U32 => bytes!(u32),
        Scalar::F32 => bytes!(f32),
        Scalar::F64 => bytes!(f64),
    }
}

fn end_record(buf: &mut Vec<u8>, out: Out) {
    if out == Out::Ascii {
        buf.push(b'\n');
    }
}

/// A file with a camera element before the vertices, normals and colours
/// (and optionally a list) on the vertices, extra lists on the faces and an
/// edge element at the end: everything the loader must skip.
fn sample(out: Out, vertex_list: bool) -> Vec<u8> {
    use Scalar::*;
    let format = match out {
        Out::Ascii => "ascii",
        Out::Little => "binary_little_endian",
        Out::Big => "binary_big_endian",
    };
    let mut header = format!(
        "ply\nformat {format} 1.0\ncomment made by hand\nobj_info test\n\
         element camera 1\nproperty float view_px\nproperty float64 view_py\n\
         element vertex 5\nproperty float x\nproperty int16 y\nproperty double z\n\
         property float nx\nproperty float ny\nproperty float nz\n\
         property uchar red\nproperty uchar green\nproperty uint8 blue\n"
    );
    if vertex_list {
        header += "property list uchar float extra\n";
    }
    header += "element face 4\nproperty uchar flags\n\
         property list uchar int vertex_indices\nproperty list ushort float texcoord\n\
         element edge 2\nproperty int vertex1\nproperty int32 vertex2\nproperty char crease\n\
         end_header\n";
    let mut data = Vec::new();
    put(&mut data, out, F32, 1.5);
    put(&mut data, out, F64, -2.0);
    end_record(&mut data, out);
    let vertices = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.5, 0.0, 1.25],
    ];
    for (i, v) in vertices.iter().enumerate() {
        put(&mut data, out, F32, v[0]);
        put(&mut data, out, I16, v[1]);
        put(&mut data, out, F64, v[2]);
        for n in [0.0, 0.0, 1.0] {
            put(&mut data, out, F32, n);
        }
        for c in [255.0, 128.0, 0.0] {
            put(&mut data, out, U8, c);
        }
        if vertex_list {
            put(&mut data, out, U8, i as f64);
            for k in 0..i {
                put(&mut data, out, F32, k as f64 * 0.25);
            }
        }
        end_record(&mut data, out);
    }
    let faces: [&[f64]; 4] = [
        &[0.0, 1.0, 2.0, 3.0],
        &[0.0, 1.0, 4.0],
        &[0.0, 1.0],
        &[1.0, 2.0, 4.0],
    ];
    for (i, face) in faces.iter().enumerate() {
        put(&mut data, out, U8, 7.0);
        put(&mut data, out, U8, face.len() as f64);
        for &c in *face {
            put(&mut data, out, I32, c);
        }
        put(&mut data, out, U16, (2 * i) as f64);
        for k in 0..2 * i {
            put(&mut data, out, F32, k as f64 / 8.0);
        }
        end_record(&mut data, out);
    }
    for edge in [[0.0, 1.0, 1.0], [1.0, 2.0, -1.0]] {
        put(&mut data, out, I32, edge[0]);
        put(&mut data, out, I32, edge[1]);
        put(&mut data, out, I8, edge[2]);
        end_record(&mut data, out);
    }
    let mut file = header.into_bytes();
    file.extend_from_slice(&data);
    file
}

fn check_sample(m: &TriMesh) {
    assert_eq!(
        m.positions(),
        &[
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.0, 1.25]
        ]
    );
    assert_eq!(m.triangles(), &[[0, 1, 2], [0, 2, 3], [0, 1, 4], [1, 2, 4]]);
}

#[test]
fn ascii_and_both_binary_byte_orders() {
    for out in [Out::Ascii, Out::Little, Out::Big] {
        for vertex_list in [false, true] {
            let file = sample(out, vertex_list);
            let m = parse(&file).unwrap_or_else(|e| panic!("{e}"));
            check_sample(&m);
        }
    }
}

fn to_crlf(bytes: &[u8]) -> Vec<u8> {
    bytes
        .iter()
        .flat_map(|&b| {
            if b == b'\n' {
                vec![b'\r', b'\n']
            } else {
                vec![b]
            }
        })
        .collect()
}

#[test]
fn crlf_header_and_ascii_data() {
    let file = sample(Out::Ascii, false);
    check_sample(&parse(&to_crlf(&file)).unwrap());
    let binary = sample(Out::Little, true);
    let split = binary
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let mut crlf = to_crlf(&binary[..split]);
    crlf.extend_from_slice(&binary[split..]);
    check_sample(&parse(&crlf).unwrap());
}

#[test]
fn every_truncation_of_binary_files_is_an_error() {
    for out in [Out::Little, Out::Big] {
        for vertex_list in [false, true] {
            let file = sample(out, vertex_list);
            for len in 0..file.len() {
                assert!(parse(&file[..len]).is_err(), "prefix of {len} bytes parsed");
            }
        }
    }
    let file = sample(Out::Little, false);
    let e = parse(&file[..file.len() - 3]).unwrap_err().to_string();
    assert!(
        e.contains("ends after 1 of 2 declared 'edge' elements (truncated?)"),
        "{e}"
    );
}

#[test]
fn ascii_truncation_says_so() {
    let file = sample(Out::Ascii, false);
    let text = String::from_utf8(file).unwrap();
    let cut = text.find("7 3 0 1 4").unwrap();
    let e = parse(&text.as_bytes()[..cut]).unwrap_err().to_string();
    assert!(e.contains("ends after 1 of 4 declared faces"), "{e}");
}

#[test]
fn corrupted_bytes_never_panic() {
    for out in [Out::Ascii, Out::Little, Out::Big] {
        let file = sample(out, true);
        for i in 0..file.len() {
            for value in [0u8, b' ', b'\n', b'9', 0x80, 0xff] {
                let mut bad = file.clone();
                bad[i] = value;
                let _ = parse(&bad);
            }
        }
    }
}

#[test]
fn garbage_is_an_error() {
    assert!(parse(b"").is_err());
    assert!(parse(b"ply").is_err());
    assert!(parse(b"ply\n").is_err());
    assert!(parse(&[0xde, 0xad, 0xbe, 0xef, 0, 1, 2, 3]).is_err());
    assert!(parse(b"ply\nformat ascii 1.0\nelement vertex 3\n").is_err());
}

fn ascii(body: &str) -> Result<TriMesh> {
    parse(format!("ply\nformat ascii 1.0\n{body}").as_bytes())
}

const TRIANGLE_HEADER: &str = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
     element face 1\nproperty list uchar uint vertex_index\nend_header\n";

#[test]
fn vertex_index_alias_and_blank_lines() {
    let m = ascii(&format!(
        "{TRIANGLE_HEADER}0 0 0\n\n1 0 0\n0 1 0\n3 0 1 2\n\n"
    ))
    .unwrap();
    assert_eq!(m.triangles(), &[[0, 1, 2]]);
}

#[test]
fn out_of_range_indices_are_errors() {
    let e = ascii(&format!("{TRIANGLE_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 13"), "{e}");
    assert!(
        e.contains("face 0 refers to vertex 7 but the file declares only 3 vertices"),
        "{e}"
    );
    let e = ascii(&format!("{TRIANGLE_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("vertex -1"), "{e}");
    let mut file = b"ply\nformat binary_big_endian 1.0\n".to_vec();
    file.extend_from_slice(TRIANGLE_HEADER.as_bytes());
    for v in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
        file.extend_from_slice(&v.to_be_bytes());
    }
    file.push(3);
    for i in [0u32, 3, 1] {
        file.extend_from_slice(&i.to_be_bytes());
    }
    let e = parse(&file).unwrap_err().to_string();
    assert!(e.contains("face 0 refers to vertex 3"), "{e}");
    assert!(e.contains(&format!("byte {}", file.len() - 8)), "{e}");
}

#[test]
fn header_errors_are_specific() {
    let e = ascii("element vertex 3\nproperty float x\nproperty float y\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("no 'z' property"), "{e}");
    let e = ascii(
        "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("no 'face' element"), "{e}");
    let e = ascii("element vertex 0\nproperty float x\nproperty float y\nproperty float z\nelement face 0\nproperty uchar flags\nend_header\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("no 'vertex_indices'"), "{e}");
    let e = ascii("element vertex 3\nproperty real x\nend_header\n")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("unknown property type 'real'") && e.contains("line 4"),
        "{e}"
    );
    let e = parse(b"ply\nformat binary_middle_endian 1.0\nend_header\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("unknown format"), "{e}");
    let e = parse(b"ply\nformat ascii 1.0\nelement vertex 3\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("no 'end_header'"), "{e}");
}

#[test]
fn huge_declared_counts_fail_without_allocating() {
    for format in ["ascii", "binary_little_endian"] {
        let header = format!(
            "ply\nformat {format} 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\n\
             element face 4000000000\nproperty list uint uint vertex_indices\nend_header\n"
        );
        let mut file = header.into_bytes();
        file.extend_from_slice(&b"1 1 1\n".repeat(4));
        let e = parse(&file).unwrap_err().to_string();
        assert!(e.contains("of 4000000000 declared vertices"), "{e}");
    }
    // A face list claiming 4 billion corners.
    let mut file = b"ply\nformat binary_little_endian 1.0\n".to_vec();
    file.extend_from_slice(
        b"element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
          element face 1\nproperty list uint uint vertex_indices\nend_header\n",
    );
    for v in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
        file.extend_from_slice(&v.to_le_bytes());
    }
    file.extend_from_slice(&u32::MAX.to_le_bytes());
    file.extend_from_slice(&[0; 12]);
    let e = parse(&file).unwrap_err().to_string();
    assert!(e.contains("ends after 0 of 1 declared faces"), "{e}");
    let e = ascii("element vertex 5000000000\nproperty float x\nproperty float y\nproperty float z\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("at most 4294967295"), "{e}");
}

#[test]
fn ascii_value_count_must_match_the_header() {
    let e = ascii(&format!("{TRIANGLE_HEADER}0 0 0\n1 0\n0 1 0\n3 0 1 2\n"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("vertex 1 has too few values"), "{e}");
    let e = ascii(&format!(
        "{TRIANGLE_HEADER}0 0 0\n1 0 0 5\n0 1 0\n3 0 1 2\n"
    ))
    .unwrap_err()
    .to_string();
    assert!(e.contains("vertex 1 has more values"), "{e}");
    let e = ascii(&format!(
        "{TRIANGLE_HEADER}0 0 0\n1 0 0\n0 one 0\n3 0 1 2\n"
    ))
    .unwrap_err()
    .to_string();
    assert!(e.contains("'one' is not a number"), "{e}");
}

#[test]
fn an_exported_binary_file_with_normals_and_colours() {
    let m = parse(crate::mesh::io::fixtures::PLY).unwrap();
    assert_eq!(m.positions().len(), crate::mesh::io::fixtures::VERTICES);
    assert_eq!(m.triangles().len(), crate::mesh::io::fixtures::TRIANGLES);
}

#[test]
fn real_file_horse() {
    let m = parse(&crate::shared_bytes("models/horse.ply")).unwrap();
    assert_eq!(m.positions().len(), 48485);
    assert_eq!(m.triangles().len(), 96966);
}
