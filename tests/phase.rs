//! The grid's phase: a scene turned and moved by sub-voxel offsets gives
//! the same instances (see `common::phase`; `examples/grid_phase.rs`
//! prints the same trials).

mod common;

use fast_reject::{MatchOptions, SceneOptions};

#[test]
fn a_turned_and_moved_scene_gives_the_same_instances() {
    let trials = common::phase::placements(
        &common::scene_dir("zoo-bunny"),
        6,
        1,
        true,
        &SceneOptions::DEFAULT,
        &MatchOptions::DEFAULT,
        |_, _| {},
    );
    for (i, t) in trials.iter().enumerate() {
        assert!(
            t.clean(),
            "placement {i} (offset {:?}): {}/{} found, false hits {:?}, error {:?}",
            t.offset,
            t.found,
            t.copies,
            t.false_hits,
            t.error
        );
    }
}
