//! Where the template's descriptors are read: a c_T whose voxels change as
//! the template turns is replaced by a steadier anchor and read at two
//! more, and copies at every orientation are found.

mod common;

use fast_reject::math::Vec3;
use fast_reject::template::VoxelTemplate;
use fast_reject::{MatchOptions, Scene, SceneOptions, TemplateSource, TriMesh, load};
use glam::DQuat;

/// The Utah teapot scaled to a bounding radius of about 1: its lid sits on
/// the open body, and around c_T (on the lid) the filled solid differs
/// with the turn.
fn teapot() -> TriMesh {
    common::scaled_model("teapot.obj", 1.0)
}

#[test]
fn teapots_turned_every_way_are_all_found() {
    let template = teapot();
    let turns: Vec<DQuat> = [
        (0.0, 0.0, 1.0, 0.0),
        (1.0, 0.0, 0.0, 1.9),
        (0.3, 1.0, -0.5, 2.6),
        (-1.0, 0.4, 0.7, 1.2),
        (0.2, -0.6, 1.0, 3.0),
        (1.0, 1.0, 0.0, 2.2),
    ]
    .iter()
    .map(|&(x, y, z, a)| DQuat::from_axis_angle(Vec3::new(x, y, z).normalize(), a))
    .collect();
    let place = |i: usize, p: Vec3| turns[i] * p + Vec3::new(3.0 * i as f64, 0.0, 0.0);
    let mut scene = template.map_positions(|p| place(0, p)).unwrap();
    for i in 1..turns.len() {
        scene.append(&template.map_positions(|p| place(i, p)).unwrap());
    }
    let scene = Scene::new(scene, &SceneOptions::DEFAULT).unwrap();
    let report = common::search_model(&scene, template);
    let c = Vec3::from_array(report.template.center);
    let r = report.template.radius;
    let truth: Vec<Vec3> = (0..turns.len()).map(|i| place(i, c)).collect();
    common::assert_found_exactly(&report, &truth, 0.2 * r);
}

/// The anchors `template` is read at when searched for in itself, in
/// template units, and its outer radius.
fn anchors_of(template: TriMesh) -> (Vec<Vec3>, f64) {
    let scene = Scene::new(template.clone(), &SceneOptions::DEFAULT).unwrap();
    let source = TemplateSource::Model(template);
    let options = MatchOptions::DEFAULT;
    let lattice = scene
        .lattice_for(source.bounding_radius(), options.template_voxels)
        .unwrap();
    let t = VoxelTemplate::new(&source, &scene, &lattice, &options).unwrap();
    let anchors = (0..t.anchors().len())
        .map(|a| t.anchor_position(a))
        .collect();
    (anchors, t.radius())
}

#[test]
fn a_drifting_template_is_read_at_three_anchors_apart_and_a_steady_one_at_one() {
    let (teapot, r) = anchors_of(teapot());
    assert_eq!(teapot.len(), 3, "{teapot:?}");
    for (i, a) in teapot.iter().enumerate() {
        for b in &teapot[i + 1..] {
            assert!(a.distance(*b) >= 0.5 * r - 1e-9, "{teapot:?}, r_k {r}");
        }
    }
    let bunny = load(&common::model_bytes("stanford-bunny.obj"), None).unwrap();
    assert_eq!(anchors_of(bunny).0.len(), 1);
}
