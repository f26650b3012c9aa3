//! Towers standing on a city's ground, fixtures from
//! `scripts/make-city-scenes.py`: three copies of a tower, each turned
//! about the vertical, among near twins and towers of other sizes on a
//! 600 m slab.
//!
//! - `city-block` (`--seed 1`): a tower with a setback at one corner. The
//!   template is square to its own grid; read at that grid's one phase,
//!   its harmonics missed all three copies at resolution 512 and found
//!   them at 500 and 520. Its signatures are now the mean over two phases
//!   (`search::voxel::signatures`).
//! - `city-gable` (`--seed 18`): a gable-roofed tower whose c_T lies on
//!   the lowest face of the template's grid, on a voxel boundary. One of
//!   the two phases was read a voxel deep there, and every copy (turned
//!   135, 73 and -54 degrees) was lost at every resolution from 256 to
//!   768, while two near twins sharing its shaft were reported. Each phase
//!   is now read at its own skin.

mod common;

use std::path::PathBuf;

use fast_reject::mesh::io::load;
use fast_reject::{MatchOptions, Scene, SceneOptions, TemplateSource, search};

fn fixture(folder: &str, file: &str) -> Vec<u8> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(folder)
        .join(file);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn towers_turned_on_the_ground_are_found_at_every_resolution() {
    every_copy_at_every_resolution("city-block");
}

#[test]
fn a_tower_anchored_on_its_grids_lowest_face_is_found_at_every_resolution() {
    every_copy_at_every_resolution("city-gable");
}

fn every_copy_at_every_resolution(folder: &str) {
    let fixture = |file| fixture(folder, file);
    let truth: serde_json::Value = serde_json::from_slice(&fixture("truth.json")).unwrap();
    let template = TemplateSource::Model(load(&fixture("template.glb"), None).unwrap());
    let mesh = load(&fixture("scene.glb"), None).unwrap();
    for resolution in [384, 448, 512, 576, 640] {
        let scene = Scene::new(
            mesh.clone(),
            &SceneOptions::DEFAULT.with_resolution(resolution),
        )
        .unwrap();
        let report = search(&scene, &template, &MatchOptions::DEFAULT, &mut ()).unwrap();
        let score = common::score(&truth, &report, false);
        // The near twins (the setback moved or reshaped) are refused: they
        // share most of the tower exactly, and refit on it, 5-10% of the
        // template lies off.
        assert_eq!(
            (score.tp, score.fp),
            (3, 0),
            "{folder} at resolution {resolution}: {score:?}, {:#?}",
            report.instances
        );
    }
}
