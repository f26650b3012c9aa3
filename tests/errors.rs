//! Bad input gets a typed error, never a panic.

use fast_reject::TemplateSource;
use fast_reject::math::Vec3;
use fast_reject::mesh::io::load;
use fast_reject::mesh::shapes::uv_sphere;
use fast_reject::scene::{Scene, SceneOptions};
use fast_reject::search::{MatchOptions, search};
use fast_reject::{Error, Format, TriMesh};

const OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n";

fn small_files() -> Vec<(Format, Vec<u8>)> {
    let mesh = load(OBJ.as_bytes(), Some(Format::Obj)).unwrap();
    let mut stl = vec![0u8; 80];
    stl.extend_from_slice(&(mesh.triangles().len() as u32).to_le_bytes());
    for t in 0..mesh.triangles().len() {
        stl.extend_from_slice(&[0u8; 12]);
        for p in mesh.corners(t) {
            for c in [p.x, p.y, p.z] {
                stl.extend_from_slice(&(c as f32).to_le_bytes());
            }
        }
        stl.extend_from_slice(&[0, 0]);
    }
    let mut ply = b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
    for p in mesh.positions() {
        for c in p {
            ply.extend_from_slice(&c.to_le_bytes());
        }
    }
    for t in mesh.triangles() {
        ply.push(3);
        for i in t {
            ply.extend_from_slice(&(*i as i32).to_le_bytes());
        }
    }
    let glb = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/demo/template.glb"
    ))
    .unwrap();
    vec![
        (Format::Obj, OBJ.as_bytes().to_vec()),
        (Format::Stl, stl),
        (Format::Ply, ply),
        (Format::Gltf, glb),
    ]
}

#[test]
fn every_format_parses_its_small_file() {
    for (format, bytes) in small_files() {
        let m = load(&bytes, Some(format)).unwrap_or_else(|e| panic!("{format}: {e}"));
        assert!(!m.triangles().is_empty(), "{format}");
        // And is recognized without a hint.
        assert!(load(&bytes, None).is_ok(), "{format} not sniffed");
    }
}

#[test]
fn truncated_files_of_every_format_are_errors() {
    for (format, bytes) in small_files() {
        // OBJ has no length to violate: a prefix can still be a valid mesh.
        if format == Format::Obj {
            continue;
        }
        let step = (bytes.len() / 200).max(1);
        for cut in (0..bytes.len()).step_by(step) {
            let r = load(&bytes[..cut], Some(format));
            assert!(
                r.is_err(),
                "{format}: a prefix of {cut} of {} bytes loaded",
                bytes.len()
            );
        }
    }
}

#[test]
fn garbage_of_every_format_is_an_error() {
    let mut state: u64 = 1;
    let garbage: Vec<u8> = (0..4096)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state as u8
        })
        .collect();
    for format in [Format::Gltf, Format::Obj, Format::Ply, Format::Stl] {
        assert!(
            load(&garbage, Some(format)).is_err(),
            "{format} accepted garbage"
        );
    }
    assert!(matches!(
        load(&garbage, None),
        Err(Error::UnknownFormat { .. })
    ));
}

#[test]
fn corrupted_bytes_never_panic() {
    // Flip bytes all over real files of every format: errors are fine, panics are not.
    let mut state: u64 = 42;
    for (format, bytes) in small_files() {
        for round in 0..300 {
            let mut b = bytes.clone();
            for _ in 0..1 + round % 8 {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let i = (state as usize) % b.len();
                b[i] = (state >> 32) as u8;
            }
            let _ = load(&b, Some(format));
        }
    }
}

#[test]
fn an_empty_mesh_is_an_error() {
    assert!(matches!(
        load(b"v 0 0 0\nv 1 0 0\n", Some(Format::Obj)),
        Err(Error::EmptyMesh { .. })
    ));
    let glb_without_triangles = br#"{"asset":{"version":"2.0"},"scenes":[{"nodes":[]}],"scene":0}"#;
    assert!(matches!(
        load(glb_without_triangles, Some(Format::Gltf)),
        Err(Error::EmptyMesh { .. })
    ));
}

#[test]
fn nan_and_infinite_coordinates_are_errors() {
    for bad in ["nan", "inf", "-inf"] {
        let obj = OBJ.replacen("v 1 0 0", &format!("v 1 {bad} 0"), 1);
        let e = load(obj.as_bytes(), Some(Format::Obj)).unwrap_err();
        assert!(
            matches!(e, Error::NonFiniteCoordinate { vertex: 1, .. }),
            "{bad}: {e}"
        );
    }
}

#[test]
fn degenerate_triangles_are_ignored() {
    let obj = format!("{OBJ}f 1 1 2\nv 2 0 0\nf 1 2 5\n");
    let m = load(obj.as_bytes(), Some(Format::Obj)).unwrap();
    assert_eq!(m.triangles().len(), 4);
    assert_eq!(m.degenerate_dropped(), 2);
}

fn sphere_scene() -> Scene {
    Scene::new(
        uv_sphere(Vec3::ZERO, 1.0, 32, 64),
        &SceneOptions::DEFAULT.with_resolution(64),
    )
    .unwrap()
}

#[test]
fn a_selection_sphere_that_touches_no_surface_is_an_error() {
    let scene = sphere_scene();
    let far = TemplateSource::Selection {
        center: [5.0, 0.0, 0.0],
        radius: 0.5,
    };
    let e = search(&scene, &far, &MatchOptions::DEFAULT, &mut ()).unwrap_err();
    assert!(matches!(e, Error::SelectionMissesScene { .. }), "{e}");
    // Inside the solid but away from the surface: it touches nothing either.
    let inside = TemplateSource::Selection {
        center: [0.0, 0.0, 0.0],
        radius: 0.5,
    };
    assert!(matches!(
        search(&scene, &inside, &MatchOptions::DEFAULT, &mut ()),
        Err(Error::SelectionMissesScene { .. })
    ));
    for bad in [
        [f64::NAN, 0.0, 0.0, 0.5],
        [1.0, 0.0, 0.0, -1.0],
        [1.0, 0.0, 0.0, f64::INFINITY],
    ] {
        let s = TemplateSource::Selection {
            center: [bad[0], bad[1], bad[2]],
            radius: bad[3],
        };
        assert!(matches!(
            search(&scene, &s, &MatchOptions::DEFAULT, &mut ()),
            Err(Error::InvalidOption { .. })
        ));
    }
    // The curvature search checks the sphere the same way.
    let mut curvature = MatchOptions::DEFAULT;
    curvature.descriptor = fast_reject::search::DescriptorKind::Curvature;
    let e = search(&scene, &far, &curvature, &mut ()).unwrap_err();
    assert!(matches!(e, Error::SelectionMissesScene { .. }), "{e}");
    for spacing in [-0.5, f64::NAN, f64::INFINITY] {
        let mut bad = curvature;
        bad.curvature_spacing = spacing;
        let e = search(&scene, &inside, &bad, &mut ()).unwrap_err();
        assert!(e.to_string().contains("curvature spacing"), "{e}");
    }
    curvature.curvature_threshold = f64::NAN;
    let e = search(&scene, &inside, &curvature, &mut ()).unwrap_err();
    assert!(matches!(e, Error::InvalidOption { .. }), "{e}");
}

#[test]
fn a_grid_beyond_the_memory_budget_is_an_error() {
    let mesh = uv_sphere(Vec3::ZERO, 1.0, 16, 32);
    // The voxelizer's work limit (tests/hostile.rs) would refuse 16384 first.
    let options = SceneOptions::DEFAULT.with_max_voxel_work(f64::INFINITY);
    let e = Scene::new(mesh.clone(), &options.with_resolution(16384)).unwrap_err();
    assert!(matches!(e, Error::OverBudget { .. }), "{e}");
    assert!(
        e.to_string().contains("lower the resolution to at most"),
        "{e}"
    );
    // The resolution the message names fits.
    let fits: u32 = e
        .to_string()
        .split("at most ")
        .nth(1)
        .unwrap()
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(fits > 512, "{e}");
    assert!(Scene::new(mesh.clone(), &SceneOptions::DEFAULT.with_resolution(fits)).is_ok());
    assert!(
        Scene::new(
            mesh.clone(),
            &SceneOptions::DEFAULT.with_resolution(fits + 1)
        )
        .is_err()
    );
    let e = Scene::new(
        mesh.clone(),
        &SceneOptions::DEFAULT.with_memory_budget(1 << 10),
    )
    .unwrap_err();
    assert!(matches!(e, Error::OverBudget { .. }), "{e}");
    assert!(e.to_string().contains("passes the budget alone"), "{e}");
    assert!(matches!(
        Scene::new(mesh, &SceneOptions::DEFAULT.with_resolution(20_000)),
        Err(Error::InvalidOption { .. })
    ));
}

#[test]
fn a_template_too_small_for_the_voxels_is_an_error() {
    let scene = sphere_scene();
    let tiny = TemplateSource::Selection {
        center: [1.0, 0.0, 0.0],
        radius: 0.05,
    };
    // At the scene's own resolution it is too small...
    let mut fixed = MatchOptions::DEFAULT;
    fixed.template_voxels = 0.0;
    assert!(matches!(
        search(&scene, &tiny, &fixed, &mut ()),
        Err(Error::TemplateTooSmall { .. })
    ));
    // ...and by default the grid is refined for it to the 32 voxels per
    // radius asked for, although the sphere's whole grid would take 1283^3
    // voxels: it is searched in windows.
    let lattice = scene
        .lattice_for(0.05, MatchOptions::DEFAULT.template_voxels)
        .unwrap();
    assert!(lattice.resolution > scene.resolution(), "{lattice:?}");
    assert!(
        (0.05 / lattice.spec.voxel_size - 32.0).abs() < 0.5,
        "{lattice:?}"
    );
    let small = scene
        .lattice_for(0.5, MatchOptions::DEFAULT.template_voxels)
        .unwrap();
    assert!(
        (0.5 / small.spec.voxel_size - 32.0).abs() < 0.5,
        "{small:?}"
    );
}

#[test]
fn invalid_options_are_errors() {
    let scene = sphere_scene();
    let sel = TemplateSource::Selection {
        center: [1.0, 0.0, 0.0],
        radius: 0.8,
    };
    let mut o = MatchOptions::DEFAULT;
    o.harmonics_threshold = f64::NAN;
    assert!(matches!(
        search(&scene, &sel, &o, &mut ()),
        Err(Error::InvalidOption { .. })
    ));
    let mut o = MatchOptions::DEFAULT;
    o.layers = 0;
    assert!(matches!(
        search(&scene, &sel, &o, &mut ()),
        Err(Error::InvalidOption { .. })
    ));
    let mut o = MatchOptions::DEFAULT;
    o.verify_threshold = 1.5;
    assert!(matches!(
        search(&scene, &sel, &o, &mut ()),
        Err(Error::InvalidOption { .. })
    ));
}

#[test]
fn cancelling_stops_the_search() {
    let scene = sphere_scene();
    let sel = TemplateSource::Selection {
        center: [1.0, 0.0, 0.0],
        radius: 0.8,
    };
    let mut layers_seen = 0;
    let mut stop_after_two = |_: &fast_reject::LayerStats| {
        layers_seen += 1;
        if layers_seen == 2 {
            std::ops::ControlFlow::Break(())
        } else {
            std::ops::ControlFlow::Continue(())
        }
    };
    let e = search(&scene, &sel, &MatchOptions::DEFAULT, &mut stop_after_two).unwrap_err();
    assert!(matches!(e, Error::Cancelled));
    assert_eq!(layers_seen, 2);
}

#[test]
fn cancelling_stops_a_search_of_parts_side_by_side() {
    // The demo scene's parts are searched side by side on the threads; their
    // layers reach the observer after each wave, and a break there ends the
    // search with the same typed error.
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/demo");
    let read = |name: &str| load(&std::fs::read(format!("{dir}/{name}")).unwrap(), None).unwrap();
    let scene = Scene::new(read("scene.glb"), &SceneOptions::DEFAULT).unwrap();
    let template = TemplateSource::Model(read("template.glb"));
    let mut layers = Vec::new();
    let mut record = |s: &fast_reject::LayerStats| {
        layers.push((s.descriptor, s.layer, s.candidates, s.survivors));
        std::ops::ControlFlow::Continue(())
    };
    let report = search(&scene, &template, &MatchOptions::DEFAULT, &mut record).unwrap();
    assert!(!report.instances.is_empty());
    // Every part's layers are reported: together they are the report's.
    for s in &report.stages {
        let (candidates, survivors) = layers
            .iter()
            .filter(|l| (l.0, l.1) == (s.descriptor, s.layer))
            .fold((0, 0), |(c, v), l| (c + l.2, v + l.3));
        assert_eq!(
            (candidates, survivors),
            (s.candidates, s.survivors),
            "{s:?}"
        );
    }
    assert!(
        layers.len() > report.stages.len(),
        "one part only: {layers:?}"
    );
    let mut seen = 0;
    let mut stop_at_first = |_: &fast_reject::LayerStats| {
        seen += 1;
        std::ops::ControlFlow::Break(())
    };
    let e = search(
        &scene,
        &template,
        &MatchOptions::DEFAULT,
        &mut stop_at_first,
    )
    .unwrap_err();
    assert!(matches!(e, Error::Cancelled), "{e}");
    assert_eq!(seen, 1);
}

#[test]
fn a_template_of_slivers_that_fill_no_voxel_is_an_error() {
    // One triangle 7e31 long and 1 wide: under voxels of 1.8e30 its corners
    // round onto one line, and it marks no voxel (found by the fuzzer).
    let mesh = TriMesh::new(
        vec![
            [0.0, 0.0, 3.851_86e-34],
            [0.0, 1.0, 7.144_028e31],
            [0.970_359, 1.0, 0.0],
        ],
        vec![[0, 1, 2]],
    )
    .unwrap();
    let scene = Scene::new(mesh, &SceneOptions::DEFAULT.with_resolution(20)).unwrap();
    let selection = TemplateSource::Selection {
        center: [0.0, 0.0, 0.0],
        radius: 5.746e31,
    };
    let e = search(&scene, &selection, &MatchOptions::DEFAULT, &mut ()).unwrap_err();
    assert!(matches!(e, Error::NothingVoxelized { .. }), "{e}");
}
