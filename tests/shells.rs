//! A template of several shells that stand apart (a wheel pair, a knee and
//! its pin): its copies are gathered from the scene's components that may
//! be their shells, whatever else they touch, and where the scene holds
//! exact copies a near twin (one shell a little larger) is refused unless
//! asked for.
//!
//! The template is a rocker arm with a ball beside it, apart from it. The
//! scene holds two copies alone, two standing on a wide plate that touches
//! both shells, a near twin whose ball is 12% larger, and an arm without
//! its ball.

mod common;

use fast_reject::math::Vec3;
use fast_reject::mesh::shapes::{cuboid, uv_sphere};
use fast_reject::{
    MatchOptions, MatchReport, Scene, SceneOptions, TemplateSource, TriMesh, search,
};
use glam::DQuat;

/// The rocker arm of radius 0.3 with a ball of `ball` radius apart from it.
fn arm_and_ball(ball: f64) -> TriMesh {
    let mut mesh = common::scaled_model("rocker-arm.obj", 0.3);
    let b = mesh.bounds();
    let centre = Vec3::new(b.max.x + 0.06 + ball, b.center().y, b.center().z);
    mesh.append(&uv_sphere(centre, ball, 12, 24));
    mesh
}

/// `mesh` turned by `turn` and moved by `shift`.
fn placed(mesh: &TriMesh, turn: DQuat, shift: Vec3) -> TriMesh {
    mesh.map_positions(|p| turn * p + shift).unwrap()
}

/// Where each exact copy's template point lies, and the report.
fn search_scene(options: &MatchOptions) -> (Vec<Vec3>, Vec3, MatchReport) {
    let template = arm_and_ball(0.08);
    let twin = arm_and_ball(0.09);
    let copies = [
        (DQuat::from_rotation_z(0.4), Vec3::new(2.0, 0.0, 0.0)),
        (
            DQuat::from_euler(glam::EulerRot::XYZ, 0.3, 1.1, -0.5),
            Vec3::new(0.0, 2.0, 0.5),
        ),
        (DQuat::from_rotation_z(-1.2), Vec3::new(6.0, 0.0, 0.0)),
        (DQuat::from_rotation_z(2.0), Vec3::new(6.0, 2.0, 0.0)),
    ];
    let twin_place = (DQuat::from_rotation_z(0.9), Vec3::new(2.0, 4.0, 0.0));
    let mut scene = placed(&template, copies[0].0, copies[0].1);
    for &(turn, shift) in &copies[1..] {
        scene.append(&placed(&template, turn, shift));
    }
    scene.append(&placed(&twin, twin_place.0, twin_place.1));
    // The arm without its ball: most of the template's surface, not a copy.
    let arm = common::scaled_model("rocker-arm.obj", 0.3);
    scene.append(&placed(
        &arm,
        DQuat::from_rotation_x(0.5),
        Vec3::new(0.0, 4.0, 0.0),
    ));
    // A plate wider than the template, touching the last two copies'
    // shells from below.
    let lowest = |turn: DQuat, shift: Vec3| placed(&template, turn, shift).bounds().min.z;
    let floor = lowest(copies[2].0, copies[2].1).max(lowest(copies[3].0, copies[3].1));
    scene.append(&cuboid(
        Vec3::new(4.5, -1.0, floor - 0.1),
        Vec3::new(7.5, 3.0, floor + 0.02),
    ));
    let scene = Scene::new(scene, &SceneOptions::DEFAULT).unwrap();
    let report = search(&scene, &TemplateSource::Model(template), options, &mut ()).unwrap();
    let c = Vec3::from_array(report.template.center);
    let at = copies
        .iter()
        .map(|&(turn, shift)| turn * c + shift)
        .collect();
    (at, twin_place.0 * c + twin_place.1, report)
}

#[test]
fn shells_apart_are_found_together_and_the_near_twin_is_refused() {
    let (copies, _, report) = search_scene(&MatchOptions::DEFAULT);
    common::assert_found_exactly(&report, &copies, 0.02);
    let exact = report.instances.iter().filter_map(|i| i.residual);
    assert!(
        exact.clone().all(|r| r < 1e-4),
        "{:?}",
        exact.collect::<Vec<_>>()
    );
}

#[test]
fn near_twins_are_kept_when_asked_for() {
    let mut options = MatchOptions::DEFAULT;
    options.keep_near_twins = true;
    let (mut copies, twin, report) = search_scene(&options);
    copies.push(twin);
    common::assert_found_exactly(&report, &copies, 0.02);
}

#[test]
fn a_copy_whose_centre_is_buried_is_found_at_a_further_anchor() {
    // A small ball sits on one copy at c_T, as a pin or a neighbour's boss
    // would: the copy's part gathers it, and its inner layers read the
    // ball's volume, which no rule excuses. The copy is still found, at an
    // anchor away from c_T.
    let template = arm_and_ball(0.08);
    let alone = Scene::new(template.clone(), &SceneOptions::DEFAULT).unwrap();
    let own = common::search_model(&alone, template.clone());
    let c = Vec3::from_array(own.template.center);
    let copies = [
        (DQuat::from_rotation_z(0.7), Vec3::new(0.0, 0.0, 0.0)),
        (
            DQuat::from_euler(glam::EulerRot::XYZ, -0.4, 0.8, 0.2),
            Vec3::new(3.0, 0.0, 0.0),
        ),
    ];
    let mut scene = placed(&template, copies[0].0, copies[0].1);
    scene.append(&placed(&template, copies[1].0, copies[1].1));
    let buried = copies[1].0 * c + copies[1].1;
    scene.append(&uv_sphere(buried, 0.05, 12, 24));
    let scene = Scene::new(scene, &SceneOptions::DEFAULT).unwrap();
    let report = common::search_model(&scene, template);
    let at: Vec<Vec3> = copies
        .iter()
        .map(|&(turn, shift)| turn * c + shift)
        .collect();
    common::assert_found_exactly(&report, &at, 0.02);
}

#[test]
fn a_copy_missing_a_small_shell_is_not_one() {
    // A bunny of radius 1 with a ball of 0.2 beside it: the ball is a few
    // per cent of the surface, and the bunny alone lies on all the rest at
    // float rounding.
    let bunny = common::scaled_model("stanford-bunny.obj", 1.0);
    let mut template = bunny.clone();
    let b = bunny.bounds();
    let centre = Vec3::new(b.max.x + 0.3, b.center().y, b.center().z);
    template.append(&uv_sphere(centre, 0.2, 12, 24));
    let copy = (DQuat::from_rotation_y(0.8), Vec3::new(0.0, 0.0, 0.0));
    let mut scene = placed(&template, copy.0, copy.1);
    scene.append(&placed(
        &bunny,
        DQuat::from_rotation_z(-0.6),
        Vec3::new(5.0, 0.0, 0.0),
    ));
    let scene = Scene::new(scene, &SceneOptions::DEFAULT).unwrap();
    let report = common::search_model(&scene, template);
    let c = Vec3::from_array(report.template.center);
    common::assert_found_exactly(&report, &[copy.0 * c + copy.1], 0.02);
}
