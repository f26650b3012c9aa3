//! The voxel pipeline: the scene's solid and skin voxels, a template with
//! its own grid or a selection of the scene's, the volume and harmonics
//! stages, then verification by placement and grouping.

use super::options::{DescriptorKind, MatchOptions};
use super::report::{GridInfo, MatchReport, TemplateInfo, Timings};
use crate::budget::{ball_bytes, candidate_bytes, voxel_bytes};
use crate::cascade::{Observer, Stage, run_cascade};
use crate::clock::now_ms;
use crate::descriptor::harmonics::ClutterGuard;
use crate::descriptor::volume::BLOCKS_PER_RADIUS;
use crate::descriptor::{HarmonicsDescriptor, SphericalTransform, VolumeDescriptor};
use crate::error::Result;
use crate::instances::{Verified, group, local_bests, placement_transform};
use crate::scene::Scene;
use crate::template::{TemplateSource, VoxelTemplate};
use crate::verify::{Verifier, moment_level};
use crate::voxel::level_for_radius;

/// Searches `scene`'s skin voxels for `source` with the voxel descriptors.
pub(super) fn search_voxels(
    scene: &Scene,
    source: &TemplateSource,
    options: &MatchOptions,
    observer: &mut dyn Observer,
) -> Result<MatchReport> {
    let build_template = || {
        let start = now_ms();
        let template = VoxelTemplate::new(source, scene, options.layers, options.backend);
        (template, now_ms() - start)
    };
    let fresh = !scene.is_voxelized();
    let t0 = now_ms();
    let (template, template_ms) = match source {
        // A separate model has its own grid, sharing only the voxel size:
        // it is built beside the scene's, and each fills the other's serial
        // parts (finding shells, for one).
        TemplateSource::Model(_) => options.backend.join(|| scene.solid(), build_template).1,
        // A selection reads the scene's voxels.
        TemplateSource::Selection { .. } => {
            scene.solid();
            build_template()
        }
    };
    let joined = now_ms();
    // The time voxelization and the template shared, counted once in the
    // total.
    let shared = if fresh {
        (scene.voxelize_ms() + template_ms - (joined - t0)).max(0.0)
    } else {
        0.0
    };
    let template = template?;
    let radii = template.radii();
    check_voxel_search(scene, &template)?;
    let (tsolid, tvoxel, backend) = (template.solid(scene), template.voxel(), options.backend);
    let transform = SphericalTransform::new();
    // The balls' tables are built once: read at the template's one point,
    // then bound to the scene's layout.
    let balls = VolumeDescriptor::unbound_balls(radii, scene.voxel_size(), backend);
    let template_volume = VolumeDescriptor::describe_with(tsolid, tvoxel, &balls, backend);
    let volume = VolumeDescriptor::with_balls(
        scene.solid(),
        scene.skin(),
        radii,
        balls
            .into_iter()
            .map(|b| b.bind(scene.solid(), backend))
            .collect(),
        template_volume,
        options.volume_threshold,
    )
    .with_clutter(options.clutter);
    let harmonics = match options.descriptor {
        DescriptorKind::Volume => None,
        _ => Some(
            HarmonicsDescriptor::new(
                scene.solid(),
                scene.skin(),
                &transform,
                radii,
                HarmonicsDescriptor::describe(tsolid, tvoxel, radii, &transform, backend),
                options.harmonics_threshold,
                backend,
            )
            .with_clutter(ClutterGuard {
                policy: options.clutter,
                balls: volume.balls(),
                template: volume.template(),
            }),
        ),
    };
    let mut stages: Vec<&dyn Stage> = Vec::new();
    if options.descriptor != DescriptorKind::Harmonics {
        stages.push(&volume);
    }
    if let Some(h) = &harmonics {
        stages.push(h);
    }
    let t1 = now_ms();
    let candidates = (0..scene.skin().len() as u32).collect();
    let (survivors, stats) = run_cascade(&stages, candidates, options.backend, observer)?;
    let t2 = now_ms();
    let position = |p| scene.position(p);
    let bests = local_bests(&survivors, position, radii[0]);
    let voxel = scene.voxel_size();
    let radii_voxels: Vec<f64> = radii.iter().map(|r| r / voxel).collect();
    let verifier = Verifier::new(
        tsolid,
        template.skin(scene),
        tvoxel,
        template.center_offset(scene),
        &radii_voxels,
        options.hidden_surface_for(matches!(source, TemplateSource::Selection { .. })),
        backend,
    );
    let verified: Vec<Verified> = backend
        .map_each(bests.len(), |i| {
            let v = scene.skin()[bests[i].point as usize];
            let placement = verifier.check(scene.solid(), scene.near_surface(), v);
            let position = scene.position(bests[i].point) + placement.offset * voxel;
            Verified {
                survivor: bests[i],
                score: placement.score(),
                position,
                transform: Some(placement_transform(
                    &placement.rotation,
                    template.center(),
                    position,
                )),
            }
        })
        .into_iter()
        .filter(|v| v.score >= options.verify_threshold)
        .collect();
    let instances = group(
        &verified,
        &survivors,
        position,
        options.group_radius * template.radius(),
    );
    let timings = Timings {
        shared,
        ..Timings::of_search(
            scene.voxelize_ms(),
            0.0,
            [joined - template_ms, t1, t2, now_ms()],
        )
    };
    Ok(MatchReport {
        template: TemplateInfo::of(template.center(), template.radius()),
        instances,
        stages: stats,
        grid: Some(GridInfo {
            resolution: scene.resolution(),
            voxel_size: scene.voxel_size(),
            skin_voxels: scene.skin().len(),
        }),
        surface: None,
        timings,
    })
}

/// Checks, before any ball table is built, that a voxel search fits the
/// scene's memory budget: the scene's grids, a model template's own, the
/// run tables of the volume and verification balls and the cascade's state.
fn check_voxel_search(scene: &Scene, template: &VoxelTemplate) -> Result<()> {
    let voxel = scene.voxel_size();
    let mut estimate = scene.voxel_estimate();
    let tsolid = template.solid(scene);
    if !std::ptr::eq(tsolid, scene.solid()) {
        estimate.add(
            "the template's voxel grids",
            voxel_bytes(tsolid.bits().spec()),
        );
    }
    let radii: Vec<f64> = template.radii().iter().map(|r| r / voxel).collect();
    for &r in &radii {
        estimate.add(
            "ball tables",
            ball_bytes(r, level_for_radius(r, BLOCKS_PER_RADIUS)),
        );
        estimate.add("ball tables", ball_bytes(r, moment_level(r)));
    }
    estimate.add("candidate state", candidate_bytes(scene.skin().len()));
    estimate.check(scene.memory_budget(), || {
        let outer = radii.last().copied().unwrap_or_default();
        match estimate.largest() {
            Some(("candidate state", _)) => format!(
                "the scene has {} candidate points (skin voxels) at resolution {}: lower the resolution (they fall with its square), or raise the memory budget",
                scene.skin().len(),
                scene.resolution()
            ),
            _ => format!(
                "the template's outer radius is {outer:.0} voxels at resolution {}: lower the resolution, pick a smaller template, or raise the memory budget",
                scene.resolution()
            ),
        }
    })
}
