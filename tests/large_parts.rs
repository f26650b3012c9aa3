//! Small parts on a very large one, as in a building model: fixtures of
//! 0.6 m on a 100 m floor slab, under long ducts. The slab's plain faces
//! hold no vertex, so no copy can be anchored there; searched whole, they
//! held 42 million candidates and the search was refused for memory. The
//! slab is too large for one grid at the template's voxels: it is searched
//! in windows, of which only those by its corners are built.

mod common;

use fast_reject::math::Vec3;
use fast_reject::mesh::shapes::cuboid;
use fast_reject::{Scene, SceneOptions, TriMesh};
use glam::DQuat;

/// The rocker arm scaled to a bounding radius of about `radius`, centred.
fn fixture(radius: f64) -> TriMesh {
    common::scaled_model("rocker-arm.obj", radius)
}

#[test]
fn fixtures_on_a_floor_slab_a_hundred_metres_wide_are_all_found() {
    let template = fixture(0.3);
    let mut scene = cuboid(Vec3::new(-50.0, -50.0, -0.3), Vec3::new(50.0, 50.0, 0.0));
    for i in 0..4 {
        let y = -30.0 + 20.0 * i as f64;
        scene.append(&cuboid(
            Vec3::new(-45.0, y - 0.2, 2.5),
            Vec3::new(45.0, y + 0.2, 2.9),
        ));
    }
    let places: Vec<(DQuat, Vec3)> = (0..6)
        .map(|i| {
            let a = 1.3 * i as f64;
            let turn = DQuat::from_axis_angle(Vec3::new(a.cos(), a.sin(), 1.0).normalize(), a);
            let at = Vec3::new(-40.0 + 15.0 * i as f64, 35.0 - 11.0 * i as f64, 0.0);
            (turn, at)
        })
        .collect();
    for &(turn, at) in &places {
        let turned = template.map_positions(|p| turn * p).unwrap();
        // Standing on the slab.
        let lift = Vec3::new(0.0, 0.0, 0.001 - turned.bounds().min.z);
        scene.append(&turned.map_positions(|p| p + at + lift).unwrap());
    }
    let scene = Scene::new(scene, &SceneOptions::DEFAULT).unwrap();
    let report = common::search_model(&scene, template.clone());
    let c = Vec3::from_array(report.template.center);
    let r = report.template.radius;
    // The slab, searched in windows, does not coarsen the lattice: the
    // template spans its 32 voxels across its bounding radius.
    let grid = report.grid.clone().expect("a voxel search");
    assert!(grid.windows > 0, "{grid:?}");
    assert!(grid.voxel_size <= 0.3 / 32.0 * 1.001, "{grid:?}");
    let truth: Vec<Vec3> = places
        .iter()
        .map(|&(turn, at)| {
            let lift = 0.001 - template.map_positions(|p| turn * p).unwrap().bounds().min.z;
            turn * c + at + Vec3::new(0.0, 0.0, lift)
        })
        .collect();
    common::assert_found_exactly(&report, &truth, 0.1 * r);
}

/// Two turned copies of a model that are nearly half the scene each, and a
/// near twin 10% smaller: at the scene's resolution the template would span
/// about 120 voxels, its ball tables growing with the cube of that. It is
/// searched on a lattice where it spans between 32 and 96, and both copies
/// are found, the twin not.
#[test]
fn a_part_half_the_scene_is_searched_on_a_coarser_lattice() {
    let template = common::scaled_model("teapot.obj", 1.0);
    let turns: [(f64, f64); 3] = [(0.4, 0.7), (2.1, -1.2), (4.0, 0.3)];
    let mut scene: Option<TriMesh> = None;
    let mut places = Vec::new();
    for (i, &(a, b)) in turns.iter().enumerate() {
        let turn = DQuat::from_axis_angle(Vec3::new(a.cos(), a.sin(), b).normalize(), a + b);
        let at = Vec3::new(2.1 * i as f64, 0.3 * i as f64, 0.0);
        let scale = if i == 2 { 0.9 } else { 1.0 };
        let copy = template.map_positions(|p| turn * (p * scale) + at).unwrap();
        match scene.as_mut() {
            Some(scene) => scene.append(&copy),
            None => scene = Some(copy),
        }
        if i < 2 {
            places.push((turn, at));
        }
    }
    let scene = Scene::new(scene.unwrap(), &SceneOptions::DEFAULT).unwrap();
    let report = common::search_model(&scene, template.clone());
    let grid = report.grid.clone().expect("a voxel search");
    let span = report.template.radius / grid.voxel_size;
    assert!((32.0..=96.5).contains(&span), "{span} voxels: {grid:?}");
    let c = Vec3::from_array(report.template.center);
    let truth: Vec<Vec3> = places.iter().map(|&(turn, at)| turn * c + at).collect();
    common::assert_found_exactly(&report, &truth, 0.05 * report.template.radius);
}
