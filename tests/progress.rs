//! Progress between layers: a search of many parts, or of the curvature
//! descriptor over many vertices (after building the welded surface), tells
//! how far it has come, and a `Break` there cancels it like one from a
//! layer.

use std::ops::ControlFlow;

use fast_reject::math::Vec3;
use fast_reject::mesh::shapes::uv_sphere;
use fast_reject::{
    DescriptorKind, Error, LayerStats, MatchOptions, Observer, Progress, Scene, SceneOptions,
    TemplateSource, load, search,
};

/// Every progress report, in order; breaks at the `stop_at`-th if given.
#[derive(Default)]
struct Recorder {
    seen: Vec<Progress>,
    stop_at: Option<usize>,
}

impl Observer for Recorder {
    fn on_layer(&mut self, _: &LayerStats) -> ControlFlow<()> {
        ControlFlow::Continue(())
    }

    fn on_progress(&mut self, progress: &Progress) -> ControlFlow<()> {
        self.seen.push(*progress);
        match self.stop_at {
            Some(n) if self.seen.len() >= n => ControlFlow::Break(()),
            _ => ControlFlow::Continue(()),
        }
    }
}

fn demo() -> (Scene, TemplateSource) {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/demo");
    let read = |name: &str| load(&std::fs::read(format!("{dir}/{name}")).unwrap(), None).unwrap();
    let scene = Scene::new(read("scene.glb"), &SceneOptions::DEFAULT).unwrap();
    (scene, TemplateSource::Model(read("template.glb")))
}

/// `seen` counts up to its total, one step, never backwards.
fn counts_up_to_the_end(seen: &[Progress], step: &str) {
    let of_step: Vec<&Progress> = seen.iter().filter(|p| p.step == step).collect();
    assert!(!of_step.is_empty(), "no {step} in {seen:?}");
    let total = of_step[0].total;
    assert!(
        of_step
            .windows(2)
            .all(|w| w[0].done < w[1].done && w[1].total == total),
        "{of_step:?}"
    );
    let last = of_step[of_step.len() - 1];
    assert_eq!((last.done, last.share()), (total, 1.0), "{of_step:?}");
}

#[test]
fn a_search_of_many_parts_counts_them_to_the_end() {
    let (scene, template) = demo();
    let mut recorder = Recorder::default();
    let report = search(&scene, &template, &MatchOptions::DEFAULT, &mut recorder).unwrap();
    assert!(!report.instances.is_empty());
    counts_up_to_the_end(&recorder.seen, Progress::PARTS);
    assert!(recorder.seen[0].total > 1, "{:?}", recorder.seen);
}

#[test]
fn parts_searched_side_by_side_are_counted_as_each_ends() {
    let (scene, template) = demo();
    let mut recorder = Recorder::default();
    search(&scene, &template, &MatchOptions::DEFAULT, &mut recorder).unwrap();
    let done: Vec<usize> = recorder
        .seen
        .iter()
        .filter(|p| p.step == Progress::PARTS)
        .map(|p| p.done)
        .collect();
    // None done first; then one wave holds them all: held to its end, they
    // would be one report.
    assert_eq!(done, (0..done.len()).collect::<Vec<_>>());
    assert!(done.len() > 2, "{done:?}");
}

fn curvature_on_a_sphere() -> (Scene, TemplateSource, MatchOptions) {
    let scene = Scene::new(
        uv_sphere(Vec3::ZERO, 1.0, 32, 64),
        &SceneOptions::DEFAULT.with_resolution(64),
    )
    .unwrap();
    let selection = TemplateSource::Selection {
        center: [1.0, 0.0, 0.0],
        radius: 0.5,
    };
    let mut options = MatchOptions::DEFAULT;
    options.descriptor = DescriptorKind::Curvature;
    (scene, selection, options)
}

#[test]
fn the_curvature_descriptor_counts_its_surface_steps_then_its_vertices_to_the_end() {
    let (scene, selection, options) = curvature_on_a_sphere();
    let mut recorder = Recorder::default();
    search(&scene, &selection, &options, &mut recorder).unwrap();
    counts_up_to_the_end(&recorder.seen, Progress::SURFACE);
    counts_up_to_the_end(&recorder.seen, Progress::CANDIDATES);
    let last_surface = recorder
        .seen
        .iter()
        .rposition(|p| p.step == Progress::SURFACE);
    let first_vertex = recorder
        .seen
        .iter()
        .position(|p| p.step == Progress::CANDIDATES);
    assert!(last_surface < first_vertex, "{:?}", recorder.seen);
}

#[test]
fn a_break_while_the_surface_is_built_cancels_and_the_next_search_builds_it() {
    let (scene, selection, options) = curvature_on_a_sphere();
    let mut stopped = Recorder {
        stop_at: Some(2),
        ..Recorder::default()
    };
    let e = search(&scene, &selection, &options, &mut stopped).unwrap_err();
    assert!(matches!(e, Error::Cancelled), "{e:?}");
    assert!(
        stopped.seen.iter().all(|p| p.step == Progress::SURFACE) && stopped.seen.len() == 2,
        "{:?}",
        stopped.seen
    );
    let mut recorder = Recorder::default();
    let report = search(&scene, &selection, &options, &mut recorder).unwrap();
    assert!(!report.instances.is_empty());
    counts_up_to_the_end(&recorder.seen, Progress::SURFACE);
}

#[test]
fn a_break_from_progress_cancels_the_search() {
    let (scene, template) = demo();
    let mut recorder = Recorder {
        stop_at: Some(1),
        ..Recorder::default()
    };
    let e = search(&scene, &template, &MatchOptions::DEFAULT, &mut recorder).unwrap_err();
    assert!(matches!(e, Error::Cancelled), "{e:?}");
    assert_eq!(recorder.seen.len(), 1);
}

#[test]
fn preparing_a_scene_counts_its_steps_and_a_break_there_cancels_it() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/demo");
    let mesh = load(&std::fs::read(format!("{dir}/scene.glb")).unwrap(), None).unwrap();
    let mut recorder = Recorder::default();
    let scene = Scene::new_observed(mesh.clone(), &SceneOptions::DEFAULT, &mut recorder).unwrap();
    counts_up_to_the_end(&recorder.seen, Progress::SCENE);
    assert_eq!(recorder.seen.len(), Scene::BUILD_STEPS);
    assert_eq!(
        scene.parts().len(),
        Scene::new(mesh.clone(), &SceneOptions::DEFAULT)
            .unwrap()
            .parts()
            .len()
    );
    for stop_at in 1..=Scene::BUILD_STEPS {
        let mut stopping = Recorder {
            stop_at: Some(stop_at),
            ..Recorder::default()
        };
        let cancelled = Scene::new_observed(mesh.clone(), &SceneOptions::DEFAULT, &mut stopping);
        assert!(
            matches!(cancelled, Err(Error::Cancelled)),
            "break at step {stop_at}"
        );
        assert_eq!(stopping.seen.len(), stop_at);
    }
}
