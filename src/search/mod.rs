//! The whole search: template, cascade, verification, grouping, with
//! timings. Two pipelines share the cascade: the voxel one (`voxel/`: volume
//! and harmonics on the scene's skin voxels) and the curvature one
//! (`curvature.rs`: on the welded mesh's vertices).

mod curvature;
mod report;
mod voxel;

pub use crate::options::{DescriptorKind, MatchOptions};
pub use report::{GpuInfo, GridInfo, MatchReport, SurfaceInfo, TemplateInfo, Timings};

use crate::cascade::Observer;
use crate::descriptor::LayerDevice;
use crate::error::Result;
use crate::scene::Scene;
use crate::template::TemplateSource;

/// Searches `scene` for every occurrence of `source`.
pub fn search(
    scene: &Scene,
    source: &TemplateSource,
    options: &MatchOptions,
    observer: &mut dyn Observer,
) -> Result<MatchReport> {
    // With no batch, nothing waits.
    crate::cascade::finished(search_with(scene, source, options, observer, None))
}

/// Either search, with the voxel layers on `device` where one is given.
async fn search_with(
    scene: &Scene,
    source: &TemplateSource,
    options: &MatchOptions,
    observer: &mut dyn Observer,
    device: Option<&dyn LayerDevice>,
) -> Result<MatchReport> {
    options.validate()?;
    if options.descriptor == DescriptorKind::Curvature {
        return curvature::search_curvature(scene, source, options, observer);
    }
    voxel::search_voxels(scene, source, options, observer, device).await
}

/// [`search`] with the volume and harmonics layers computed on `gpu`:
/// the same instances (see `descriptor::harmonics` on the guard band).
/// The report's `gpu` says which adapter ran and whether layers went back
/// to the CPU; the curvature descriptor runs on the CPU. Blocks while the
/// GPU works.
#[cfg(all(feature = "gpu", not(target_arch = "wasm32")))]
pub fn search_on_gpu(
    scene: &Scene,
    source: &TemplateSource,
    options: &MatchOptions,
    observer: &mut dyn Observer,
    gpu: &crate::gpu::Gpu,
) -> Result<MatchReport> {
    pollster::block_on(search_on_gpu_async(scene, source, options, observer, gpu))
}

/// [`search_on_gpu`] without blocking: the form a browser needs, where the
/// GPU's results arrive on the event loop.
#[cfg(feature = "gpu")]
pub async fn search_on_gpu_async(
    scene: &Scene,
    source: &TemplateSource,
    options: &MatchOptions,
    observer: &mut dyn Observer,
    gpu: &crate::gpu::Gpu,
) -> Result<MatchReport> {
    search_with(scene, source, options, observer, Some(gpu)).await
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
