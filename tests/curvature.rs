//! The curvature descriptor on the shared scenes, with default parameters:
//! every instance found, nothing else reported (scored like evaluate.py),
//! the same instances from the serial and the parallel backend, and from
//! the sampled first pass as from every vertex.

mod common;

use common::run_with;
use fast_reject::exec::Backend;
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
    // A pass over one vertex per cell, then every vertex near its survivors.
    let stages: Vec<&str> = report.stages.iter().map(|s| s.descriptor).collect();
    let expected: Vec<&str> = [["curvature-sample"; 6], ["curvature"; 6]].concat();
    assert_eq!(stages, expected);
    let (sample, every) = report.stages.split_at(6);
    let vertices = report.surface.as_ref().unwrap().vertices;
    for pass in [sample, every] {
        assert!(pass[0].candidates * 2 < vertices, "{:?}", report.stages);
    }
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
    serial.backend = Backend::Serial;
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
    // Every vertex a candidate: the paper's schema on the whole mesh.
    let mut every = curvature();
    every.curvature_spacing = 0.0;
    for (name, select) in [("twisted-homer", false), ("select-cow-head", true)] {
        let a = run_with(name, select, &every);
        let b = run_with(name, select, &curvature());
        assert_eq!(a.stages.len(), 6, "one pass over every vertex");
        // A survivor far from every sample survivor can be missed, which
        // lowers an instance's support; the best points are the same.
        let found = |r: &fast_reject::search::MatchReport| {
            r.instances
                .iter()
                .map(|i| (i.position, i.distance))
                .collect::<Vec<_>>()
        };
        assert_eq!(found(&a), found(&b), "{name}");
        let first = |r: &fast_reject::search::MatchReport| r.stages[0].candidates;
        assert!(
            first(&b) * 3 < first(&a),
            "{name}: the sample is not sparse"
        );
    }
}
