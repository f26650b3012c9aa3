//! The curvature descriptor on the shared scenes, with default parameters:
//! every instance found, nothing else reported (scored like evaluate.py),
//! the same instances from the serial and the parallel backend and from a
//! turned scene, and from the optional sampled first pass as from every
//! vertex.

mod common;

use common::run_with;
use fast_reject::exec::Threads;
use fast_reject::search::{DescriptorKind, MatchOptions};

fn curvature() -> MatchOptions {
    let mut options = MatchOptions::DEFAULT;
    options.descriptor = DescriptorKind::Curvature;
    options
}

fn assert_finds_everything(name: &str, select: bool) {
    let report = run_with(name, select, &curvature());
    common::assert_finds_everything(name, select, &report);
    assert!(report.grid.is_none(), "a curvature search needs no voxels");
    let stages: Vec<&str> = report.stages.iter().map(|s| s.descriptor).collect();
    assert_eq!(stages, vec!["curvature"; 6]);
}

#[test]
fn twisted_homer() {
    assert_finds_everything("twisted-homer", false);
}

#[test]
fn fused_homer() {
    assert_finds_everything("fused-homer", false);
}

#[test]
fn select_cow_head() {
    assert_finds_everything("select-cow-head", true);
}

#[test]
fn remeshed_cow() {
    // The cow is mirror-symmetric and c_T lies on a flank: without the
    // mirror test, the other flank of each cow is reported instead.
    assert_finds_everything("remeshed-cow", false);
}

#[test]
fn zoo_bunny() {
    assert_finds_everything("zoo-bunny", false);
}

#[test]
fn serial_and_parallel_agree() {
    let mut serial = curvature();
    serial.backend = Threads::Serial;
    let a = run_with("twisted-homer", false, &serial);
    let b = run_with("twisted-homer", false, &curvature());
    assert_eq!(a.instances, b.instances);
    let counts = |r: &fast_reject::search::MatchReport| {
        r.stages
            .iter()
            .map(|s| (s.candidates, s.survivors))
            .collect::<Vec<_>>()
    };
    assert_eq!(counts(&a), counts(&b));
}

#[test]
fn the_sampled_pass_finds_what_every_vertex_finds() {
    let mut sampled = curvature();
    sampled.curvature_spacing = 0.5;
    for (name, select) in [("twisted-homer", false), ("select-cow-head", true)] {
        let a = run_with(name, select, &curvature());
        let b = run_with(name, select, &sampled);
        // A pass over one vertex per cell, then every vertex near its
        // survivors: both far fewer than the vertices.
        let stages: Vec<&str> = b.stages.iter().map(|s| s.descriptor).collect();
        let expected: Vec<&str> = [["curvature-sample"; 6], ["curvature"; 6]].concat();
        assert_eq!(stages, expected, "{name}");
        let vertices = b.surface.as_ref().unwrap().vertices;
        for pass in b.stages.chunks(6) {
            assert!(pass[0].candidates * 3 < vertices, "{name}: {:?}", b.stages);
        }
        // A survivor far from every sample survivor can be missed, which
        // lowers an instance's support; the best points are the same.
        let found = |r: &fast_reject::search::MatchReport| {
            r.instances
                .iter()
                .map(|i| (i.position, i.distance))
                .collect::<Vec<_>>()
        };
        assert_eq!(found(&a), found(&b), "{name}");
    }
}

#[test]
fn a_turned_scene_gives_the_same_occurrences() {
    // Every descriptor value is invariant under rotation, so turning the
    // scene must not change what is found.
    use fast_reject::math::Vec3;
    use fast_reject::mesh::io::load;
    use fast_reject::scene::{Scene, SceneOptions};
    use fast_reject::search::search;
    let axis = {
        let a = Vec3::new(1.0, 2.0, 3.0);
        a * (1.0 / a.length())
    };
    // Rodrigues' rotation about `axis`.
    let turn = |p: Vec3, angle: f64| {
        let (s, c) = angle.sin_cos();
        p * c + axis.cross(p) * s + axis * (axis.dot(p) * (1.0 - c))
    };
    let name = "twisted-homer";
    let bytes = std::fs::read(common::scene_dir(name).join("scene.glb")).unwrap();
    let mesh = load(&bytes, None).unwrap();
    let truth = common::truth(name);
    for angle in [0.25, 1.3, 2.2] {
        let turned = mesh.map_positions(|p| turn(p, angle)).unwrap();
        let scene = Scene::new(turned, &SceneOptions::DEFAULT).unwrap();
        let mut report = search(
            &scene,
            &common::template(name, false),
            &curvature(),
            &mut (),
        )
        .unwrap();
        for i in &mut report.instances {
            let [x, y, z] = i.position;
            let back = turn(Vec3::new(x, y, z), -angle);
            i.position = [back.x, back.y, back.z];
        }
        let s = common::score(&truth, &report, false);
        assert_eq!((s.tp, s.fp), (s.targets, 0), "turned by {angle}: {s:?}");
    }
}
