//! Does a search depend on where the voxel grid falls? Moves a shared scene
//! by random sub-voxel offsets (and, with `--turn`, turns it about its
//! centre), searches each copy and scores it against the truth moved the
//! same way. A search independent of the grid's phase finds the same
//! instances every time (the real-scenes issue asks for it; `tests/phase.rs`
//! asserts it on a generated scene).
//!
//! ```sh
//! cargo run --release --example grid_phase -- zoo-bunny [--trials 10] [--seed 1]
//!     [--turn] [--resolution N] [--descriptor NAME]
//! ```
//!
//! SCENE is a folder of `../shared/scenes` (or any folder with `scene.glb`,
//! `template.glb` and `truth.json`). Prints a row per placement (its offset
//! in voxels, true and false positives, milliseconds), each false hit, and
//! how many placements found every instance with no false positive.

#[path = "../tests/common/mod.rs"]
mod common;

use std::path::PathBuf;

use fast_reject::{DescriptorKind, MatchOptions, SceneOptions};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let flag = |name: &str| {
        args.iter()
            .position(|a| a == name)
            .map(|i| args[i + 1].clone())
    };
    let Some(name) = args.first().filter(|a| !a.starts_with("--")) else {
        eprintln!(
            "usage: grid_phase SCENE [--trials N] [--seed S] [--turn] [--resolution N] [--descriptor NAME]"
        );
        std::process::exit(2);
    };
    let trials: usize = flag("--trials").map_or(10, |v| v.parse().expect("--trials N"));
    let seed: u64 = flag("--seed").map_or(1, |v| v.parse().expect("--seed S"));
    let turn = args.iter().any(|a| a == "--turn");
    let mut scene_options = SceneOptions::DEFAULT;
    if let Some(r) = flag("--resolution") {
        scene_options = scene_options.with_resolution(r.parse().expect("--resolution N"));
    }
    let mut options = MatchOptions::DEFAULT;
    if let Some(d) = flag("--descriptor") {
        options.descriptor = d
            .parse::<DescriptorKind>()
            .unwrap_or_else(|e| panic!("{e}"));
    }
    let path = PathBuf::from(name);
    let dir = if path.join("scene.glb").exists() {
        path
    } else {
        common::scene_dir(name)
    };
    println!(
        "{name}: {trials} placements, {} by up to a voxel",
        if turn {
            "turned about the centre and moved"
        } else {
            "moved"
        }
    );
    println!(
        "{:>5} {:>24} {:>6} {:>4} {:>9}",
        "trial", "offset (voxels)", "found", "fp", "ms"
    );
    let results = common::phase::placements(
        &dir,
        trials,
        seed,
        turn,
        &scene_options,
        &options,
        |i, t| {
            let offset = format!("({:.2}, {:.2}, {:.2})", t.offset.x, t.offset.y, t.offset.z);
            if let Some(e) = &t.error {
                println!("{i:>5} {offset:>24} error: {e}");
                return;
            }
            println!(
                "{i:>5} {offset:>24} {:>6} {:>4} {:>9.0}",
                format!("{}/{}", t.found, t.copies),
                t.false_hits.len(),
                t.ms
            );
            for (distance, score) in &t.false_hits {
                println!("      false hit {distance:.2} r from a copy, score {score:.3}");
            }
        },
    );
    let clean = results.iter().filter(|t| t.clean()).count();
    println!("every instance and no false positive in {clean} of {trials} placements");
}
