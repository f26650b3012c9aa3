//! The serial and the parallel backend give identical results: the same
//! part grids, the same survivors at every layer, the same instances, bit for bit.

mod common;

use fast_reject::TemplateSource;
use fast_reject::exec::Threads;
use fast_reject::mesh::io::load;
use fast_reject::scene::{Scene, SceneOptions};
use fast_reject::search::{MatchOptions, MatchReport, search};

fn run(scene_bytes: &[u8], template: &TemplateSource, backend: Threads) -> (Scene, MatchReport) {
    let scene = Scene::new(
        load(scene_bytes, None).unwrap(),
        &SceneOptions::DEFAULT.with_backend(backend),
    )
    .unwrap();
    let mut options = MatchOptions::DEFAULT;
    options.backend = backend;
    let report = search(&scene, template, &options, &mut ()).unwrap();
    (scene, report)
}

fn assert_identical(scene_bytes: &[u8], template: &TemplateSource) {
    let (scene_s, serial) = run(scene_bytes, template, Threads::Serial);
    let (scene_p, parallel) = run(scene_bytes, template, Threads::Parallel);
    // Every part's voxels, at the padding a search uses.
    let lattice = scene_s
        .lattice_for(
            template.bounding_radius(),
            MatchOptions::DEFAULT.template_voxels,
        )
        .unwrap();
    let reach = serial.template.radius / lattice.spec.voxel_size;
    let parts = |scene: &Scene| scene.parts().to_vec();
    for (i, (a, b)) in parts(&scene_s).iter().zip(parts(&scene_p)).enumerate() {
        let s = scene_s.voxelize_part(a, &lattice, reach).unwrap();
        let p = scene_p.voxelize_part(&b, &lattice, reach).unwrap();
        assert!(s.grid() == p.grid(), "voxel grids of part {i} differ");
        assert_eq!(s.skin(), p.skin());
        assert!(s.near_surface() == p.near_surface());
    }
    let counts = |r: &MatchReport| {
        r.stages
            .iter()
            .map(|s| (s.descriptor, s.layer, s.candidates, s.survivors))
            .collect::<Vec<_>>()
    };
    assert_eq!(counts(&serial), counts(&parallel));
    assert_eq!(serial.instances, parallel.instances);
    assert_eq!(serial.template, parallel.template);
    assert!(!serial.instances.is_empty());
}

#[test]
fn demo_scene() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/demo");
    let scene = std::fs::read(format!("{dir}/scene.glb")).unwrap();
    let template = TemplateSource::Model(
        load(&std::fs::read(format!("{dir}/template.glb")).unwrap(), None).unwrap(),
    );
    assert_identical(&scene, &template);
}

#[test]
fn select_cow_head() {
    let scene = std::fs::read(common::scene_dir("select-cow-head").join("scene.glb")).unwrap();
    assert_identical(&scene, &common::template("select-cow-head", true));
}
