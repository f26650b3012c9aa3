//! The matcher on the shared benchmark scenes, with default parameters:
//! every instance found, nothing else reported (scored like evaluate.py).

mod common;

use common::run;

fn assert_finds_everything(name: &str, select: bool) {
    common::assert_finds_everything(name, select, &run(name, select));
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
