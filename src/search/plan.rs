//! What a search will take, told before it runs, so that a caller can ask
//! before starting one that would run for minutes (a sphere dropped on a
//! whole building by mistake). The plan does the search's cheap first
//! steps, the template's grid and which parts can hold a copy and which
//! copy one another, and judges the rest from the parts' areas.

use crate::error::Result;
use crate::options::{DescriptorKind, MatchOptions};
use crate::scene::Scene;
use crate::template::TemplateSource;

/// A voxel search's work, judged before it runs.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct SearchPlan {
    /// The scene's parts large enough to hold a copy.
    pub parts: usize,
    /// Of those, the ones searched: the others are rigid copies of one of
    /// them and take its instances, moved.
    pub distinct_parts: usize,
    /// The skin voxels of the distinct parts, estimated from their area.
    pub skin_voxels: f64,
    /// The least work the search takes, in about nanoseconds of one core
    /// (the unit of [`MatchOptions::max_part_work`]): its skin voxels
    /// built. Parts like the template take several times more.
    pub least_work: f64,
    /// The threads the search runs on ([`MatchOptions::backend`]).
    pub threads: usize,
    /// The least work shared by the threads, in seconds: about the least
    /// wall time the search takes (the work's nanoseconds are those of the
    /// machine that weighed it; natively here, a search of distinct parts
    /// unlike the template took 0.6-0.9 of it, under WebAssembly more).
    pub least_seconds: f64,
    /// Whether the search is refused for its work even at the least
    /// (`max_part_work`).
    pub over_limit: bool,
}

/// What searching `scene` for `source` will take, judged without running
/// it; `None` for the curvature descriptor, whose work is the welded
/// surface's vertices, known once the scene is loaded.
pub fn plan(
    scene: &Scene,
    source: &TemplateSource,
    options: &MatchOptions,
) -> Result<Option<SearchPlan>> {
    options.validate()?;
    if options.descriptor == DescriptorKind::Curvature {
        return Ok(None);
    }
    super::voxel::plan_voxels(scene, source, options).map(Some)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cascade::{LayerStats, Observer, Progress};
    use crate::math::Vec3;
    use crate::mesh::TriMesh;
    use crate::mesh::shapes::{cuboid, torus, uv_sphere};
    use crate::scene::SceneOptions;
    use crate::search::search;
    use std::ops::ControlFlow;

    /// The count of parts the search reports it will search.
    struct PartsTotal(Option<usize>);

    impl Observer for PartsTotal {
        fn on_layer(&mut self, _: &LayerStats) -> ControlFlow<()> {
            ControlFlow::Continue(())
        }
        fn on_progress(&mut self, progress: &Progress) -> ControlFlow<()> {
            if progress.step == Progress::PARTS {
                self.0 = Some(progress.total);
            }
            ControlFlow::Continue(())
        }
    }

    fn ring(at: Vec3) -> TriMesh {
        torus(at, 1.0, 0.3, 48, 16)
    }

    /// Three rings (two of them copies), boxes and a ball, none touching.
    fn scene() -> Scene {
        let mut mesh = ring(Vec3::ZERO);
        for part in [
            ring(Vec3::new(6.0, 0.0, 0.0)),
            ring(Vec3::new(0.0, 6.0, 0.0)),
            cuboid(Vec3::new(-7.0, -6.0, 0.0), Vec3::new(-4.5, -5.0, 0.5)),
            cuboid(Vec3::new(6.0, 6.0, 0.0), Vec3::new(8.5, 6.4, 1.9)),
            uv_sphere(Vec3::new(-6.0, 6.0, 0.0), 1.2, 24, 32),
            // Too small to hold a ring.
            cuboid(Vec3::new(0.0, -6.0, 0.0), Vec3::new(0.1, -5.9, 0.1)),
        ] {
            mesh.append(&part);
        }
        Scene::new(mesh, &SceneOptions::DEFAULT).unwrap()
    }

    #[test]
    fn the_plan_names_the_parts_the_search_searches_and_bounds_its_skin() {
        let scene = scene();
        let source = TemplateSource::Model(ring(Vec3::new(40.0, 0.0, 0.0)));
        let options = MatchOptions::DEFAULT;
        let plan = plan(&scene, &source, &options).unwrap().unwrap();
        // Six parts can hold a ring; the two copies of the first are not
        // searched on their own.
        assert_eq!(plan.parts, 6, "{plan:?}");
        assert_eq!(plan.distinct_parts, 4, "{plan:?}");
        let mut told = PartsTotal(None);
        let report = search(&scene, &source, &options, &mut told).unwrap();
        assert_eq!(report.instances.len(), 3);
        assert_eq!(told.0, Some(plan.distinct_parts));
        // The skin the search built, against the plan's least.
        let built = report.grid.unwrap().skin_voxels as f64;
        assert!(
            plan.skin_voxels <= built && plan.skin_voxels >= 0.4 * built,
            "planned {} built {built}",
            plan.skin_voxels
        );
        assert!(plan.least_work > 0.0 && !plan.over_limit);
        let tight = MatchOptions {
            max_part_work: plan.least_work / 2.0,
            ..options
        };
        assert!(
            super::plan(&scene, &source, &tight)
                .unwrap()
                .unwrap()
                .over_limit
        );
    }

    #[test]
    fn a_curvature_search_has_no_plan() {
        let options = MatchOptions {
            descriptor: DescriptorKind::Curvature,
            ..MatchOptions::DEFAULT
        };
        let source = TemplateSource::Model(ring(Vec3::ZERO));
        assert_eq!(plan(&scene(), &source, &options).unwrap(), None);
    }
}
