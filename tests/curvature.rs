//! The curvature descriptor on the shared scenes, with default parameters:
//! every instance found, nothing else reported (scored like evaluate.py),
//! and the same instances from the serial and the parallel backend.

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
