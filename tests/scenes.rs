//! The matcher on the shared benchmark scenes, with default parameters:
//! every instance found, nothing else reported (scored like evaluate.py).

mod common;

use common::run;

fn assert_finds_everything(name: &str, select: bool) {
    let report = run(name, select);
    common::assert_finds_everything(name, select, &report);
    if select {
        assert!(report.instances.iter().all(|i| i.pose.is_some()));
    } else {
        assert_poses(name, &report);
    }
}

/// Each found copy's pose agrees with the truth's placement within 2
/// degrees and 2% of r_k: the voxel placement refined on the meshes
/// (measured within 0.07 degrees and 0.1% on these scenes).
fn assert_poses(name: &str, report: &fast_reject::MatchReport) {
    let (angle, shift) = common::worst_pose_error(&common::truth(name), report);
    assert!(
        angle <= 2.0,
        "{name}: a pose is turned {angle:.3} degrees off"
    );
    assert!(shift <= 0.02, "{name}: a pose puts c_T {shift:.4} r_k off");
}

#[test]
fn zoo_bunny() {
    assert_finds_everything("zoo-bunny", false);
}

#[test]
fn remeshed_cow() {
    assert_finds_everything("remeshed-cow", false);
}

#[test]
fn crowd_rocker() {
    assert_finds_everything("crowd-rocker", false);
}

#[test]
fn select_cow_head() {
    assert_finds_everything("select-cow-head", true);
}

#[test]
fn fused_homer() {
    assert_finds_everything("fused-homer", false);
}

#[test]
fn cluttered_bunny() {
    // Also: the two 0.75-scale decoys are not reported (they would be fp).
    assert_finds_everything("cluttered-bunny", false);
}

#[test]
fn twisted_homer() {
    // Bent by up to 30 degrees: no rigid pose exists, so poses are not
    // checked; 89% of each copy's surface lies within the default 3% of
    // r_k of the scene at the best rigid fit.
    let report = run("twisted-homer", false);
    common::assert_finds_everything("twisted-homer", false, &report);
}

#[test]
fn a_tighter_surface_tolerance_refuses_bent_copies() {
    // At 1% of r_k, as for exact CAD instances, a copy must be rigid.
    let mut options = fast_reject::MatchOptions::DEFAULT;
    options.surface_tolerance = 0.01;
    let report = common::run_with("twisted-homer", false, &options);
    assert!(report.instances.is_empty(), "{:?}", report.instances);
    let report = common::run_with("zoo-bunny", false, &options);
    common::assert_finds_everything("zoo-bunny", false, &report);
}

#[test]
fn real_saw_fin() {
    // Real CAD: twelve thin plates packed close on a ring, other parts'
    // surface all around them; found because each part is described alone.
    // A plate is 4 voxels thick and nearly the same turned over: the
    // voxels leave some upside down, the meshes turn them back.
    let report = run("real-saw-fin", false);
    common::assert_finds_everything("real-saw-fin", false, &report);
    assert_poses("real-saw-fin", &report);
}

#[test]
fn real_saw_roller() {
    // Real CAD: 24 needle rollers touching their neighbours on a ring, each
    // 4% of the assembly: the grid is refined until a roller spans 32
    // voxels, where its pose and a longer pin nearby are told apart. A
    // roller is nearly a cylinder: the turn about its axis comes from the
    // meshes' facets.
    let report = run("real-saw-roller", false);
    common::assert_finds_everything("real-saw-roller", false, &report);
    assert_poses("real-saw-roller", &report);
}

#[test]
fn real_t12_knee() {
    // Real CAD: a robot's knee of two shells between its thigh and shin,
    // ankles (near twins) nearby. The knee's part gathers what touches it,
    // which buries c_T: the copies are found at a further anchor, read
    // where c_T found none. The ankles are not reported (before, two
    // were, at score 0.88).
    let report = run("real-t12-knee", false);
    common::assert_finds_everything("real-t12-knee", false, &report);
    assert_poses("real-t12-knee", &report);
}

#[test]
fn real_truck_wheels() {
    // Real data: a truck's wheel pair, a third of the scene, in its arches.
    // The rear pair's part gathers the parts at its axle, which bury c_T:
    // that pair is found at a further anchor.
    let report = run("real-truck-wheels", false);
    common::assert_finds_everything("real-truck-wheels", false, &report);
    assert_poses("real-truck-wheels", &report);
}
