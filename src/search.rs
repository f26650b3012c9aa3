//! The whole search: template, cascade, grouping, with timings.

use std::fmt;
use std::str::FromStr;

use crate::budget::{
    MemoryEstimate, ball_bytes, candidate_bytes, mesh_bytes, surface_bytes, voxel_bytes,
};
use crate::cascade::{LayerStats, Observer, Stage, run_cascade};
use crate::clock::now_ms;
use crate::descriptor::curvature::{MirrorTest, SAMPLE_REACH, SAMPLE_SLACK, VertexSample};
use crate::descriptor::harmonics::ClutterGuard;
use crate::descriptor::volume::BLOCKS_PER_RADIUS;
use crate::descriptor::{
    ClutterPolicy, CurvatureDescriptor, HarmonicsDescriptor, SphericalTransform, VolumeDescriptor,
};
use crate::error::{Error, Result};
use crate::exec::Backend;
use crate::instances::{Instance, Verified, group, local_bests};
use crate::math::Vec3;
use crate::scene::Scene;
use crate::template::{SurfaceTemplate, Template, TemplateSource};
use crate::verify::{Verifier, moment_level};
use crate::voxel::level_for_radius;

/// Which descriptors the cascade runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DescriptorKind {
    /// The volume prefilter, then the spherical harmonics (the paper's SHD).
    #[default]
    VolumeHarmonics,
    /// The volume descriptor alone.
    Volume,
    /// The spherical harmonics alone.
    Harmonics,
    /// Gaussian curvature on the mesh (paper, sec. 4.3): for shapes bent
    /// out of their rigid pose.
    Curvature,
}

impl DescriptorKind {
    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            DescriptorKind::VolumeHarmonics => "volume+harmonics",
            DescriptorKind::Volume => "volume",
            DescriptorKind::Harmonics => "harmonics",
            DescriptorKind::Curvature => "curvature",
        }
    }
}

impl fmt::Display for DescriptorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for DescriptorKind {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "volume+harmonics" => Ok(DescriptorKind::VolumeHarmonics),
            "volume" => Ok(DescriptorKind::Volume),
            "harmonics" => Ok(DescriptorKind::Harmonics),
            "curvature" => Ok(DescriptorKind::Curvature),
            _ => Err(Error::invalid_option(
                "descriptor",
                format!("'{s}' is not one of volume+harmonics, volume, harmonics, curvature"),
            )),
        }
    }
}

/// How to search.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct MatchOptions {
    /// The descriptor chain. Default: volume+harmonics.
    pub descriptor: DescriptorKind,
    /// Number of radii k. Default: 6 (the paper's).
    pub layers: usize,
    /// Volume stage: bound on the sum of fraction differences. Default: 0.12
    /// (the paper's epsilon').
    pub volume_threshold: f64,
    /// Harmonics stage: bound on the normalized distance, in voxels of
    /// equivalent deviation (see [`crate::descriptor::harmonics`]).
    /// Default: 0.8.
    pub harmonics_threshold: f64,
    /// Curvature stage: bound on the sum of squared differences of the
    /// Gaussian curvatures scaled by r_k^2 (see
    /// [`crate::descriptor::curvature`]). Default: 2.5.
    pub curvature_threshold: f64,
    /// Curvature stage: 0 (the default) makes every vertex a candidate, the
    /// paper's schema on the whole mesh. A positive value is the side of
    /// grid cells, as a fraction of r_1: one vertex per cell is a candidate
    /// of a first pass with a looser threshold, and every vertex near its
    /// survivors one of the final pass. At 0.5 this is 1.5-20 times faster on
    /// the shared scenes, but what it finds depends on where the cells fall:
    /// turning remeshed-cow can lose an occurrence (see the README).
    pub curvature_spacing: f64,
    /// Survivors within this fraction of r_k of a better one join its
    /// instance: an occurrence claims the ball its descriptor describes.
    /// Default: 1.0.
    pub group_radius: f64,
    /// Verification: the least share of the template's surface that must
    /// land on the scene's surface when the template is placed at a point
    /// (0..1), after the pose is refined. Default: 0.85.
    pub verify_threshold: f64,
    /// When extra material (other objects) excuses the outer layers; see
    /// [`crate::descriptor::clutter`]. Default: [`ClutterPolicy::DEFAULT`].
    pub clutter: ClutterPolicy,
    /// Serial or parallel. Default: parallel.
    pub backend: Backend,
}

impl MatchOptions {
    /// The defaults.
    pub const DEFAULT: MatchOptions = MatchOptions {
        descriptor: DescriptorKind::VolumeHarmonics,
        layers: 6,
        volume_threshold: 0.12,
        harmonics_threshold: 0.8,
        curvature_threshold: 2.5,
        curvature_spacing: 0.0,
        group_radius: 1.0,
        verify_threshold: 0.85,
        clutter: ClutterPolicy::DEFAULT,
        backend: Backend::Parallel,
    };

    fn validate(&self) -> Result<()> {
        let positive = |name, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(Error::invalid_option(
                    name,
                    format!("must be a positive number, got {v}"),
                ))
            }
        };
        positive("volume threshold", self.volume_threshold)?;
        positive("harmonics threshold", self.harmonics_threshold)?;
        positive("curvature threshold", self.curvature_threshold)?;
        positive("group radius", self.group_radius)?;
        if !(self.curvature_spacing.is_finite() && self.curvature_spacing >= 0.0) {
            return Err(Error::invalid_option(
                "curvature spacing",
                format!(
                    "must be 0 or a positive number, got {}",
                    self.curvature_spacing
                ),
            ));
        }
        for (name, share) in [
            ("verify threshold", self.verify_threshold),
            ("hidden surface", self.clutter.hidden_surface),
        ] {
            if !(0.0..=1.0).contains(&share) {
                return Err(Error::invalid_option(
                    name,
                    format!("must lie in 0..=1, got {share}"),
                ));
            }
        }
        if !(1..=64).contains(&self.layers) {
            return Err(Error::invalid_option(
                "layers",
                format!("{} is outside 1..=64", self.layers),
            ));
        }
        Ok(())
    }
}

impl Default for MatchOptions {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The template as the report shows it.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct TemplateInfo {
    /// c_T: template-model coordinates, or world for a selection.
    pub center: [f64; 3],
    /// r_k.
    pub radius: f64,
}

impl TemplateInfo {
    fn of(center: Vec3, radius: f64) -> TemplateInfo {
        TemplateInfo {
            center: center.to_array(),
            radius,
        }
    }
}

/// The welded surface as the report shows it (curvature searches).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SurfaceInfo {
    /// Welded vertices: the candidate points.
    pub vertices: usize,
    /// Triangles.
    pub triangles: usize,
}

/// The grid as the report shows it.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct GridInfo {
    /// Voxels along the longest side.
    pub resolution: u32,
    /// Edge length of a voxel.
    pub voxel_size: f64,
    /// Candidate points.
    pub skin_voxels: usize,
}

/// Milliseconds per stage.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Timings {
    /// Reading and parsing the files (filled in by whoever loaded them).
    pub load: f64,
    /// Voxelizing the scene (voxel descriptors).
    pub voxelize: f64,
    /// Welding the scene's mesh and building its adjacency (curvature).
    pub surface: f64,
    /// Building the template and its descriptors.
    pub template: f64,
    /// The cascade.
    #[serde(rename = "match")]
    pub match_: f64,
    /// Verifying and grouping survivors.
    pub group: f64,
    /// All of the above, as wall-clock time: where two stages ran at once
    /// (a separate template model is voxelized beside the scene), the time
    /// they shared counts once.
    pub total: f64,
    /// The time two stages shared.
    #[serde(skip)]
    overlap: f64,
}

impl Timings {
    /// A search's stages from the clock marks before the template, the
    /// cascade and grouping and after grouping; `load` is the caller's.
    fn of_search(voxelize: f64, surface: f64, [t0, t1, t2, t3]: [f64; 4]) -> Timings {
        let mut timings = Timings {
            voxelize,
            surface,
            template: t1 - t0,
            match_: t2 - t1,
            group: t3 - t2,
            ..Timings::default()
        };
        timings.sum();
        timings
    }

    /// Recomputes `total` from the parts, less the time two of them shared.
    pub fn sum(&mut self) {
        self.total =
            self.load + self.voxelize + self.surface + self.template + self.match_ + self.group
                - self.overlap;
    }
}

/// Everything a search found, in the shape of the CLI's JSON.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MatchReport {
    /// The template's centre and outer radius.
    pub template: TemplateInfo,
    /// The occurrences, best first.
    pub instances: Vec<Instance>,
    /// Per-layer statistics of every stage.
    pub stages: Vec<LayerStats>,
    /// The voxel grid (voxel descriptors; None for curvature).
    pub grid: Option<GridInfo>,
    /// The welded surface (curvature; None for the voxel descriptors).
    pub surface: Option<SurfaceInfo>,
    /// Stage timings.
    #[serde(rename = "timings_ms")]
    pub timings: Timings,
}

/// A readable table: template, grid, every layer, the instances, timings.
impl fmt::Display for MatchReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let t = &self.template;
        writeln!(
            f,
            "template: centre ({:.4}, {:.4}, {:.4}), radius {:.4}",
            t.center[0], t.center[1], t.center[2], t.radius
        )?;
        if let Some(g) = &self.grid {
            writeln!(
                f,
                "grid: {} voxels on the longest side, voxel {:.5}, {} candidate points",
                g.resolution, g.voxel_size, g.skin_voxels
            )?;
        }
        if let Some(s) = &self.surface {
            writeln!(
                f,
                "surface: {} welded vertices (the candidate points), {} triangles",
                s.vertices, s.triangles
            )?;
        }
        writeln!(f)?;
        writeln!(
            f,
            "{:<10} {:>5} {:>8} {:>10} {:>10} {:>9}",
            "stage", "layer", "radius", "candidates", "survivors", "ms"
        )?;
        for s in &self.stages {
            writeln!(
                f,
                "{:<10} {:>5} {:>8.4} {:>10} {:>10} {:>9.1}",
                s.descriptor, s.layer, s.radius, s.candidates, s.survivors, s.ms
            )?;
        }
        writeln!(f, "\n{} instance(s):", self.instances.len())?;
        for (i, inst) in self.instances.iter().enumerate() {
            let p = inst.position;
            write!(
                f,
                "  #{:<3} at ({:.4}, {:.4}, {:.4})  distance {:.4}",
                i + 1,
                p[0],
                p[1],
                p[2],
                inst.distance,
            )?;
            if let Some(score) = inst.score {
                write!(f, "  agreement {score:.3}")?;
            }
            writeln!(f, "  support {}", inst.support)?;
        }
        let tm = &self.timings;
        write!(
            f,
            "\ntime (ms): load {:.1}, voxelize/weld {:.1}, template {:.1}, match {:.1}, group {:.1}, total {:.1}",
            tm.load,
            tm.voxelize + tm.surface,
            tm.template,
            tm.match_,
            tm.group,
            tm.total
        )
    }
}

/// Searches `scene` for every occurrence of `source`.
pub fn search(
    scene: &Scene,
    source: &TemplateSource,
    options: &MatchOptions,
    observer: &mut dyn Observer,
) -> Result<MatchReport> {
    options.validate()?;
    if options.descriptor == DescriptorKind::Curvature {
        return search_surface(scene, source, options, observer);
    }
    let build_template = || {
        let start = now_ms();
        let template = Template::new(source, scene, options.layers, options.backend);
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
    let overlap = if fresh {
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
        options
            .clutter
            .hidden_surface_for(matches!(source, TemplateSource::Selection { .. })),
        backend,
    );
    let verified: Vec<Verified> = backend
        .map_each(bests.len(), |i| {
            let v = scene.skin()[bests[i].point as usize];
            let placement = verifier.check(scene.solid(), scene.near_surface(), v);
            Verified {
                survivor: bests[i],
                score: placement.score(),
                position: scene.position(bests[i].point) + placement.offset * voxel,
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
    let mut timings = Timings::of_search(
        scene.voxelize_ms(),
        0.0,
        [joined - template_ms, t1, t2, now_ms()],
    );
    timings.overlap = overlap;
    timings.sum();
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

/// The curvature search: candidates are the scene's welded vertices;
/// the best survivor of each blob must turn the same way as the template
/// ([`MirrorTest`]), then survivors are grouped. There is no voxel
/// verification: the shapes this descriptor is for are bent, so a rigid
/// placement would not fit them.
fn search_surface(
    scene: &Scene,
    source: &TemplateSource,
    options: &MatchOptions,
    observer: &mut dyn Observer,
) -> Result<MatchReport> {
    check_surface_search(scene, source)?;
    let surface = scene.surface();
    let t0 = now_ms();
    let template = SurfaceTemplate::new(source, scene, options.layers)?;
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
    let spacing = options.curvature_spacing * radii[0];
    let (survivors, stats) = match VertexSample::of(surface, spacing) {
        Some(sample) => {
            let loose = CurvatureDescriptor::new(
                surface,
                radii,
                &gaussians,
                options.curvature_threshold * SAMPLE_SLACK,
            )
            .named("curvature-sample");
            let (near, mut stats) =
                run_cascade(&[&loose], sample.vertices, options.backend, observer)?;
            let points: Vec<Vec3> = near.iter().map(|s| surface.position(s.point)).collect();
            let candidates = sample.grid.within(surface, &points, SAMPLE_REACH * spacing);
            let (survivors, exact) =
                run_cascade(&[&curvature], candidates, options.backend, observer)?;
            stats.extend(exact);
            (survivors, stats)
        }
        None => {
            let every = surface.used_vertices().collect();
            run_cascade(&[&curvature], every, options.backend, observer)?
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
        timings,
    })
}

/// Checks, before any ball table is built, that a voxel search fits the
/// scene's memory budget: the scene's grids, a model template's own, the
/// run tables of the volume and verification balls and the cascade's state.
fn check_voxel_search(scene: &Scene, template: &Template) -> Result<()> {
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

#[cfg(test)]
mod tests {
    use super::*;
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
        assert!(t.total <= wall + 0.1, "{t:?} over {wall} ms");
        let (busiest, rest) = (t.voxelize.max(t.template), t.match_ + t.group);
        assert!(t.total >= busiest + rest - 0.1, "{t:?}");
    }
}
