//! The curvature pipeline: the scene's welded mesh, its vertices as
//! candidates, the mirror test, then grouping.

use super::report::{MatchReport, SurfaceInfo, TemplateInfo, Timings};
use crate::budget::{candidate_bytes, mesh_bytes, surface_bytes};
use crate::cascade::{LayerStats, Observer, Survivor, run_cascade_in_chunks};
use crate::clock::now_ms;
use crate::descriptor::CurvatureDescriptor;
use crate::descriptor::curvature::{MirrorTest, SAMPLE_REACH, SAMPLE_SLACK, Surface, VertexSample};
use crate::error::MemoryEstimate;
use crate::error::Result;
use crate::instances::{Verified, group, local_bests};
use crate::math::Vec3;
use crate::options::MatchOptions;
use crate::scene::Scene;
use crate::template::{CurvatureTemplate, TemplateSource};

/// Candidates a thread takes through every layer at a time: few enough
/// that their neighbourhoods (a fanned cap's vertex holds thousands of
/// triangles) stay within megabytes.
const CHUNK: usize = 256;

/// The curvature search: candidates are the scene's welded vertices;
/// the best survivor of each blob must turn the same way as the template
/// ([`MirrorTest`]), then survivors are grouped. There is no voxel
/// verification: the shapes this descriptor is for are bent, so a rigid
/// placement would not fit them.
pub(super) fn search_curvature(
    scene: &Scene,
    source: &TemplateSource,
    options: &MatchOptions,
    observer: &mut dyn Observer,
) -> Result<MatchReport> {
    check_surface_search(scene, source)?;
    let surface = scene.surface();
    let t0 = now_ms();
    let template = CurvatureTemplate::new(source, scene, options.layers)?;
    let radii = template.radii();
    let template_surface = template.surface(scene);
    let template_layers =
        CurvatureDescriptor::layers_at(template_surface, template.vertex(), radii);
    let mirror_test = MirrorTest::new(
        template_surface.vertex_normal(template.vertex()),
        &template_layers,
        radii,
    );
    let gaussians: Vec<f64> = template_layers.iter().map(|l| l.gaussian).collect();
    let curvature =
        CurvatureDescriptor::new(surface, radii, &gaussians, options.curvature_threshold);
    let t1 = now_ms();
    let (survivors, stats) = cascade(surface, radii, &curvature, &gaussians, options, observer)?;
    let t2 = now_ms();
    let position = |v| surface.position(v);
    let bests: Vec<Verified> = local_bests(&survivors, position, radii[0])
        .into_iter()
        .filter(|s| {
            mirror_test.passes(
                surface.vertex_normal(s.point),
                &CurvatureDescriptor::layers_at(surface, s.point, radii),
            )
        })
        .map(|s| Verified {
            survivor: s,
            score: 1.0,
            position: position(s.point),
            pose: None,
        })
        .collect();
    let mut instances = group(
        &bests,
        &survivors,
        position,
        options.group_radius * template.radius(),
    );
    for i in &mut instances {
        i.score = None;
    }
    let timings = Timings::of_search(0.0, scene.surface_ms(), [t0, t1, t2, now_ms()]);
    Ok(MatchReport {
        template: TemplateInfo::of(template.center(), template.radius()),
        instances,
        stages: stats,
        grid: None,
        surface: Some(SurfaceInfo {
            vertices: surface.vertex_count(),
            triangles: surface.triangles().len(),
        }),
        gpu: None,
        timings,
    })
}

/// The survivors of the `curvature` layers over the surface's vertices,
/// and each layer's figures. On a surface dense enough, a sample of its
/// vertices goes through looser layers first, and only the vertices near
/// the sample's survivors are candidates.
fn cascade(
    surface: &Surface,
    radii: &[f64],
    curvature: &CurvatureDescriptor<'_>,
    gaussians: &[f64],
    options: &MatchOptions,
    observer: &mut dyn Observer,
) -> Result<(Vec<Survivor>, Vec<LayerStats>)> {
    let spacing = options.curvature_spacing * radii[0];
    let Some(sample) = VertexSample::of(surface, spacing) else {
        let every = surface.used_vertices().collect();
        return run_cascade_in_chunks(&[curvature], every, CHUNK, 1, options.backend, observer);
    };
    let loose = CurvatureDescriptor::new(
        surface,
        radii,
        gaussians,
        options.curvature_threshold * SAMPLE_SLACK,
    )
    .named("curvature-sample");
    let (near, mut stats) = run_cascade_in_chunks(
        &[&loose],
        sample.vertices,
        CHUNK,
        1,
        options.backend,
        observer,
    )?;
    let points: Vec<Vec3> = near.iter().map(|s| surface.position(s.point)).collect();
    let candidates = sample.grid.within(surface, &points, SAMPLE_REACH * spacing);
    let (survivors, exact) = run_cascade_in_chunks(
        &[curvature],
        candidates,
        CHUNK,
        1,
        options.backend,
        observer,
    )?;
    stats.extend(exact);
    Ok((survivors, stats))
}

/// Checks, before the welded surfaces are built, that a curvature search
/// fits the scene's memory budget.
fn check_surface_search(scene: &Scene, source: &TemplateSource) -> Result<()> {
    let mesh = scene.mesh();
    let mut estimate = MemoryEstimate::new();
    estimate
        .add(
            "the mesh",
            mesh_bytes(mesh.positions().len(), mesh.triangles().len()),
        )
        .add("welded surface", surface_bytes(mesh.triangles().len()))
        .add("candidate state", candidate_bytes(mesh.positions().len()));
    if let TemplateSource::Model(model) = source {
        estimate
            .add(
                "the template's mesh",
                mesh_bytes(model.positions().len(), model.triangles().len()),
            )
            .add("welded surface", surface_bytes(model.triangles().len()));
    }
    estimate.check(scene.memory_budget(), || {
        format!(
            "the scene has {} triangles: simplify the mesh, or raise the memory budget",
            mesh.triangles().len()
        )
    })
}
