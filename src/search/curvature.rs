//! The curvature pipeline: the scene's welded mesh, its vertices as
//! candidates, the mirror test, then grouping.

use super::report::{MatchReport, SurfaceInfo, TemplateInfo, Timings};
use crate::budget::Item;
use crate::cascade::candidate_bytes;
use crate::cascade::{LayerStats, Observer, Progress, Survivor, run_cascade_in_chunks};
use crate::clock::now_ms;
use crate::descriptor::CurvatureDescriptor;
use crate::descriptor::curvature::surface_bytes;
use crate::descriptor::curvature::{MirrorTest, SAMPLE_REACH, SAMPLE_SLACK, Surface, VertexSample};
use crate::error::{Error, Result};
use crate::exec::Threads;
use crate::instances::{Verified, group, local_bests};
use crate::math::Vec3;
use crate::mesh::mesh_bytes;
use crate::options::MatchOptions;
use crate::scene::Scene;
use crate::template::{CurvatureTemplate, TemplateSource};
use std::ops::ControlFlow;

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
    // Seconds on a mesh of millions of triangles: reported, and stoppable.
    let surface = scene
        .surface_observed(&mut |done| {
            observer.on_progress(&Progress {
                step: Progress::SURFACE,
                done,
                total: Surface::BUILD_STEPS,
            })
        })
        .ok_or(Error::Cancelled)?;
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
        None,
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
    let limit = options.max_curvature_work;
    let spacing = options.curvature_spacing * radii[0];
    let Some(sample) = VertexSample::of(surface, spacing) else {
        let every: Vec<u32> = surface.used_vertices().collect();
        check_projected_work(curvature, &every, limit, options.backend)?;
        return run_within(curvature, &[curvature], every, limit, options, observer);
    };
    let loose = CurvatureDescriptor::new(
        surface,
        radii,
        gaussians,
        options.curvature_threshold * SAMPLE_SLACK,
    )
    .named("curvature-sample");
    check_projected_work(&loose, &sample.vertices, limit, options.backend)?;
    let (near, mut stats) =
        run_within(&loose, &[&loose], sample.vertices, limit, options, observer)?;
    let points: Vec<Vec3> = near.iter().map(|s| surface.position(s.point)).collect();
    let candidates = sample.grid.within(surface, &points, SAMPLE_REACH * spacing);
    let counted = [&loose, curvature];
    let (survivors, exact) = run_within(curvature, &counted, candidates, limit, options, observer)?;
    stats.extend(exact);
    Ok((survivors, stats))
}

/// Candidates the work estimate takes through the layers: spread evenly
/// over the list, enough that a few costly vertices (a fan's hub) do not
/// decide it, and about 1% of a mesh large enough to need the estimate.
const WORK_SAMPLE: usize = 512;

/// Refuses, before the pass, a pass of `descriptor` over `candidates`
/// whose work, projected from a sample of them, passes `limit`: a fanned
/// mesh is refused in a second rather than after the limit's worth of
/// work. A mesh too small for a sample to say much is left to the limit.
fn check_projected_work(
    descriptor: &CurvatureDescriptor<'_>,
    candidates: &[u32],
    limit: f64,
    backend: Threads,
) -> Result<()> {
    if candidates.len() < 4 * WORK_SAMPLE {
        return Ok(());
    }
    let sample: Vec<u32> = candidates
        .iter()
        .step_by(candidates.len() / WORK_SAMPLE)
        .copied()
        .collect();
    let scale = candidates.len() as f64 / sample.len() as f64;
    let probe = descriptor.fresh();
    let (_, stats) = run_cascade_in_chunks(&[&probe], sample, CHUNK, 1, backend, &mut ())?;
    let work = probe.work() as f64 * scale;
    let balls = stats.iter().map(|s| s.candidates).sum::<usize>() as f64 * scale;
    if work > limit {
        return Err(too_much_work(work, balls, limit));
    }
    Ok(())
}

/// Runs `descriptor`'s pass over `candidates`, stopping once the
/// descriptors `counted` (this pass's and those before it) have measured
/// more than `limit` triangles together. Checked between rounds of
/// candidates, which are the same on any thread count: whether a search
/// stops depends on the scene and the options only.
fn run_within(
    descriptor: &CurvatureDescriptor<'_>,
    counted: &[&CurvatureDescriptor<'_>],
    candidates: Vec<u32>,
    limit: f64,
    options: &MatchOptions,
    observer: &mut dyn Observer,
) -> Result<(Vec<Survivor>, Vec<LayerStats>)> {
    let mut limited = WorkLimit {
        observer,
        counted,
        limit,
        balls: 0,
        over: false,
    };
    let run = run_cascade_in_chunks(
        &[descriptor],
        candidates,
        CHUNK,
        1,
        options.backend,
        &mut limited,
    );
    match run {
        Err(Error::Cancelled) if limited.over => {
            Err(too_much_work(limited.work(), limited.balls as f64, limit))
        }
        other => other,
    }
}

/// An observer that passes everything on, and stops the cascade once the
/// descriptors it counts have passed the work limit.
struct WorkLimit<'a, 'd> {
    observer: &'a mut dyn Observer,
    counted: &'a [&'a CurvatureDescriptor<'d>],
    limit: f64,
    /// Candidates taken through a layer, layer by layer, so far.
    balls: usize,
    over: bool,
}

impl WorkLimit<'_, '_> {
    fn work(&self) -> f64 {
        self.counted.iter().map(|d| d.work() as f64).sum()
    }
}

impl Observer for WorkLimit<'_, '_> {
    fn on_layer(&mut self, stats: &LayerStats) -> ControlFlow<()> {
        self.balls += stats.candidates;
        self.observer.on_layer(stats)
    }

    fn on_progress(&mut self, progress: &Progress) -> ControlFlow<()> {
        if self.work() > self.limit {
            self.over = true;
            return ControlFlow::Break(());
        }
        self.observer.on_progress(progress)
    }
}

/// The error for `work` triangles measured over `balls` candidate layers.
fn too_much_work(work: f64, balls: f64, limit: f64) -> Error {
    Error::CurvatureTooMuchWork {
        work,
        per_ball: work / balls.max(1.0),
        limit,
        advice: "simplify or remesh the scene (slivers and fans put thousands of triangles in \
                 every ball), or search with the volume descriptor, whose work does not grow \
                 with the triangles"
            .into(),
    }
}

/// Checks, before the welded surfaces are built, that a curvature search
/// fits the scene's memory budget.
fn check_surface_search(scene: &Scene, source: &TemplateSource) -> Result<()> {
    let mesh = scene.mesh();
    let mut held = scene.budget();
    held.reserve(
        Item::Surface {
            triangles: mesh.triangles().len(),
        },
        surface_bytes(mesh.triangles().len()),
    )?
    .reserve(
        Item::SurfaceCandidates {
            vertices: mesh.positions().len(),
        },
        candidate_bytes(mesh.positions().len()),
    )?;
    if let TemplateSource::Model(model) = source {
        held.reserve(
            Item::TemplateMesh {
                triangles: model.triangles().len(),
            },
            mesh_bytes(model.positions().len(), model.triangles().len()),
        )?
        .reserve(
            Item::Surface {
                triangles: model.triangles().len(),
            },
            surface_bytes(model.triangles().len()),
        )?;
    }
    Ok(())
}
