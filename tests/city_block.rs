//! Towers standing on a city's ground: a fixture from
//! `scripts/make-city-scenes.py tests/fixtures/city-block --seed 1`, three
//! copies of a tower with a setback at one corner, each turned about the
//! vertical, among near twins and towers of other sizes on a 600 m slab.
//! The template is square to its own grid; read at that grid's one phase,
//! its harmonics missed all three copies at resolution 512 and found them
//! at 500 and 520. Its signatures are now the mean over two phases
//! (`search::voxel::signatures`), and the copies are found at every
//! resolution tried, with no near twin.

mod common;

use std::path::PathBuf;

use fast_reject::mesh::io::load;
use fast_reject::{MatchOptions, Scene, SceneOptions, TemplateSource, search};

fn fixture(file: &str) -> Vec<u8> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/city-block")
        .join(file);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn towers_turned_on_the_ground_are_found_at_every_resolution() {
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
            "resolution {resolution}: {score:?}, {:#?}",
            report.instances
        );
    }
}
