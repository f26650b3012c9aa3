//! The curvature pipeline: the scene's welded mesh, its vertices as
//! candidates, the mirror test, then grouping.

use super::options::MatchOptions;
use super::report::{MatchReport, SurfaceInfo, TemplateInfo, Timings};
use crate::budget::{candidate_bytes, mesh_bytes, surface_bytes};
use crate::cascade::{Observer, finished, run_cascade};
use crate::clock::now_ms;
use crate::descriptor::CurvatureDescriptor;
use crate::descriptor::curvature::{CoverDescriptor, Covers, MirrorTest};
use crate::error::MemoryEstimate;
use crate::error::Result;
use crate::instances::{Verified, group, local_bests};
use crate::scene::Scene;
use crate::template::{CurvatureTemplate, TemplateSource};

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
    let reach = options.curvature_spacing * radii[0];
    let covers = (reach > 0.0).then(|| Covers::new(surface, reach));
    let bound = covers.as_ref().and_then(|covers| {
        CoverDescriptor::new(
            surface,
            covers,
            radii,
            &gaussians,
            options.curvature_threshold,
        )
    });
    let (survivors, stats) = match (&covers, bound) {
        (Some(covers), Some(bound)) => {
            let groups = (0..covers.len() as u32).collect();
            let (near, mut stats) = finished(run_cascade(
                &[&bound],
                groups,
                1,
                options.backend,
                None,
                observer,
            ))?;
            let mut candidates: Vec<u32> = near
                .iter()
                .flat_map(|g| covers.members(g.point).iter().copied())
                .collect();
            candidates.sort_unstable();
            let (survivors, exact) = finished(run_cascade(
                &[&curvature],
                candidates,
                1,
                options.backend,
                None,
                observer,
            ))?;
            stats.extend(exact);
            (survivors, stats)
        }
        _ => {
            let every = surface.used_vertices().collect();
            finished(run_cascade(
                &[&curvature],
                every,
                1,
                options.backend,
                None,
                observer,
            ))?
        }
    };
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
