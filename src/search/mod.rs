//! The whole search: template, cascade, verification, grouping, with
//! timings. Two pipelines share the cascade: the voxel one (`voxel/`: volume
//! and harmonics on the scene's skin voxels) and the curvature one
//! (`curvature.rs`: on the welded mesh's vertices).

mod curvature;
mod plan;
mod report;
mod voxel;

pub use crate::options::{DescriptorKind, MatchOptions};
pub use plan::{SearchPlan, plan};
pub use report::{GpuInfo, GridInfo, MatchReport, SurfaceInfo, TemplateInfo, Timings};

use crate::cascade::Observer;
use crate::descriptor::LayerDevice;
use crate::error::Result;
use crate::scene::Scene;
use crate::template::TemplateSource;

/// Where the volume and harmonics layers run. The search never names the
/// GPU: a device takes a batch of layers per grid and owns its waves and
/// its retries; the curvature descriptor runs on the threads either way.
#[derive(Clone, Copy, Default)]
pub enum Executor<'d> {
    /// On this process's threads, serial or parallel as
    /// [`MatchOptions::backend`] says.
    #[default]
    Threads,
    /// Batched on a device, such as `gpu::Gpu` (feature `gpu`):
    /// the same instances (see `descriptor::harmonics` on the guard band),
    /// and the report's `gpu` says which adapter ran and whether layers
    /// went back to the CPU.
    Device(&'d dyn LayerDevice),
}

/// Searches `scene` for every occurrence of `source` on this process's
/// threads: [`search_on`] with [`Executor::Threads`], which never waits.
pub fn search(
    scene: &Scene,
    source: &TemplateSource,
    options: &MatchOptions,
    observer: &mut dyn Observer,
) -> Result<MatchReport> {
    crate::cascade::finished(search_on(
        Executor::Threads,
        scene,
        source,
        options,
        observer,
    ))
}

/// Searches `scene` for every occurrence of `source`, with the volume and
/// harmonics layers on `executor`. A device's results arrive when it has
/// them: natively, block on the future (pollster); in a browser, await it
/// on the event loop.
pub async fn search_on(
    executor: Executor<'_>,
    scene: &Scene,
    source: &TemplateSource,
    options: &MatchOptions,
    observer: &mut dyn Observer,
) -> Result<MatchReport> {
    options.validate()?;
    if options.descriptor == DescriptorKind::Curvature {
        return curvature::search_curvature(scene, source, options, observer);
    }
    let device = match executor {
        Executor::Threads => None,
        Executor::Device(device) => Some(device),
    };
    voxel::search_voxels(scene, source, options, observer, device).await
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::now_ms;
    use crate::mesh::io::load;
    use crate::scene::SceneOptions;

    fn demo(name: &str) -> crate::mesh::TriMesh {
        let path = format!("{}/assets/demo/{name}.glb", env!("CARGO_MANIFEST_DIR"));
        load(&std::fs::read(path).unwrap(), None).unwrap()
    }

    #[test]
    fn the_total_is_wall_clock_time_when_stages_overlap() {
        // A separate model is voxelized beside the scene: the two stages'
        // times add up to more than the time they took together.
        let scene = Scene::new(demo("scene"), &SceneOptions::DEFAULT).unwrap();
        let template = TemplateSource::Model(demo("template"));
        let start = now_ms();
        let report = search(&scene, &template, &MatchOptions::DEFAULT, &mut ()).unwrap();
        let wall = now_ms() - start;
        let t = &report.timings;
        assert!(t.total() <= wall + 0.1, "{t:?} over {wall} ms");
        let (busiest, rest) = (t.voxelize.max(t.template), t.match_ + t.group);
        assert!(t.total() >= busiest + rest - 0.1, "{t:?}");
    }
}
